// libFuzzer target: read_poses must accept any bytes, either parsing them or throwing
// picoscan::Error; every pose it returns is a finite rigid transform.
#include "fuzz_input_file.h"
#include "picoscan/error.h"
#include "picoscan/io.h"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const picoscan::fuzz::InputFile input("poses", ".txt", data, size);
    try {
        for (const picoscan::ViewPose& view : picoscan::read_poses(input.path())) {
            const cv::Matx44d& pose = view.pose;
            for (int i = 0; i < 16; ++i)
                if (!std::isfinite(pose.val[i])) std::abort();
            if (pose(3, 3) != 1) std::abort();
        }
    } catch (const picoscan::Error&) {
        // Rejected cleanly.
    }
    return 0;
}
