// libFuzzer target: read_stl must accept any bytes, either parsing them or throwing
// picoscan::Error. Anything else escaping (or a crash, leak or UB) is a finding.
#include "fuzz_input_file.h"
#include "picoscan/error.h"
#include "picoscan/io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const picoscan::fuzz::InputFile input("stl", ".stl", data, size);
    try {
        const picoscan::Mesh mesh = picoscan::read_stl(input.path());
        picoscan::fuzz::check_mesh_invariants(mesh);
    } catch (const picoscan::Error&) {
        // Rejected cleanly.
    }
    return 0;
}
