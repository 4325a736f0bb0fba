// The picoscan commands, in groups; main.cpp puts them into one table. Each command only
// translates its options into the core's options structs, calls the pipeline (pipeline.h)
// and prints the result.
#pragma once

#include "arguments.h"

#include "picoscan/io.h"
#include "picoscan/patterns.h"
#include "picoscan/pipeline.h"

#include <functional>
#include <string>
#include <vector>

namespace picoscan::cli {

struct Command {
    std::string name;
    std::string summary;  // one line for 'picoscan --help'
    const char* help;     // 'picoscan NAME --help'
    std::function<int(const Arguments&)> run;
    ArgumentRules rules;
};

std::vector<Command> pattern_commands();      // patterns, manifest           (pattern_commands.cpp)
std::vector<Command> scan_commands();         // simulate, reconstruct        (scan_commands.cpp)
std::vector<Command> calibration_commands();  // calibrate, response          (calibration_commands.cpp)
std::vector<Command> model_commands();        // clean, stitch, mesh, demo    (model_commands.cpp)
std::vector<Command> section_commands();      // section                      (section_commands.cpp)
std::vector<Command> capture_commands();      // screens, capture, scan       (capture_commands.cpp, a module)

// Shared between the groups.
PatternOptions pattern_options(const Arguments& arguments, cv::Size projector_size);  // --shifts --period-bits --rows
SimulationOptions camera_options(const Arguments& arguments);                        // --noise --gamma --blur --seed

// Reconstructs a capture folder with the pipeline and writes the view and its products; with
// a stereo calibration, both cameras' folders binocularly.
struct ReconstructRequest {
    std::string calibration, captures, cloud, mesh, preview;
    std::string second_calibration, second_captures;
    std::string second_manifest, projector_calibration;  // binocular only
    bool refine_stereo_pose = false;                      // binocular only
    ReconstructOptions options;
    int mesh_step = 1;
    Encoding encoding = Encoding::Binary;
};
int reconstruct_and_write(const ReconstructRequest& request);
// Throws Error when an output of `request` is badly named, would overwrite an input or another
// output, or lies in a capture folder: what reconstruct_and_write checks before any work.
void check_reconstruct_outputs(const ReconstructRequest& request);

}  // namespace picoscan::cli
