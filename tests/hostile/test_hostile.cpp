// The hostile-input suite: the real `picoscan` CLI run on files and options made by a careless
// or hostile user (issue 15). Every case is one row of a table; the runner checks, for each:
//   - the exit status (an error is exit 1, never a crash or a hang),
//   - that the message names the file or option concerned,
//   - that every file present before the run is unchanged afterwards (inputs, and old
//     outputs of a failed run), by checksum,
//   - that no temporary file (*.tmp-PID-N) is left anywhere in the case's folder,
//   - that the run stays within an address-space limit (setrlimit RLIMIT_AS in the child) and
//     a time limit.
#include "picoscan/calibration.h"
#include "picoscan/cloud.h"
#include "picoscan/io.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using namespace picoscan;

namespace {

// The child's address space: generous for the small inputs here, far below what any of the
// memory bombs would need. The core's own budget is set lower, so a refusal comes first.
constexpr rlim_t kAddressSpaceLimit = rlim_t(3) << 30;
constexpr const char* kMemoryBudgetMb = "1024";

struct Outcome {
    int exit_code = -1;     // -1 when killed by a signal
    int signal = 0;         // the signal that ended it, if any
    bool timed_out = false;
    double seconds = 0;
    std::string output;     // stdout and stderr
    bool temporary_file_at_signal = false;
};

std::vector<fs::path> temporary_files(const fs::path& directory) {
    std::vector<fs::path> found;
    std::error_code error;  // files come and go while the child runs
    for (auto entry = fs::recursive_directory_iterator(directory, error); !error && entry != fs::recursive_directory_iterator();
         entry.increment(error))
        if (entry->path().filename().string().find(".tmp-") != std::string::npos) found.push_back(entry->path());
    return found;
}

// Runs picoscan with `arguments` in `directory` under the limits; with `interrupt`, sends
// that signal `interrupt_after_s` after the start.
Outcome run_cli(const std::vector<std::string>& arguments, const fs::path& directory, double timeout_s,
                int interrupt = 0, double interrupt_after_s = 0) {
    const fs::path log = directory / "picoscan-output.log";
    const std::string cli = test_support::cli_path();
    const auto start = std::chrono::steady_clock::now();
    const pid_t child = ::fork();
    if (child == 0) {
        rlimit limit{kAddressSpaceLimit, kAddressSpaceLimit};
        ::setrlimit(RLIMIT_AS, &limit);
        ::setenv("PICOSCAN_MEMORY_MB", kMemoryBudgetMb, 1);
        if (::chdir(directory.c_str()) != 0) ::_exit(127);
        const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        ::dup2(fd, 1);
        ::dup2(fd, 2);
        std::vector<char*> argv{const_cast<char*>(cli.c_str())};
        for (const std::string& argument : arguments) argv.push_back(const_cast<char*>(argument.c_str()));
        argv.push_back(nullptr);
        ::execv(cli.c_str(), argv.data());
        ::_exit(127);
    }
    Outcome outcome;
    bool interrupted = false;
    int status = 0;
    while (true) {
        const pid_t done = ::waitpid(child, &status, WNOHANG);
        outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (done == child) break;
        // The signal goes in while a temporary file exists (or at interrupt_after_s at the latest).
        if (interrupt && !interrupted &&
            (outcome.seconds >= interrupt_after_s || !temporary_files(directory).empty())) {
            outcome.temporary_file_at_signal = !temporary_files(directory).empty();
            ::kill(child, interrupt);
            interrupted = true;
        }
        if (outcome.seconds > timeout_s) {
            outcome.timed_out = true;
            ::kill(child, SIGKILL);
            ::waitpid(child, &status, 0);
            break;
        }
        std::this_thread::sleep_for(std::chrono::microseconds(interrupt && !interrupted ? 200 : 5000));
    }
    if (WIFEXITED(status)) outcome.exit_code = WEXITSTATUS(status);
    if (WIFSIGNALED(status)) outcome.signal = WTERMSIG(status);
    std::ifstream text(log);
    std::stringstream buffer;
    buffer << text.rdbuf();
    outcome.output = buffer.str();
    fs::remove(log);
    return outcome;
}

uint64_t checksum(const fs::path& path) {
    std::ifstream file(path, std::ios::binary);
    uint64_t hash = 1469598103934665603ull;  // FNV-1a
    char buffer[65536];
    while (file.read(buffer, sizeof buffer) || file.gcount() > 0) {
        for (std::streamsize i = 0; i < file.gcount(); ++i) hash = (hash ^ uint8_t(buffer[i])) * 1099511628211ull;
        if (!file) break;
    }
    return hash;
}

std::map<fs::path, uint64_t> snapshot(const fs::path& directory) {
    std::map<fs::path, uint64_t> files;
    for (const auto& entry : fs::recursive_directory_iterator(directory))
        if (std::error_code error; entry.is_regular_file(error)) files[entry.path()] = checksum(entry.path());
    return files;
}

void write_text(const fs::path& path, const std::string& text) {
    fs::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary) << text;
}

// --- inputs ---------------------------------------------------------------------------

// A small rig: the seed rig with its camera shrunk to 160x120, so simulating takes moments.
Calibration small_rig() {
    Calibration rig = seed_rig_calibration();
    const double scale = 0.1;
    rig.camera_size = {160, 120};
    rig.camera_matrix(0, 0) *= scale;
    rig.camera_matrix(1, 1) *= scale;
    rig.camera_matrix(0, 2) = (rig.camera_matrix(0, 2) + 0.5) * scale - 0.5;
    rig.camera_matrix(1, 2) = (rig.camera_matrix(1, 2) + 0.5) * scale - 0.5;
    return rig;
}

std::string calibration_text(const Calibration& rig, const fs::path& scratch) {
    write_calibration(rig, scratch.string());
    std::ifstream file(scratch);
    std::stringstream text;
    text << file.rdbuf();
    fs::remove(scratch);
    return text.str();
}

// A manifest and PNG frames of `size` for a 64x32 projector, as a capture folder; returns
// the frames' file names.
std::vector<std::string> write_capture_folder(const fs::path& folder, cv::Size size) {
    PatternOptions options;
    options.projector_size = {64, 32};
    options.shifts = 3;
    options.period_bits = 3;
    options.rows = false;
    const PatternSequence sequence = make_pattern_sequence(options);
    fs::create_directories(folder);
    write_manifest(sequence, (folder / "sequence.json").string());
    std::vector<uint8_t> png;
    cv::imencode(".png", cv::Mat(size, CV_8U, cv::Scalar(128)), png);
    std::vector<std::string> files;
    for (const Frame& frame : sequence.frames) {
        write_text(folder / frame.file, std::string(png.begin(), png.end()));
        files.push_back(frame.file);
    }
    return files;
}

// A PNG that is only a header claiming width x height (no image data).
std::string png_header_only(uint32_t width, uint32_t height) {
    std::string bytes = "\x89PNG\r\n\x1a\n";
    auto be32 = [&](uint32_t value) {
        for (int shift = 24; shift >= 0; shift -= 8) bytes.push_back(char((value >> shift) & 0xff));
    };
    be32(13);
    bytes += "IHDR";
    be32(width);
    be32(height);
    bytes += std::string("\x08\x00\x00\x00\x00", 5);  // 8 bit grey
    be32(0);                                           // CRC (not checked before the size)
    return bytes;
}

// A cloud with normals written as PLY.
void write_cloud(const fs::path& path, const std::vector<cv::Vec3f>& points, const std::vector<cv::Vec3f>& normals) {
    PointCloud cloud;
    cloud.points = points;
    cloud.normals = normals;
    write_ply(cloud, path.string());
}

// Points on a sphere of `radius` around `centre`, with outward normals.
void add_sphere(std::vector<cv::Vec3f>& points, std::vector<cv::Vec3f>& normals, cv::Vec3f centre, float radius,
                int count) {
    const double golden = CV_PI * (3 - std::sqrt(5.0));
    for (int i = 0; i < count; ++i) {
        const double z = 1 - 2 * (i + 0.5) / count, r = std::sqrt(1 - z * z), angle = golden * i;
        const cv::Vec3f normal(float(r * std::cos(angle)), float(r * std::sin(angle)), float(z));
        points.push_back(centre + radius * normal);
        normals.push_back(normal);
    }
}

// --- the table ------------------------------------------------------------------------

struct Case {
    std::string name;
    // Makes the inputs (and any old outputs) in the case's folder; returns the arguments.
    std::function<std::vector<std::string>(const fs::path& folder)> prepare{};
    int exit_code = 1;
    std::vector<std::string> message{};  // each must appear in the output (the file or option named)
    double timeout_s = 30;
    int interrupt = 0;                 // a signal to send after interrupt_after_s
    double interrupt_after_s = 0;
    std::vector<std::string> may_change{};  // files (relative) a successful run may replace
};

std::vector<Case> hostile_cases() {
    std::vector<Case> cases;
    const std::string deep_json = "{\"format\": " + std::string(100000, '[') + std::string(100000, ']') + "}";

    // Crashes and hangs.
    cases.push_back({"manifest nested 100000 levels deep", [deep_json](const fs::path& dir) {
                         write_capture_folder(dir / "caps", {160, 120});
                         write_text(dir / "caps" / "sequence.json", deep_json);
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         return std::vector<std::string>{"reconstruct", "--calibration", "rig.yml", "--captures", "caps",
                                                         "--out", "cloud.ply"};
                     },
                     1, {"caps/sequence.json", "nested more than 64 levels"}, 10});
    cases.push_back({"scene nested 100000 levels deep (JSON)", [](const fs::path& dir) {
                         write_text(dir / "scene.json", "{\"spheres\": " + std::string(100000, '[') +
                                                            std::string(100000, ']') + "}");
                         return std::vector<std::string>{"simulate", "--scene", "scene.json", "--out", "sim"};
                     },
                     1, {"scene.json", "nested more than 64 levels"}, 10});
    cases.push_back({"scene nested 300 levels deep (YAML block)", [](const fs::path& dir) {
                         std::string text = "spheres:\n";
                         for (int level = 1; level <= 300; ++level) text += std::string(level, ' ') + "- \n";
                         write_text(dir / "scene.yml", text);
                         return std::vector<std::string>{"simulate", "--scene", "scene.yml", "--out", "sim"};
                     },
                     1, {"scene.yml", "nested more than 64 levels"}, 10});
    cases.push_back({"scene nested 100000 levels deep (YAML dashes)", [](const fs::path& dir) {
                         std::string text = "spheres: ";
                         for (int level = 0; level < 100000; ++level) text += "- ";
                         write_text(dir / "scene.yml", text + "x\n");
                         return std::vector<std::string>{"simulate", "--scene", "scene.yml", "--out", "sim"};
                     },
                     1, {"scene.yml", "nested more than 64 levels"}, 10});
    cases.push_back({"scene nested 100000 levels deep (XML)", [](const fs::path& dir) {
                         std::string text = "<?xml version=\"1.0\"?>\n<opencv_storage>\n<spheres>";
                         for (int level = 0; level < 100000; ++level) text += "<_>";
                         for (int level = 0; level < 100000; ++level) text += "</_>";
                         write_text(dir / "scene.xml", text + "</spheres>\n</opencv_storage>\n");
                         return std::vector<std::string>{"simulate", "--scene", "scene.xml", "--out", "sim"};
                     },
                     1, {"scene.xml", "nested more than 64 levels"}, 10});
    cases.push_back({"calibration with an unclosed [ list (3 MB)", [](const fs::path& dir) {
                         std::string text = "%YAML:1.0\ncamera_size: [ 160,\n";
                         while (text.size() < (3u << 20)) text += "1, 2, 3, 4, 5, 6, 7, 8,\n";
                         write_text(dir / "rig.yml", text);
                         write_capture_folder(dir / "caps", {160, 120});
                         return std::vector<std::string>{"reconstruct", "--calibration", "rig.yml", "--captures", "caps",
                                                         "--out", "cloud.ply"};
                     },
                     1, {"rig.yml"}, 5});
    cases.push_back({"mesh of identical points with --spacing-mm 0", [](const fs::path& dir) {
                         write_cloud(dir / "same.ply", std::vector<cv::Vec3f>(500, cv::Vec3f(1, 2, 300)),
                                     std::vector<cv::Vec3f>(500, cv::Vec3f(0, 0, -1)));
                         return std::vector<std::string>{"mesh", "same.ply", "--out", "same.stl", "--spacing-mm", "0"};
                     },
                     1, {"point cloud", "has only 1 usable points"}});

    // Memory bombs.
    cases.push_back({"view PLY whose picoscan_grid claims 30000x30000", [](const fs::path& dir) {
                         write_text(dir / "bomb.ply",
                                    "ply\nformat ascii 1.0\ncomment picoscan_grid 30000 30000\nelement vertex 1\n"
                                    "property float x\nproperty float y\nproperty float z\nproperty int pixel\n"
                                    "end_header\n0 0 400 899999999\n");
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         return std::vector<std::string>{"clean", "bomb.ply", "--calibration", "rig.yml", "--out",
                                                         "clean.ply"};
                     },
                     1, {"bomb.ply", "picoscan_grid"}});
    cases.push_back({"stitch of a view PLY whose grid claims 10000x10000", [](const fs::path& dir) {
                         const std::string bomb =
                             "ply\nformat ascii 1.0\ncomment picoscan_grid 10000 10000\nelement vertex 1\n"
                             "property float x\nproperty float y\nproperty float z\nproperty int pixel\n"
                             "end_header\n0 0 400 5\n";
                         write_text(dir / "a.ply", bomb);
                         write_text(dir / "b.ply", bomb);
                         return std::vector<std::string>{"stitch", "a.ply", "b.ply", "--out", "merged.ply"};
                     },
                     1, {"a.ply", "picoscan_grid"}});
    cases.push_back({"calibration with projector_size 65536x65536", [](const fs::path& dir) {
                         std::string text = calibration_text(small_rig(), dir / "scratch.yml");
                         text.replace(text.find("projector_size: [ 854, 480 ]"), 28, "projector_size: [ 65536, 65536 ]");
                         write_text(dir / "rig.yml", text);
                         write_capture_folder(dir / "caps", {160, 120});
                         return std::vector<std::string>{"reconstruct", "--calibration", "rig.yml", "--captures", "caps",
                                                         "--out", "cloud.ply"};
                     },
                     1, {"rig.yml", "projector_size"}});
    cases.push_back({"simulate with camera_size 65536x65536", [](const fs::path& dir) {
                         std::string text = calibration_text(small_rig(), dir / "scratch.yml");
                         text.replace(text.find("camera_size: [ 160, 120 ]"), 25, "camera_size: [ 65536, 65536 ]");
                         write_text(dir / "rig.yml", text);
                         return std::vector<std::string>{"simulate", "--calibration", "rig.yml", "--out", "sim"};
                     },
                     1, {"rig.yml", "camera_size"}});
    cases.push_back({"simulate over the memory budget (16384x4096 camera)", [](const fs::path& dir) {
                         Calibration rig = small_rig();
                         rig.camera_size = {16384, 4096};
                         write_text(dir / "rig.yml", calibration_text(rig, dir / "scratch.yml"));
                         return std::vector<std::string>{"simulate", "--calibration", "rig.yml", "--out", "sim"};
                     },
                     1, {"memory budget"}});
    cases.push_back({"capture frame whose PNG header claims 20000x20000", [](const fs::path& dir) {
                         const std::string third = write_capture_folder(dir / "caps", {160, 120})[2];
                         write_text(dir / "caps" / third, png_header_only(20000, 20000));
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         return std::vector<std::string>{"reconstruct", "--calibration", "rig.yml", "--captures", "caps",
                                                         "--out", "cloud.ply"};
                     },
                     1, {"caps/", "20000x20000", "but"}});
    cases.push_back({"every capture frame's PNG header claims 20000x20000", [](const fs::path& dir) {
                         write_capture_folder(dir / "caps", {160, 120});
                         for (const auto& entry : fs::directory_iterator(dir / "caps"))
                             if (entry.path().extension() == ".png")
                                 write_text(entry.path(), png_header_only(20000, 20000));
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         return std::vector<std::string>{"reconstruct", "--calibration", "rig.yml", "--captures", "caps",
                                                         "--out", "cloud.ply"};
                     },
                     1, {"caps/", "20000x20000"}});
    cases.push_back({"simulate --blur 1e6", [](const fs::path&) {
                         return std::vector<std::string>{"simulate", "--blur", "1e6", "--out", "sim"};
                     },
                     1, {"--blur"}, 10});

    // Wrong answers with exit 0.
    cases.push_back({"manifest projector_width 4294968150 (wraps to 854 in 32 bits)", [](const fs::path& dir) {
                         write_capture_folder(dir / "caps", {160, 120});
                         std::ifstream file(dir / "caps" / "sequence.json");
                         std::stringstream text;
                         text << file.rdbuf();
                         std::string manifest = text.str();
                         const size_t at = manifest.find("\"projector_width\": 64");
                         manifest.replace(at, 21, "\"projector_width\": 4294967360");
                         write_text(dir / "caps" / "sequence.json", manifest);
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         return std::vector<std::string>{"reconstruct", "--calibration", "rig.yml", "--captures", "caps",
                                                         "--out", "cloud.ply"};
                     },
                     1, {"sequence.json", "4294967360", "32 bits"}});
    cases.push_back({"mesh of a cloud whose normals are all NaN", [](const fs::path& dir) {
                         std::vector<cv::Vec3f> points, normals;
                         add_sphere(points, normals, {0, 0, 400}, 30, 3000);
                         const float nan = std::numeric_limits<float>::quiet_NaN();
                         for (cv::Vec3f& normal : normals) normal = {nan, nan, nan};
                         write_cloud(dir / "cloud.ply", points, normals);
                         write_text(dir / "part.stl", "old mesh");
                         return std::vector<std::string>{"mesh", "cloud.ply", "--out", "part.stl"};
                     },
                     1, {"point cloud", "no valid normal"}});
    cases.push_back({"Poisson mesh of two separate spheres", [](const fs::path& dir) {
                         std::vector<cv::Vec3f> points, normals;
                         add_sphere(points, normals, {-60, 0, 400}, 20, 4000);
                         add_sphere(points, normals, {60, 0, 400}, 20, 4000);
                         write_cloud(dir / "two.ply", points, normals);
                         write_text(dir / "two.stl", "old mesh");
                         return std::vector<std::string>{"mesh", "two.ply", "--out", "two.stl"};
                     },
                     1, {"point cloud", "separate part"}, 60});

    cases.push_back({"capture folder holding a symlink loop", [](const fs::path& dir) {
                         write_capture_folder(dir / "caps", {160, 120});
                         fs::create_symlink("loop.png", dir / "caps" / "loop.png");
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         return std::vector<std::string>{"reconstruct", "--calibration", "rig.yml", "--captures", "caps",
                                                         "--out", "cloud.ply"};
                     },
                     1, {"caps"}});

    // Data loss: outputs checked up front, against each other and every input.
    cases.push_back({"reconstruct --out x.ply --mesh x.ply", [](const fs::path& dir) {
                         write_capture_folder(dir / "caps", {160, 120});
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         write_text(dir / "x.ply", "old cloud");
                         return std::vector<std::string>{"reconstruct", "--calibration", "rig.yml", "--captures", "caps",
                                                         "--out", "x.ply", "--mesh", "x.ply"};
                     },
                     1, {"x.ply", "overwrite"}});
    cases.push_back({"stitch whose MERGED.poses.txt is the --initial-poses file", [](const fs::path& dir) {
                         write_text(dir / "a.ply", "view a");
                         write_text(dir / "b.ply", "view b");
                         write_text(dir / "m.poses.txt", "# poses\n");
                         return std::vector<std::string>{"stitch", "a.ply", "b.ply", "--initial-poses", "m.poses.txt",
                                                         "--out", "m.ply"};
                     },
                     1, {"m.poses.txt", "overwrite"}});
    cases.push_back({"stitch whose MERGED.unmerged-NAME.ply is an input view", [](const fs::path& dir) {
                         write_text(dir / "a.ply", "view a");
                         write_text(dir / "m.unmerged-a.ply", "another view");
                         return std::vector<std::string>{"stitch", "a.ply", "m.unmerged-a.ply", "--out", "m.ply"};
                     },
                     1, {"m.unmerged-a.ply", "overwrite"}});
    cases.push_back({"patterns --out into a capture set", [](const fs::path& dir) {
                         write_capture_folder(dir / "caps", {160, 120});
                         return std::vector<std::string>{"patterns", "--projector", "64x32", "--out", "caps"};
                     },
                     1, {"caps", "did not write"}});
    {
        Case again{"patterns written twice into one folder", [](const fs::path& dir) {
                       write_text(dir / "pat" / ".picoscan-patterns", "made by picoscan patterns\n");
                       return std::vector<std::string>{"patterns", "--projector", "64x32", "--shifts", "3", "--out",
                                                       "pat"};
                   },
                   0, {"wrote"}};
        again.may_change = {"pat"};
        cases.push_back(again);
    }

    {
        Case restart{"simulate restarted in the folder of an interrupted simulate", [](const fs::path& dir) {
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         write_text(dir / "sim" / ".picoscan-simulate", "made by picoscan simulate\n");
                         write_text(dir / "sim" / "half_written.png", "partial");
                         return std::vector<std::string>{"simulate", "--calibration", "rig.yml", "--shifts", "3",
                                                         "--out", "sim"};
                     },
                     0, {"wrote"}};
        restart.may_change = {"sim"};
        cases.push_back(restart);
    }
    cases.push_back({"simulate into a folder of other files", [](const fs::path& dir) {
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         write_text(dir / "sim" / "notes.txt", "the user's notes");
                         return std::vector<std::string>{"simulate", "--calibration", "rig.yml", "--out", "sim"};
                     },
                     1, {"sim", "not empty"}});

    // Options: repeated, value that looks like an option, NaN, out of range; -h everywhere.
    cases.push_back({"repeated --out", [](const fs::path&) {
                         return std::vector<std::string>{"simulate", "--out", "a", "--out", "b"};
                     },
                     1, {"--out", "more than once"}});
    cases.push_back({"an option's value that looks like an option", [](const fs::path&) {
                         return std::vector<std::string>{"reconstruct", "--calibration", "--captures", "caps", "--out",
                                                         "x.ply"};
                     },
                     1, {"--calibration", "needs a value"}});
    cases.push_back({"--min-contrast nan", [](const fs::path& dir) {
                         write_capture_folder(dir / "caps", {160, 120});
                         write_text(dir / "rig.yml", calibration_text(small_rig(), dir / "scratch.yml"));
                         return std::vector<std::string>{"reconstruct", "--calibration", "rig.yml", "--captures", "caps",
                                                         "--out", "x.ply", "--min-contrast", "nan"};
                     },
                     1, {"--min-contrast"}});
    cases.push_back({"--period-bits 40 (would wrap to a 256 px period)", [](const fs::path&) {
                         return std::vector<std::string>{"patterns", "--projector", "854x480", "--period-bits", "40",
                                                         "--out", "pat"};
                     },
                     1, {"--period-bits"}});
    cases.push_back({"--spacing-mm -1", [](const fs::path& dir) {
                         std::vector<cv::Vec3f> points, normals;
                         add_sphere(points, normals, {0, 0, 400}, 20, 500);
                         write_cloud(dir / "cloud.ply", points, normals);
                         return std::vector<std::string>{"mesh", "cloud.ply", "--out", "m.stl", "--spacing-mm", "-1"};
                     },
                     1, {"--spacing-mm"}});
    for (const char* command : {"patterns", "simulate", "reconstruct", "manifest", "calibrate", "response", "clean",
                                "stitch", "mesh", "demo", "capture", "scan"}) {
        cases.push_back({std::string(command) + " -h", [command](const fs::path&) {
                             return std::vector<std::string>{command, "-h"};
                         },
                         0, {command}});
    }

    // Interruptions: a signal during a run leaves no temporary file behind.
    for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
        Case interrupted;
        interrupted.name = std::string("simulate interrupted by ") + strsignal(signal_number);
        interrupted.prepare = [](const fs::path&) {
            return std::vector<std::string>{"simulate", "--out", "sim", "--shifts", "3"};
        };
        interrupted.exit_code = -1;  // killed by the signal, after removing its temporary files
        interrupted.interrupt = signal_number;
        interrupted.interrupt_after_s = 20;
        interrupted.may_change = {"sim"};
        cases.push_back(interrupted);
    }
    return cases;
}

TEST(Hostile, EveryCaseIsHandled) {
    const fs::path root = test_support::make_temp_dir("hostile");
    const std::vector<Case> cases = hostile_cases();
    int handled = 0;
    for (size_t index = 0; index < cases.size(); ++index) {
        const Case& hostile = cases[index];
        SCOPED_TRACE("case " + std::to_string(index) + ": " + hostile.name);
        const fs::path folder = root / ("case" + std::to_string(index));
        fs::create_directories(folder);
        const std::vector<std::string> arguments = hostile.prepare(folder);
        const std::map<fs::path, uint64_t> before = snapshot(folder);
        const Outcome outcome =
            run_cli(arguments, folder, hostile.timeout_s, hostile.interrupt, hostile.interrupt_after_s);
        bool ok = true;
        auto expect = [&](bool condition, const std::string& what) {
            if (!condition) {
                ADD_FAILURE() << hostile.name << ": " << what << "\n--- output ---\n" << outcome.output.substr(0, 2000);
                ok = false;
            }
        };
        expect(!outcome.timed_out, "did not finish within " + std::to_string(hostile.timeout_s) + " s");
        if (hostile.interrupt) {
            expect(outcome.signal == hostile.interrupt || outcome.exit_code != 0,
                   "was not ended by the signal (exit " + std::to_string(outcome.exit_code) + ")");
        } else {
            expect(outcome.signal == 0, "crashed with signal " + std::to_string(outcome.signal));
            expect(outcome.exit_code == hostile.exit_code, "exit code " + std::to_string(outcome.exit_code) +
                                                               ", expected " + std::to_string(hostile.exit_code));
        }
        expect(outcome.output.find("filesystem error") == std::string::npos &&
                   outcome.output.find("libpng") == std::string::npos,
               "a third-party message reached the user");
        for (const std::string& part : hostile.message)
            expect(outcome.output.find(part) != std::string::npos, "the message does not name '" + part + "'");
        if (hostile.exit_code != 0 && !hostile.interrupt) {
            size_t error_lines = 0;
            std::istringstream lines(outcome.output);
            for (std::string line; std::getline(lines, line);) error_lines += line.find("error") != std::string::npos;
            expect(error_lines == 1 && outcome.output.find("picoscan ") != std::string::npos &&
                       outcome.output.find(": error: ") != std::string::npos,
                   "the error is not one line from picoscan");
        }
        if (hostile.interrupt)
            expect(outcome.temporary_file_at_signal, "no temporary file existed when the signal was sent");
        for (const auto& [path, sum] : before) {
            const std::string relative = fs::relative(path, folder).string();
            bool may_change = false;
            for (const std::string& prefix : hostile.may_change) may_change |= relative.rfind(prefix, 0) == 0;
            if (may_change) continue;
            expect(fs::exists(path) && checksum(path) == sum, relative + " was changed or removed");
        }
        const std::vector<fs::path> left = temporary_files(folder);
        expect(left.empty(), "left temporary files behind" + (left.empty() ? "" : ": " + left.front().string()));
        if (ok) ++handled;
        std::printf("[hostile] %-64s %s (%.2f s)\n", hostile.name.c_str(), ok ? "handled" : "NOT HANDLED",
                    outcome.seconds);
    }
    std::printf("[hostile] %d of %zu hostile cases tried were handled\n", handled, cases.size());
    EXPECT_EQ(handled, int(cases.size()));
}

}  // namespace
