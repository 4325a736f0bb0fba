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
#include "picoscan/pipeline.h"
#include "picoscan/capture_set.h"
#include "picoscan/stereo.h"
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
    std::string errors;     // stderr alone
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
    const fs::path log = directory / "picoscan-output.log", error_log = directory / "picoscan-errors.log";
    const std::string cli = test_support::cli_path();
    const auto start = std::chrono::steady_clock::now();
    const pid_t child = ::fork();
    if (child == 0) {
#ifndef __SANITIZE_ADDRESS__  // AddressSanitizer reserves terabytes of address space for its shadow
        rlimit limit{kAddressSpaceLimit, kAddressSpaceLimit};
        ::setrlimit(RLIMIT_AS, &limit);
#endif
        ::setenv("PICOSCAN_MEMORY_MB", kMemoryBudgetMb, 1);
        if (::chdir(directory.c_str()) != 0) ::_exit(127);
        ::dup2(::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644), 1);
        ::dup2(::open(error_log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644), 2);
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
        // The signal goes in while a temporary file exists (or at interrupt_after_s at the latest);
        // one look at the folder decides both, as a file seen once may be renamed by the next look.
        const bool temporary_file_now = interrupt && !interrupted && !temporary_files(directory).empty();
        if (interrupt && !interrupted && (outcome.seconds >= interrupt_after_s || temporary_file_now)) {
            outcome.temporary_file_at_signal = temporary_file_now;
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
    auto take = [](const fs::path& path) {
        std::ifstream text(path);
        std::stringstream buffer;
        buffer << text.rdbuf();
        fs::remove(path);
        return buffer.str();
    };
    outcome.errors = take(error_log);
    outcome.output = take(log) + outcome.errors;
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
    // A 64x32 projector, as in write_capture_folder.
    const double across = 64.0 / rig.projector_size.width, down = 32.0 / rig.projector_size.height;
    rig.projector_size = {64, 32};
    rig.projector_matrix(0, 0) *= across;
    rig.projector_matrix(1, 1) *= down;
    rig.projector_matrix(0, 2) = (rig.projector_matrix(0, 2) + 0.5) * across - 0.5;
    rig.projector_matrix(1, 2) = (rig.projector_matrix(1, 2) + 0.5) * down - 0.5;
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

// A binary STL of triangles given by their corners, three by three (normals left zero).
std::string binary_stl(const std::vector<cv::Vec3f>& corners) {
    std::string bytes(80, ' ');
    const auto append = [&](const void* data, size_t size) { bytes.append(static_cast<const char*>(data), size); };
    const uint32_t count = static_cast<uint32_t>(corners.size() / 3);
    append(&count, 4);
    for (size_t i = 0; i + 2 < corners.size(); i += 3) {
        const float normal[3] = {0, 0, 0};
        append(normal, sizeof normal);
        for (size_t k = i; k < i + 3; ++k) append(corners[k].val, 12);
        bytes.append(2, '\0');
    }
    return bytes;
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

// A real capture set of the small rig (the demo part, 64x32 projector, columns only), made
// once per run and copied into the cases that need frames that decode.
const fs::path& scan_fixture() {
    static const fs::path folder = [] {
        const fs::path root = test_support::make_temp_dir("hostile-fixture");
        SimulateOptions options;
        options.patterns.shifts = 3;
        options.patterns.period_bits = 3;
        options.patterns.rows = false;
        write_capture_set(simulate_captures(demo_scene(), small_rig(), options), (root / "caps").string());
        write_calibration(small_rig(), (root / "rig.yml").string());
        return root;
    }();
    return folder;
}

void copy_fixture(const fs::path& dir) {
    fs::copy(scan_fixture(), dir, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
}

std::string read_bytes(const fs::path& path) {
    std::ifstream file(path, std::ios::binary);
    std::stringstream text;
    text << file.rdbuf();
    return text.str();
}

// Flips bytes inside the first IDAT chunk's compressed data: libpng fails while decoding.
void corrupt_png_data(const fs::path& path) {
    std::string bytes = read_bytes(path);
    const size_t idat = bytes.find("IDAT");
    for (size_t i = idat + 6; i < idat + 60 && i + 4 < bytes.size(); ++i) bytes[i] = char(bytes[i] ^ 0x5a);
    write_text(path, bytes);
}

// Inserts a malformed iCCP chunk (valid CRC) after IHDR: libpng warns, and decodes the image.
void add_bad_colour_profile(const fs::path& path) {
    std::string bytes = read_bytes(path);
    const std::string data = std::string("ICC\0\0", 5) + "xx";
    std::string chunk;
    auto be32 = [&](uint32_t value) {
        for (int shift = 24; shift >= 0; shift -= 8) chunk.push_back(char((value >> shift) & 0xff));
    };
    be32(uint32_t(data.size()));
    const std::string typed = "iCCP" + data;
    uint32_t crc = 0xffffffffu;  // the PNG CRC-32
    for (const char c : typed) {
        crc ^= uint8_t(c);
        for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
    }
    chunk += typed;
    be32(crc ^ 0xffffffffu);
    bytes.insert(33, chunk);  // signature (8) + IHDR chunk (25)
    write_text(path, bytes);
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << "'" << from << "' not in the text";
    return at == std::string::npos ? text : text.replace(at, from.size(), to);
}

std::vector<std::string> reconstruct_arguments(const std::string& calibration = "rig.yml") {
    return {"reconstruct", "--calibration", calibration, "--captures", "caps", "--out", "cloud.ply"};
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
    std::vector<std::string> absent{};      // files or folders (relative) that must not exist afterwards
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
                     1, {"same.ply: has only 1 usable points"}});

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
    // Coordinates: a view's points 1e15 mm away overflowed the registration's cell keys (UBSan).
    cases.push_back({"stitch of views whose points lie 1e15 mm away", [](const fs::path& dir) {
                         for (const char* name : {"a.ply", "b.ply"}) {
                             std::string text = "ply\nformat ascii 1.0\ncomment picoscan_grid 20 20\nelement vertex 400\n"
                                                "property float x\nproperty float y\nproperty float z\nproperty int pixel\n"
                                                "end_header\n";
                             for (int pixel = 0; pixel < 400; ++pixel)
                                 text += std::to_string((pixel % 20) * 1e14) + " " + std::to_string((pixel / 20) * 1e14) +
                                         " 3e17 " + std::to_string(pixel) + "\n";
                             write_text(dir / name, text);
                         }
                         return std::vector<std::string>{"stitch", "a.ply", "b.ply", "--out", "merged.ply"};
                     },
                     1, {"a.ply", "beyond 1 km"}});
    cases.push_back({"calibration with projector_size 65536x65536", [](const fs::path& dir) {
                         std::string text = calibration_text(small_rig(), dir / "scratch.yml");
                         text.replace(text.find("projector_size: [ 64, 32 ]"), 26, "projector_size: [ 65536, 65536 ]");
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
                     1, {"cloud.ply: 3000 of 3000 points have no valid normal"}});
    cases.push_back({"Poisson mesh of two separate spheres", [](const fs::path& dir) {
                         std::vector<cv::Vec3f> points, normals;
                         add_sphere(points, normals, {-60, 0, 400}, 20, 4000);
                         add_sphere(points, normals, {60, 0, 400}, 20, 4000);
                         write_cloud(dir / "two.ply", points, normals);
                         write_text(dir / "two.stl", "old mesh");
                         return std::vector<std::string>{"mesh", "two.ply", "--out", "two.stl"};
                     },
                     1, {"two.ply: the Poisson surface covers only", "separate part"}, 60});

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
    // Outputs into a missing folder are refused before any work, whatever the extension says.
    cases.push_back({"mesh --out into a missing folder (.3mf)", [](const fs::path& dir) {
                         std::vector<cv::Vec3f> points, normals;
                         add_sphere(points, normals, {0, 0, 400}, 20, 500);
                         write_cloud(dir / "cloud.ply", points, normals);
                         return std::vector<std::string>{"mesh", "cloud.ply", "--out", "missing/part.3mf"};
                     },
                     1, {"--out", "the folder 'missing' does not exist"}, 10, 0, 0, {}, {"missing"}});
    for (const char* drawing : {"--svg", "--dxf"})
        cases.push_back({std::string("section ") + drawing + " into a missing folder", [drawing](const fs::path& dir) {
                             write_text(dir / "part.stl", binary_stl({{0, 0, 0}, {10, 0, 0}, {0, 10, 10}}));
                             const std::string name = std::string("missing/outline.") + (drawing + 2);
                             return std::vector<std::string>{"section", "part.stl", "--axis", "z", drawing, name};
                         },
                         1, {drawing, "the folder 'missing' does not exist"}, 10, 0, 0, {}, {"missing"}});
    // A manifest written over a file that is not one (a scan) would destroy it.
    cases.push_back({"manifest --out an existing scan (.ply)", [](const fs::path& dir) {
                         write_text(dir / "scan.ply", "ply\nformat ascii 1.0\nend_header\n");
                         return std::vector<std::string>{"manifest", "--preset", "opencv-graycode", "--projector",
                                                         "854x480", "--out", "scan.ply"};
                     },
                     1, {"scan.ply", "must end in .json"}, 5});
    cases.push_back({"patterns --flat-levels 1000 (an 8-bit frame has 256)", [](const fs::path&) {
                         return std::vector<std::string>{"patterns", "--projector", "854x480", "--flat-levels", "1000",
                                                         "--out", "levels"};
                     },
                     1, {"--flat-levels", "3..256"}, 5, 0, 0, {}, {"levels"}});
    cases.push_back({"stitch --step-deg without --turntable", [](const fs::path& dir) {
                         for (const char* name : {"a.ply", "b.ply"}) {
                             std::vector<cv::Vec3f> points, normals;
                             add_sphere(points, normals, {0, 0, 400}, 20, 500);
                             write_cloud(dir / name, points, normals);
                         }
                         return std::vector<std::string>{"stitch", "a.ply", "b.ply", "--out", "m.ply", "--step-deg", "45"};
                     },
                     1, {"--step-deg", "goes with --turntable"}, 5, 0, 0, {}, {"m.ply"}});
    // The same frames as the "second camera" would confirm every point: a check that checks nothing.
    cases.push_back({"reconstruct --second-captures the --captures folder again", [](const fs::path& dir) {
                         copy_fixture(dir);
                         std::vector<std::string> arguments = reconstruct_arguments();
                         for (const char* extra : {"--second-calibration", "rig.yml", "--second-captures", "./caps/"})
                             arguments.push_back(extra);
                         return arguments;
                     },
                     1, {"--second-captures", "the --captures folder again"}, 10, 0, 0, {}, {"cloud.ply"}});
    // Named before the missing --projector-screen (which a missing file made the only complaint).
    cases.push_back({"capture --camera a video file that is not there", [](const fs::path&) {
                         return std::vector<std::string>{"capture", "--camera", "missing.mp4", "--out", "cap"};
                     },
                     1, {"missing.mp4", "no such camera or video file"}, 30, 0, 0, {}, {"cap"}});
    // The open surface's voxel cells are 64-bit keys of floor(coordinate / voxel): a point at
    // 1e30 mm is refused before any cell is computed, and a tiny spacing only thins nothing.
    cases.push_back({"mesh --fill open of a cloud with a point at 1e30 mm", [](const fs::path& dir) {
                         std::vector<cv::Vec3f> points, normals;
                         add_sphere(points, normals, {0, 0, 400}, 20, 500);
                         points.push_back({1e30f, 0, 0});
                         normals.push_back({0, 0, 1});
                         write_cloud(dir / "cloud.ply", points, normals);
                         return std::vector<std::string>{"mesh", "cloud.ply", "--out", "m.stl", "--fill", "open"};
                     },
                     1, {"cloud.ply: point 500 lies 1e+30 mm from the origin, beyond 1 km"}});
    cases.push_back({"mesh --fill open --spacing-mm 1e-12", [](const fs::path& dir) {
                         std::vector<cv::Vec3f> points, normals;
                         add_sphere(points, normals, {0, 0, 400}, 20, 500);
                         write_cloud(dir / "cloud.ply", points, normals);
                         return std::vector<std::string>{"mesh", "cloud.ply", "--out", "m.stl", "--fill", "open",
                                                         "--spacing-mm", "1e-12"};
                     },
                     0, {"triangles -> m.stl"}});
    for (const char* command : {"patterns", "simulate", "reconstruct", "manifest", "calibrate", "response", "clean",
                                "stitch", "mesh", "demo", "capture", "scan"}) {
        cases.push_back({std::string(command) + " -h", [command](const fs::path&) {
                             return std::vector<std::string>{command, "-h"};
                         },
                         0, {command}});
    }


    // Third-party messages are attached to PicoScan's line, never printed first (issue 15, 4).
    cases.push_back({"a corrupt PNG frame (libpng error), a bad colour profile in another", [](const fs::path& dir) {
                         copy_fixture(dir);
                         corrupt_png_data(dir / "caps" / "004_col_gray01.png");
                         add_bad_colour_profile(dir / "caps" / "000_white.png");
                         return reconstruct_arguments();
                     },
                     1, {"caps/004_col_gray01.png", "corrupt image", "libpng error"}});
    cases.push_back({"only a bad colour profile (a libpng warning): the scan succeeds", [](const fs::path& dir) {
                         copy_fixture(dir);
                         for (const char* frame : {"000_white.png", "001_black.png", "002_col_gray00.png"})
                             add_bad_colour_profile(dir / "caps" / frame);
                         return reconstruct_arguments();
                     },
                     0, {"cloud.ply"}});

    // Errors name the right thing.
    cases.push_back({"calibration with 15 distortion coefficients", [](const fs::path& dir) {
                         copy_fixture(dir);
                         Calibration rig = small_rig();
                         rig.camera_distortion = cv::Mat::zeros(1, 14, CV_64F);
                         std::string text = calibration_text(rig, dir / "scratch.yml");
                         const size_t data = text.find("data", text.find("camera_distortion"));
                         const size_t close = text.find(']', data);
                         write_text(dir / "tilted.yml", text.substr(0, close) + ", 0.02" + text.substr(close));
                         text = read_bytes(dir / "tilted.yml");
                         write_text(dir / "tilted.yml", replaced(text, "cols: 14", "cols: 15"));
                         return reconstruct_arguments("tilted.yml");
                     },
                     1, {"tilted.yml", "'camera_distortion'"}});
    cases.push_back({"calibration whose tau_y is not zero", [](const fs::path& dir) {
                         copy_fixture(dir);
                         Calibration rig = small_rig();
                         rig.camera_distortion = cv::Mat::zeros(1, 14, CV_64F);
                         const std::string text = calibration_text(rig, dir / "scratch.yml");
                         const size_t data = text.find("data", text.find("camera_distortion"));
                         const size_t close = text.find(']', data);
                         const size_t last = text.rfind(',', close);
                         write_text(dir / "tilted.yml", text.substr(0, last + 1) + " 0.01 " + text.substr(close));
                         return reconstruct_arguments("tilted.yml");
                     },
                     1, {"tilted.yml", "'camera_distortion'", "tilted-sensor"}});
    cases.push_back({"truncated binary STL whose header begins with 'solid'", [](const fs::path& dir) {
                         std::string stl = "solid exported by a CAD tool" + std::string(52, ' ');
                         stl += std::string("\x10\x00\x00\x00", 4);  // 16 triangles declared
                         stl += std::string(3 * 50, '\0');          // 3 present
                         write_text(dir / "part.stl", stl);
                         write_text(dir / "scene.yml", "meshes:\n  - { file: part.stl }\n");
                         return std::vector<std::string>{"simulate", "--scene", "scene.yml", "--out", "sim"};
                     },
                     1, {"part.stl", "truncated or corrupt binary STL", "16 triangles"}});

    // Meshes and clouds a user may feed mesh and section (hostile inputs of the fourth sanitizer run).
    cases.push_back({"section of a binary STL with a NaN vertex (the plane was named, through NaN)", [](const fs::path& dir) {
                         write_text(dir / "part.stl", binary_stl({{0, 0, 0}, {10, 0, 0}, {0, 10, 10},
                                                                  {std::nanf(""), 0, 0}, {10, 0, 0}, {0, 10, 0}}));
                         return std::vector<std::string>{"section", "part.stl", "--axis", "z"};
                     },
                     1, {"part.stl", "vertex 3 is not a finite point"}, 10});
    cases.push_back({"section of a binary STL 1e20 mm away (it 'only grazed' the plane)", [](const fs::path& dir) {
                         write_text(dir / "part.stl", binary_stl({{1e20f, 0, 0}, {1e20f, 10, 0}, {1e20f, 0, 10}}));
                         return std::vector<std::string>{"section", "part.stl", "--axis", "z"};
                     },
                     1, {"part.stl", "vertex 0 lies 1e+20 mm from the origin, beyond 1 km"}, 10});
    cases.push_back({"Poisson mesh of 500 points on a 30 mm ball (crashed in CGAL's export)", [](const fs::path& dir) {
                         std::vector<cv::Vec3f> points, normals;
                         add_sphere(points, normals, {0, 0, 400}, 30, 500);
                         write_cloud(dir / "ball.ply", points, normals);
                         return std::vector<std::string>{"mesh", "ball.ply", "--out", "ball.stl"};
                     },
                     1, {"ball.ply: Poisson reconstruction: the surface mesher kept no facet"}, 60});

    // A manifest made for another projector than the calibration's.
    cases.push_back({"manifest projector 64x32, calibration projector 854x480", [](const fs::path& dir) {
                         copy_fixture(dir);
                         Calibration rig = small_rig();
                         rig.projector_size = {854, 480};
                         write_text(dir / "rig854.yml", calibration_text(rig, dir / "scratch.yml"));
                         return reconstruct_arguments("rig854.yml");
                     },
                     1, {"caps/sequence.json", "64x32", "rig854.yml", "854x480"}});

    // Outputs refused before any work.
    cases.push_back({"reconstruct --mesh ''", [](const fs::path& dir) {
                         copy_fixture(dir);
                         std::vector<std::string> arguments = reconstruct_arguments();
                         arguments.insert(arguments.end(), {"--mesh", ""});
                         return arguments;
                     },
                     1, {"--mesh", "must not be empty"}, 5});
    cases.push_back({"reconstruct --out with a 250-character name", [](const fs::path& dir) {
                         copy_fixture(dir);
                         std::vector<std::string> arguments = reconstruct_arguments();
                         arguments.back() = std::string(246, 'a') + ".ply";
                         return arguments;
                     },
                     1, {"--out", "250 characters long"}, 5});
    cases.push_back({"reconstruct --preview with a path longer than PATH_MAX", [](const fs::path& dir) {
                         copy_fixture(dir);
                         std::vector<std::string> arguments = reconstruct_arguments();
                         std::string deep;
                         for (int part = 0; part < 700; ++part) deep += "folder/";
                         arguments.insert(arguments.end(), {"--preview", deep + "p.png"});
                         return arguments;
                     },
                     1, {"--preview", "characters long"}, 5});
    cases.push_back({"reconstruct --mesh into a folder that does not exist", [](const fs::path& dir) {
                         copy_fixture(dir);
                         std::vector<std::string> arguments = reconstruct_arguments();
                         arguments.insert(arguments.end(), {"--mesh", "no_such_folder/part.stl"});
                         return arguments;
                     },
                     1, {"--mesh", "no_such_folder", "does not exist"}, 5});
    {
        Case scan{"scan --mesh into its own capture folder", [](const fs::path&) {
                      return std::vector<std::string>{"scan", "--camera", "virtual", "--out", "scn", "--mesh",
                                                      "scn/captures/part.stl"};
                  },
                  1, {"--mesh", "scn/captures"}, 10};
        scan.absent = {"scn"};  // refused before the capture made anything
        cases.push_back(scan);
    }

    // demo restarts in the folder of an interrupted demo; it never clears a folder it did not make.
    {
        Case restart{"demo restarted in the folder of an interrupted demo", [](const fs::path& dir) {
                         write_text(dir / "d" / "captures" / ".picoscan-demo", "made by picoscan demo\n");
                         write_text(dir / "d" / "captures" / "half_written.png", "partial");
                         return std::vector<std::string>{"demo", "--single-view", "--out", "d"};
                     },
                     -1};
        // Interrupted again once it has started writing: past the point where it could refuse.
        restart.interrupt = SIGTERM;
        restart.interrupt_after_s = 20;
        restart.may_change = {"d"};
        restart.absent = {"d/captures/half_written.png"};
        cases.push_back(restart);
    }
    cases.push_back({"demo into a captures folder it did not make", [](const fs::path& dir) {
                         write_text(dir / "d" / "captures" / "my_scan.png", "the user's image");
                         return std::vector<std::string>{"demo", "--single-view", "--out", "d"};
                     },
                     1, {"d/captures", "not made by 'picoscan demo'"}, 5});

    // A failed commit leaves the old set whole: the preview's rename (the last) meets a folder.
    cases.push_back({"reconstruct whose last output's rename fails (a folder in the way)", [](const fs::path& dir) {
                         copy_fixture(dir);
                         write_text(dir / "cloud.ply", "old cloud");
                         write_text(dir / "part.stl", "old mesh");
                         fs::create_directories(dir / "p.png");
                         std::vector<std::string> arguments = reconstruct_arguments();
                         arguments.insert(arguments.end(), {"--mesh", "part.stl", "--preview", "p.png"});
                         return arguments;
                     },
                     1, {"p.png", "old outputs were left as they were"}});

    // One malformed instance of each format docs/formats.md describes.
    cases.push_back({"formats: sequence.json without 'origin'", [](const fs::path& dir) {
                         copy_fixture(dir);
                         const std::string text = read_bytes(dir / "caps" / "sequence.json");
                         write_text(dir / "caps" / "sequence.json", replaced(text, "\"origin\"", "\"origine\""));
                         return reconstruct_arguments();
                     },
                     1, {"caps/sequence.json", "origin"}, 10});
    cases.push_back({"formats: AxisCode gray_bits 99", [](const fs::path& dir) {
                         copy_fixture(dir);
                         const std::string text = read_bytes(dir / "caps" / "sequence.json");
                         write_text(dir / "caps" / "sequence.json", replaced(text, "\"gray_bits\": 6", "\"gray_bits\": 99"));
                         return reconstruct_arguments();
                     },
                     1, {"caps/sequence.json", "gray_bits"}, 10});
    cases.push_back({"formats: frame file with a path ('../')", [](const fs::path& dir) {
                         copy_fixture(dir);
                         const std::string text = read_bytes(dir / "caps" / "sequence.json");
                         write_text(dir / "caps" / "sequence.json", replaced(text, "\"000_white.png\"", "\"../rig.yml\""));
                         return reconstruct_arguments();
                     },
                     1, {"caps/sequence.json", "frames[0].file", "plain file name"}, 10});
    cases.push_back({"formats: manifest --preset slmaster-cgc with --periods 3", [](const fs::path&) {
                         return std::vector<std::string>{"manifest", "--preset", "slmaster-cgc", "--projector", "1920x1080",
                                                         "--periods", "3", "--out", "eye.json"};
                     },
                     1, {"--periods"}, 5});
    cases.push_back({"formats: calibration XML with an unclosed element", [](const fs::path& dir) {
                         copy_fixture(dir);
                         write_calibration(small_rig(), (dir / "rig.xml").string());
                         const std::string text = read_bytes(dir / "rig.xml");
                         write_text(dir / "rig.xml", replaced(text, "</camera_size>", ""));
                         return reconstruct_arguments("rig.xml");
                     },
                     1, {"rig.xml", "camera_size"}, 10});
    cases.push_back({"formats: calibration JSON with a nested map", [](const fs::path& dir) {
                         copy_fixture(dir);
                         write_calibration(small_rig(), (dir / "rig.json").string());
                         const std::string text = read_bytes(dir / "rig.json");
                         write_text(dir / "rig.json", replaced(text, "\"camera_size\": [", "\"extra\": {\"a\": {}}, \"x\": ["));
                         return reconstruct_arguments("rig.json");
                     },
                     1, {"rig.json", "line"}, 10});
    cases.push_back({"formats: a JSON calibration is read (calibrate --out may end in .json)", [](const fs::path& dir) {
                         copy_fixture(dir);
                         write_calibration(small_rig(), (dir / "rig.json").string());
                         return reconstruct_arguments("rig.json");
                     },
                     0, {"cloud.ply"}});
    cases.push_back({"formats: SLStudio calibration.xml without Kp", [](const fs::path& dir) {
                         copy_fixture(dir);
                         write_text(dir / "calibration.xml",
                                    "<?xml version=\"1.0\"?>\n<opencv_storage>\n<Kc type_id=\"opencv-matrix\"><rows>3</rows>"
                                    "<cols>3</cols><dt>f</dt><data>250 0 80 0 250 60 0 0 1</data></Kc>\n"
                                    "<kc type_id=\"opencv-matrix\"><rows>1</rows><cols>5</cols><dt>f</dt><data>0 0 0 0 0"
                                    "</data></kc>\n<Rp type_id=\"opencv-matrix\"><rows>3</rows><cols>3</cols><dt>f</dt>"
                                    "<data>1 0 0 0 1 0 0 0 1</data></Rp>\n<frameWidth>160</frameWidth>"
                                    "<frameHeight>120</frameHeight>\n</opencv_storage>\n");
                         return reconstruct_arguments("calibration.xml");
                     },
                     1, {"calibration.xml", "Kp"}, 10});
    cases.push_back({"formats: stereo calibration without the first camera's size", [](const fs::path& dir) {
                         copy_fixture(dir);
                         StereoCalibration stereo;
                         stereo.left_size = stereo.right_size = {160, 120};
                         stereo.left_matrix = stereo.right_matrix = small_rig().camera_matrix;
                         stereo.T = {-100, 0, 0};
                         write_stereo_calibration(stereo, (dir / "stereo.yml").string());
                         const std::string text = read_bytes(dir / "stereo.yml");
                         write_text(dir / "stereo.yml", replaced(text, "camera1_size", "camera1_sise"));
                         std::vector<std::string> arguments = reconstruct_arguments("stereo.yml");
                         arguments.insert(arguments.end(), {"--second-captures", "caps"});
                         return arguments;
                     },
                     1, {"stereo.yml", "camera1_size"}, 10});
    cases.push_back({"formats: scene file with an unknown top-level key", [](const fs::path& dir) {
                         write_text(dir / "scene.yml", "cubes:\n  - { centre: [0, 0, 400] }\n");
                         return std::vector<std::string>{"simulate", "--scene", "scene.yml", "--out", "sim"};
                     },
                     1, {"scene.yml", "cubes"}, 10});
    cases.push_back({"formats: scene sphere with a negative radius", [](const fs::path& dir) {
                         write_text(dir / "scene.yml", "spheres:\n  - { centre: [0, 0, 400], radius_mm: -5 }\n");
                         return std::vector<std::string>{"simulate", "--scene", "scene.yml", "--out", "sim"};
                     },
                     1, {"scene.yml", "spheres[0]", "radius_mm"}, 10});
    cases.push_back({"formats: poses file with a pose that is not a rotation", [](const fs::path& dir) {
                         write_text(dir / "a.ply", "view a");
                         write_text(dir / "b.ply", "view b");
                         write_text(dir / "poses.txt", "a.ply\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n"
                                                        "b.ply\n2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
                         return std::vector<std::string>{"stitch", "a.ply", "b.ply", "--initial-poses", "poses.txt",
                                                         "--out", "m.ply"};
                     },
                     1, {"poses.txt", "rotation"}, 5});
    cases.push_back({"formats: view PLY with a pixel outside its grid", [](const fs::path& dir) {
                         write_text(dir / "view.ply",
                                    "ply\nformat ascii 1.0\ncomment picoscan_grid 4 4\n"
                                    "comment picoscan_camera 250 250 2 2 0\nelement vertex 2\n"
                                    "property float x\nproperty float y\nproperty float z\nproperty int pixel\n"
                                    "end_header\n0 0 400 3\n0 0 400 16\n");
                         return std::vector<std::string>{"clean", "view.ply", "--out", "clean.ply"};
                     },
                     1, {"view.ply", "pixel outside the grid"}, 5});
    cases.push_back({"formats: cloud PLY whose header claims 2^31 vertices", [](const fs::path& dir) {
                         write_text(dir / "cloud.ply",
                                    "ply\nformat binary_little_endian 1.0\nelement vertex 2147483647\n"
                                    "property float x\nproperty float y\nproperty float z\nend_header\n" +
                                        std::string(24, '\0'));
                         return std::vector<std::string>{"mesh", "cloud.ply", "--out", "m.stl"};
                     },
                     1, {"cloud.ply"}, 5});
    cases.push_back({"formats: ASCII STL with a facet of two vertices", [](const fs::path& dir) {
                         write_text(dir / "part.stl", "solid p\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                                                      "vertex 1 0 0\nendloop\nendfacet\nendsolid p\n");
                         write_text(dir / "scene.yml", "meshes:\n  - { file: part.stl }\n");
                         return std::vector<std::string>{"simulate", "--scene", "scene.yml", "--out", "sim"};
                     },
                     1, {"part.stl", "ASCII STL"}, 5});
    cases.push_back({"formats: flat levels without a level between black and white", [](const fs::path& dir) {
                         copy_fixture(dir);
                         fs::create_directories(dir / "levels");
                         fs::copy_file(dir / "caps" / "001_black.png", dir / "levels" / "level_000.png");
                         fs::copy_file(dir / "caps" / "000_white.png", dir / "levels" / "level_255.png");
                         return std::vector<std::string>{"response", "--captures", "levels", "--calibration", "rig.yml",
                                                         "--out", "corrected.yml"};
                     },
                     1, {"levels", "level_000.png, level_255.png and at least one level between"}, 5});
    cases.push_back({"formats: a corrupt flat-level image", [](const fs::path& dir) {
                         copy_fixture(dir);
                         fs::create_directories(dir / "levels");
                         fs::copy_file(dir / "caps" / "001_black.png", dir / "levels" / "level_000.png");
                         fs::copy_file(dir / "caps" / "002_col_gray00.png", dir / "levels" / "level_128.png");
                         fs::copy_file(dir / "caps" / "000_white.png", dir / "levels" / "level_255.png");
                         corrupt_png_data(dir / "levels" / "level_128.png");
                         return std::vector<std::string>{"response", "--captures", "levels", "--calibration", "rig.yml",
                                                         "--out", "corrected.yml"};
                     },
                     1, {"levels/level_128.png", "libpng"}, 5});
    cases.push_back({"formats: capture image truncated after its header", [](const fs::path& dir) {
                         copy_fixture(dir);
                         const std::string text = read_bytes(dir / "caps" / "003_col_gray00_inv.png");
                         write_text(dir / "caps" / "003_col_gray00_inv.png", text.substr(0, 60));
                         return reconstruct_arguments();
                     },
                     1, {"caps/003_col_gray00_inv.png"}, 10});

    // Interruptions: a signal during a run leaves no temporary file behind.
    for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
        Case interrupted;
        interrupted.name = std::string("simulate interrupted by ") + strsignal(signal_number);
        interrupted.prepare = [](const fs::path& dir) {
            // A 640x480 camera: rendering takes a moment, and 30 frames are written one by one.
            Calibration rig = small_rig();
            rig.camera_size = {640, 480};
            for (int row = 0; row < 2; ++row)
                for (int column = 0; column < 3; ++column) rig.camera_matrix(row, column) *= 4;
            rig.camera_matrix(0, 2) += 1.5;
            rig.camera_matrix(1, 2) += 1.5;
            write_text(dir / "rig.yml", calibration_text(rig, dir / "scratch.yml"));
            return std::vector<std::string>{"simulate", "--calibration", "rig.yml", "--rows", "--out", "sim",
                                            "--shifts", "3"};
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
        {  // third-party text only inside PicoScan's own line
            std::istringstream lines(outcome.errors);
            for (std::string line; std::getline(lines, line);)
                for (const char* third_party : {"filesystem error", "libpng", "CGAL", "OpenCV", "[ WARN", "[ERROR"})
                    if (line.find(third_party) != std::string::npos && line.rfind("picoscan", 0) != 0)
                        expect(false, "a third-party message reached the user on its own line: " + line);
        }
        for (const std::string& part : hostile.message)
            expect(outcome.output.find(part) != std::string::npos, "the message does not name '" + part + "'");
        if (hostile.exit_code != 0 && !hostile.interrupt) {
            // stderr: PicoScan's error line comes first (warnings of its own aside), and is the
            // only line that mentions an error.
            size_t error_lines = 0;
            std::string first_error_line;
            std::istringstream lines(outcome.errors);
            for (std::string line; std::getline(lines, line);)
                if (line.find("error") != std::string::npos) {
                    if (!error_lines++) first_error_line = line;
                }
            const std::string first_line = outcome.errors.substr(0, outcome.errors.find('\n'));
            expect(error_lines == 1 && first_error_line.rfind("picoscan ", 0) == 0 &&
                       first_error_line.find(": error: ") != std::string::npos &&
                       first_line.rfind("picoscan ", 0) == 0,
                   "the error is not one line from picoscan, first on stderr");
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
        for (const std::string& path : hostile.absent)
            expect(!fs::exists(folder / path), path + " exists after the run");
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
