// picoscan: the command-line front end. The table of contents of its commands; each group of
// commands lives in its own file (commands.h), and the work is done by the core's pipeline.
#include "commands.h"

#include "picoscan/error.h"

#include <dlfcn.h>
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <vector>

using namespace picoscan;
using namespace picoscan::cli;

namespace {

const char* kTypicalSession = R"(
Run 'picoscan COMMAND --help' for the options of one command.

A typical session:
  picoscan patterns --projector 854x480 --out patterns/      # show these on the projector
  picoscan simulate --out scan/                              # or capture them with a camera
  picoscan reconstruct --calibration scan/calibration.yml --captures scan/ \
                       --out part.ply --mesh part.stl
)";

std::vector<Command> builtin_commands() {
    std::vector<Command> commands;
    for (auto group : {pattern_commands, scan_commands, calibration_commands, model_commands, section_commands})
        for (Command& command : group()) commands.push_back(std::move(command));
    return commands;
}

// The commands that need a camera or a screen, from the capture module (picoscan_capture.so
// beside this program, or installed under PICOSCAN_CAPTURE_MODULE_DIR relative to it): only
// they load OpenCV's videoio and Qt. The module stays loaded, its commands' code in use. On
// failure: none, and `problem` says why.
std::vector<Command> capture_module_commands(std::string& problem) {
    std::error_code error;
    const std::filesystem::path program = std::filesystem::read_symlink("/proc/self/exe", error);
    if (error) {
        problem = "cannot find this program's file (/proc/self/exe): " + error.message();
        return {};
    }
    for (const std::filesystem::path& folder : {program.parent_path(), program.parent_path() / PICOSCAN_CAPTURE_MODULE_DIR}) {
        const std::filesystem::path module = folder / "picoscan_capture.so";
        if (!std::filesystem::exists(module)) continue;
        void* handle = dlopen(module.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!handle) {
            problem = dlerror();
            return {};
        }
        using Entry = void (*)(std::vector<Command>*);
        const auto entry = reinterpret_cast<Entry>(dlsym(handle, "picoscan_capture_commands"));
        if (!entry) {
            problem = module.string() + ": no picoscan_capture_commands in it";
            return {};
        }
        std::vector<Command> commands;
        entry(&commands);
        return commands;
    }
    problem = "picoscan_capture.so is neither beside " + program.string() + " nor in " +
              (program.parent_path() / PICOSCAN_CAPTURE_MODULE_DIR).lexically_normal().string();
    return {};
}

const Command* find_command(const std::vector<Command>& commands, const std::string& name) {
    for (const Command& candidate : commands)
        if (candidate.name == name) return &candidate;
    return nullptr;
}

void print_usage(const std::vector<Command>& commands, FILE* stream) {
    std::fprintf(stream, "picoscan - structured-light 3D scanning with a projector and a webcam\n\n"
                         "Usage: picoscan COMMAND [OPTIONS]\n\nCommands:\n");
    for (const Command& command : commands) std::fprintf(stream, "  %-13s %s\n", command.name.c_str(), command.summary.c_str());
    std::fputs(kTypicalSession, stream);
}

// The core names option fields ("decode.min_modulation"); the user typed flags.
std::string flag_for_field(const std::string& field) {
    static const std::map<std::string, std::string> flags{
        {"patterns.shifts", "--shifts"},
        {"patterns.period_bits", "--period-bits"},
        {"decode.min_contrast", "--min-contrast"},
        {"decode.min_modulation", "--min-modulation"},
        {"camera.noise_sigma_dn", "--noise"},
        {"camera.projector_gamma", "--gamma"},
        {"camera.blur_sigma_px", "--blur"},
        {"cleaning.min_quality", "--min-quality"},
        {"cleaning.max_grazing_deg", "--max-grazing-deg"},
        {"cleaning.outlier_sigma", "--outlier-sigma"},
        {"cleaning.min_cluster_points", "--min-cluster"},
        {"cleaning.volume", "--box"},
        {"background_tolerance_mm", "--background-tolerance-mm"},
        {"registration.sample_spacing_mm", "--spacing-mm"},
        {"mesh.sample_spacing_mm", "--spacing-mm"},
        {"mesh.max_hole_diameter_mm", "--max-hole-mm"},
        {"mesh.target_faces", "--target-faces"},
        {"mesh.grid.pixel_step", "--mesh-step"},
        {"mesh.max_points", "--max-points"},
        {"mesh.max_faces", "--max-faces"},
        {"mesh.fill", "--fill"},
        {"mesh.table_axis", "--turntable"},
        {"turntable.point_mm", "--turntable"},
        {"turntable.direction", "--turntable"},
        {"turntable.step_deg", "--step-deg"},
        {"preset", "--preset"},
        {"periods", "--periods"},  // manifest presets
        {"bits", "--bits"},
    };
    const auto found = flags.find(field);
    return found == flags.end() ? field : found->second;
}

// A command allocates and frees buffers of megabytes stage after stage (a view's file bytes,
// its points, the samples and search grids of registration, the merged cloud). glibc maps
// each one afresh and gives it back when freed; every 4 KB page of fresh memory then costs a
// page fault, which on the virtual machines PicoScan is benchmarked on costs as much as the
// work in it. Kept in the process (up to 32 MB each, glibc's ceiling), freed memory is used
// again; larger blocks are still mapped and given back.
void keep_freed_memory_for_reuse() {
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
}

}  // namespace

int main(int argc, char** argv) {
    keep_freed_memory_for_reuse();
    std::vector<Command> commands = builtin_commands();
    const std::string name = argc > 1 ? argv[1] : "";
    const bool listing = name.empty() || name == "--help" || name == "-h" || name == "help";
    std::string module_problem;
    if (listing || !find_command(commands, name))
        for (Command& command : capture_module_commands(module_problem)) commands.push_back(std::move(command));
    if (listing) {
        FILE* stream = name.empty() ? stderr : stdout;
        print_usage(commands, stream);
        if (!module_problem.empty()) std::fprintf(stream, "\nThe capture commands are missing: %s\n", module_problem.c_str());
        return name.empty() ? 2 : 0;
    }
    const Command* command = find_command(commands, name);
    if (!command) {
        std::fprintf(stderr, "picoscan: unknown command '%s' (see picoscan --help)%s%s\n", name.c_str(),
                     module_problem.empty() ? "" : "; the capture commands could not be loaded: ", module_problem.c_str());
        return 2;
    }
    // After a progress bar, an error starts on a fresh line.
    const char* fresh_line = isatty(STDERR_FILENO) ? "\n" : "";
    try {
        const Arguments arguments(argc, argv, 2, command->rules);
        if (arguments.has("--help")) {
            std::fputs(command->help, stdout);
            return 0;
        }
        return command->run(arguments);
    } catch (const Error& error) {
        const std::string subject = flag_for_field(error.subject());
        const std::string what = error.what();
        std::string problem = error.subject().empty() ? what : what.substr(error.subject().size() + 2);
        std::replace(problem.begin(), problem.end(), '\n', ' ');
        std::fprintf(stderr, "%spicoscan %s: error: %s%s%s\n", fresh_line, name.c_str(), subject.c_str(),
                     subject.empty() ? "" : ": ", problem.c_str());
        return 1;
    } catch (const std::exception& error) {
        // A third-party exception (CGAL's spans several lines) still makes one line.
        std::string what = error.what();
        std::replace(what.begin(), what.end(), '\n', ' ');
        std::fprintf(stderr, "%spicoscan %s: error: %s\n", fresh_line, name.c_str(), what.c_str());
        return 1;
    }
}
