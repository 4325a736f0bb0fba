// libFuzzer target: read_scene must accept any bytes, either parsing them or throwing
// picoscan::Error. Anything else escaping (or a crash, deep recursion, leak or UB) is a finding.
#include "fuzz_input_file.h"
#include "picoscan/error.h"
#include "picoscan/simulate.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const picoscan::fuzz::InputFile input("scene", ".yml", data, size);
    try {
        picoscan::read_scene(input.path());
    } catch (const picoscan::Error&) {
        // Rejected cleanly.
    }
    return 0;
}
