// picoscan: the command-line front end. Argument parsing and printing only; the work is in the core.
#include "picoscan/calibration.h"
#include "picoscan/capture.h"
#include "picoscan/capture_qt.h"
#include "picoscan/capture_set.h"
#include "picoscan/clean.h"
#include "picoscan/decode.h"
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "picoscan/mesh.h"
#include "picoscan/register.h"
#include "picoscan/multi_camera.h"
#include "picoscan/patterns.h"
#include "picoscan/preview.h"
#include "picoscan/simulate.h"
#include "picoscan/triangulate.h"

#include <opencv2/imgcodecs.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace picoscan;

namespace {

const char* kUsage = R"(picoscan - structured-light 3D scanning with a projector and a webcam

Usage: picoscan COMMAND [OPTIONS]

Commands:
  patterns      write the projector patterns (PNG) and their sequence.json manifest
  simulate      render a capture set of a virtual scene with the simulated rig
  reconstruct   decode a capture set and triangulate it into a point cloud (and mesh)
  manifest      write a sequence.json describing a capture set made by another system
  calibrate     calibrate camera + projector from captures of a board in several poses
  response      measure the projector's response (gamma) and store its correction
  clean         remove stray-light noise, background and outliers from a view
  stitch        align several views of a part into one model (features, RANSAC, ICP)
  mesh          mesh a cloud: watertight Poisson, advancing front or pixel grid -> STL
  demo          simulated 360-degree turntable scan of the built-in part -> watertight STL
  screens       list the screens (find the projector's index)
  capture       project the patterns and capture them with webcams (or the virtual camera)
  scan          capture + reconstruct in one step

Run 'picoscan COMMAND --help' for the options of one command.

A typical session:
  picoscan patterns --projector 854x480 --out patterns/      # show these on the projector
  picoscan simulate --out scan/                              # or capture them with a camera
  picoscan reconstruct --calibration scan/calibration.yml --captures scan/ \
                       --out part.ply --mesh part.stl
)";

const char* kPatternsHelp = R"(picoscan patterns --projector WxH --out DIR [options]

Writes one 8-bit PNG per projector frame, named in projection order, and DIR/sequence.json.
The sequence: white, black, Gray code bits of the projector columns (each followed by its
inverse), phase-shifted sinusoids of the columns, then the same for the rows.

  --projector WxH      projector resolution in pixels, e.g. 854x480 (required)
  --shifts K           phase shifts per axis, 3..64 (default 24; more shifts average out noise)
  --period-bits N      fringe period = 2^N projector pixels (default 4, i.e. 16 px)
  --rows | --no-rows   also encode projector rows (default --rows; rows allow ray-ray triangulation)
  --calibration FILE   apply the projector response correction stored in this calibration
                       (see 'picoscan response'), so the projected fringes are truly sinusoidal
  --flat-levels N      instead, write N flat grey frames level_LLL.png from black to white, for
                       measuring the projector's response
  --out DIR            output folder (created if needed)
)";

const char* kResponseHelp = R"(picoscan response --captures DIR --calibration IN.yml --out OUT.yml

Measures the projector's response (gamma) and stores its inverse in a copy of the calibration.
Show the frames of 'picoscan patterns --flat-levels 17' on a white, matte surface and capture
each as DIR/level_LLL.png (the same names). Patterns made with 'picoscan patterns
--calibration OUT.yml' are then corrected, so few-shift scans have no fringe-periodic ripple.

  --captures DIR       the flat-frame captures (level_000.png ... level_255.png)
  --calibration FILE   the rig's calibration (not modified)
  --out FILE           the calibration with the response table added
)";

const char* kSimulateHelp = R"(picoscan simulate --out DIR [options]

Renders the capture set a real rig would record, with the seed-like rig (1600x1200 camera,
854x480 projector, 150 mm baseline, 400 mm working distance) unless --calibration is given.
Writes the images, DIR/sequence.json and the exact rig as DIR/calibration.yml.

  --out DIR            output folder (must be empty or not exist)
  --scene FILE         scene description (YAML/JSON, see docs/formats.md); default: built-in part
  --calibration FILE   rig to simulate (default: the seed-like rig)
  --shifts K, --period-bits N, --rows | --no-rows    pattern options as for 'patterns'
  --noise SIGMA        camera noise in grey levels (default 1)
  --gamma G            projector response exponent (default 1)
  --blur SIGMA         defocus blur in camera pixels (default 0.7)
  --seed N             noise seed (default 1)
)";

const char* kReconstructHelp = R"(picoscan reconstruct --calibration FILE --captures DIR --out CLOUD.ply [options]

Decodes the Gray code and phase-shift frames of a capture set (hybrid unwrapping) and
triangulates every camera pixel. Writes an organised point cloud with colour, normals and
quality, and optionally a grid mesh that does not bridge depth jumps.

  --calibration FILE   camera-projector calibration (PicoScan YAML, SLMaster caliInfo.yml or
                       SLStudio calibration.xml)
  --captures DIR       capture set folder
  --manifest FILE      sequence.json to use instead of DIR/sequence.json (for foreign sets)
  --out FILE           point cloud (.ply, binary unless --ascii)
  --mesh FILE          grid mesh too (.stl, .ply or .obj)
  --mesh-step N        join every N-th pixel only: N*N times fewer triangles (default 1)
  --preview FILE       shaded PNG preview of the scan
  --binary-only        Gray code only, ignore the phase frames (for comparison)
  --ascii              write ASCII PLY/STL instead of binary
  --min-contrast DN    white-black contrast below this is shadow (default 15)
  --min-modulation DN  fringe amplitude below this is rejected (default 4)
  --clean              remove unreliable points before writing: stray-light outliers, points seen
                       at grazing angles (> 80 deg), small disconnected clusters; prints what
                       each filter removed
  --second-calibration FILE, --second-captures DIR
                       a second camera's calibration (with the same projector) and its captures
                       of the same scan: points the second camera does not confirm (stray light,
                       interreflections, points only the first camera sees) are removed
)";

const char* kManifestHelp = R"(picoscan manifest --preset NAME --projector WxH --out FILE [options]

Writes a sequence.json that describes a capture set made by another system, so that
'picoscan reconstruct --manifest FILE' can read it in place.

  --preset opencv-graycode   OpenCV structured_light GrayCodePattern: (pattern, inverse) pairs,
                             columns then rows, then white, black. Files PREFIX<K>SUFFIX.
           --prefix P --suffix S --first-index K   (defaults: "", ".png", 1)
  --preset slstudio-gray     SLStudio Gray code: white, black, column bits without inverses
           --bits N          projected bits (default: all)
  --preset slstudio-phase-cue  SLStudio calibration sequence: 3-step fringes and a 3-step
                             one-period cue, columns then rows
           --periods N       fringe periods across the projector (default 16)
  --preset slmaster-cgc      SLMaster sinusoid + complementary Gray code
           --shifts K --periods N   (defaults 12 and 32)
  --projector WxH            the projector resolution of that system
  --out FILE                 the manifest to write
)";

const char* kCalibrateHelp = R"(picoscan calibrate --board SPEC --captures POSE_DIR... --out CALIBRATION.yml [options]

Calibrates the camera, the projector and their relative pose from captures of a flat board
held in several poses. For each pose, project the full sequence ('picoscan patterns
--rows') onto the board and capture it into its own folder. Corners are found in the white
frame; each corner's projector position comes from the decoded codes around it.

  --board SPEC         chessboard:COLSxROWS:SQUARE_MM      (inner corners, e.g. chessboard:9x6:20)
                       circles:COLSxROWS:SPACING_MM  acircles:COLSxROWS:SPACING_MM
                       charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICTIONARY]  (squares)
  --captures DIR...    one capture set per board pose (10 or more poses, tilted in different
                       directions, covering the whole view)
  --out FILE           the calibration to write (only written when calibration succeeds)
  --manifest FILE      sequence.json for every pose, for poses captured by another system
                       (e.g. 'picoscan manifest --preset slstudio-phase-cue ...')
  --max-pose-error PX  drop poses whose reprojection error exceeds this (default 1.0)
  --report FILE        an HTML report: errors per pose, residual plot, coverage, the rig in 3D

Prints the RMS reprojection errors of the camera and the projector, per pose, and advice.
)";


// Parsed "--key value" and "--flag" arguments of one command.
class Arguments {
public:
    Arguments(int argc, char** argv, int first, const std::set<std::string>& flags) {
        for (int index = first; index < argc; ++index) {
            std::string key = argv[index];
            if (key.rfind("--", 0) != 0) throw Error(key, "unexpected argument (options start with --)");
            if (key == "--help" || key == "-h" || flags.count(key)) {
                values_[key] = "";
                continue;
            }
            if (index + 1 >= argc) throw Error(key, "needs a value");
            values_[key] = argv[++index];
            all_values_[key].push_back(values_[key]);  // a repeated option adds (--camera 0 --camera 1)
            // Further values up to the next option belong to the same key (--captures A B C).
            while (index + 1 < argc && std::string(argv[index + 1]).rfind("--", 0) != 0) {
                extra_values_[key].push_back(argv[++index]);
                all_values_[key].push_back(extra_values_[key].back());
            }
        }
    }
    // Every value given for a key that takes several.
    std::vector<std::string> list(const std::string& key) const {
        used_.insert(key);
        if (!has(key)) return {};
        return all_values_.at(key);
    }
    bool has(const std::string& key) const { return values_.count(key) > 0; }
    std::string text(const std::string& key, const std::string& fallback = "") const {
        used_.insert(key);
        auto found = values_.find(key);
        return found == values_.end() ? fallback : found->second;
    }
    std::string required(const std::string& key) const {
        if (!has(key)) throw Error(key, "is required (see --help)");
        return text(key);
    }
    double number(const std::string& key, double fallback) const {
        if (!has(key)) return used_.insert(key), fallback;
        const std::string value = text(key);
        try {
            size_t end = 0;
            const double parsed = std::stod(value, &end);
            if (end != value.size()) throw std::invalid_argument(value);
            return parsed;
        } catch (const std::exception&) {
            throw Error(key, "expects a number, got '" + value + "'");
        }
    }
    int integer(const std::string& key, int fallback) const {
        const double value = number(key, fallback);
        if (!(std::abs(value) < 1e9) || value != std::floor(value)) throw Error(key, "expects a whole number");
        return int(value);
    }
    bool flag(const std::string& key) const { return used_.insert(key), has(key); }
    cv::Size size(const std::string& key) const {
        const std::string value = required(key);
        int width = 0, height = 0;
        char separator = 0, extra = 0;
        if (std::sscanf(value.c_str(), "%d%c%d%c", &width, &separator, &height, &extra) != 3 || separator != 'x')
            throw Error(key, "expects WIDTHxHEIGHT, e.g. 854x480, got '" + value + "'");
        return {width, height};
    }
    // Unknown options are mistakes (a typo would otherwise be silently ignored).
    void reject_unknown() const {
        for (const auto& [key, value] : values_)
            if (!used_.count(key)) throw Error(key, "unknown option (see --help)");
        for (const auto& [key, values] : extra_values_)
            if (!list_keys_.count(key)) throw Error(values.front(), "unexpected argument after " + key + " (it takes one value)");
    }
    void allow_several(const std::string& key) { list_keys_.insert(key); }

private:
    std::map<std::string, std::string> values_;
    std::map<std::string, std::vector<std::string>> extra_values_;
    std::map<std::string, std::vector<std::string>> all_values_;  // every value, repeats included
    std::set<std::string> list_keys_;
    mutable std::set<std::string> used_;
};

// A one-line progress bar on a terminal; silent when stderr is not one.
ProgressCallback terminal_progress() {
    if (!isatty(STDERR_FILENO)) return nullptr;
    return [](double fraction, const std::string& stage) {
        const int width = 30, filled = int(fraction * width + 0.5);
        std::fprintf(stderr, "\r%-12s [%s%s] %3d%%", stage.c_str(), std::string(filled, '#').c_str(),
                     std::string(width - filled, ' ').c_str(), int(fraction * 100 + 0.5));
        if (fraction >= 1.0) std::fprintf(stderr, "\n");
        std::fflush(stderr);
        return true;
    };
}

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

PatternOptions pattern_options(const Arguments& arguments, cv::Size projector_size) {
    PatternOptions options;
    options.projector_size = projector_size;
    options.shifts = arguments.integer("--shifts", options.shifts);
    options.period_bits = arguments.integer("--period-bits", options.period_bits);
    if (arguments.flag("--rows") && arguments.flag("--no-rows")) throw Error("--rows", "conflicts with --no-rows");
    options.rows = !arguments.flag("--no-rows");
    return options;
}

fs::path absolute_path(const std::string& path) { return fs::weakly_canonical(fs::absolute(path)); }

bool is_inside(const fs::path& path, const fs::path& directory) {
    const fs::path relative = path.lexically_relative(directory);
    return !relative.empty() && *relative.begin() != "..";
}

std::string lowercase_extension(const std::string& path) {
    std::string extension = fs::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), ::tolower);
    return extension;
}

void check_extension(const std::string& path, const std::set<std::string>& allowed, const std::string& what) {
    if (!path.empty() && !allowed.count(lowercase_extension(path)))
        throw Error(path, what + " must end in " + [&] {
            std::string list;
            for (const auto& extension : allowed) list += (list.empty() ? "" : " or ") + extension;
            return list;
        }());
}

void write_mesh_file(const Mesh& mesh, const std::string& path, Encoding encoding) {
    const std::string extension = lowercase_extension(path);
    if (extension == ".stl") write_stl(mesh, path, encoding);
    else if (extension == ".ply") write_ply(mesh, path, encoding);
    else write_obj(mesh, path);
}

std::string level_file(int level) {
    char name[32];
    std::snprintf(name, sizeof name, "level_%03d.png", level);
    return name;
}

int run_patterns(const Arguments& arguments) {
    const PatternOptions options = pattern_options(arguments, arguments.size("--projector"));
    const std::string directory = arguments.required("--out");
    const cv::Mat response = arguments.has("--calibration")
                                 ? read_calibration(arguments.text("--calibration")).projector_inverse_response
                                 : cv::Mat();
    const int flat_levels = arguments.integer("--flat-levels", 0);
    arguments.reject_unknown();
    if (flat_levels > 0) {
        std::error_code ignored;
        fs::create_directories(directory, ignored);
        for (int level : response_levels(flat_levels)) {
            std::vector<uint8_t> png;
            cv::imencode(".png", cv::Mat(options.projector_size, CV_8U, cv::Scalar(level)), png);
            write_file_atomically((fs::path(directory) / level_file(level)).string(), std::string(png.begin(), png.end()));
        }
        std::printf("wrote %d flat frames level_LLL.png to %s\n", flat_levels, directory.c_str());
        return 0;
    }
    const PatternSequence sequence = make_pattern_sequence(options);
    write_pattern_images(sequence, directory, response);
    std::printf("wrote %zu patterns (%d column bits, %d row bits, %d shifts, period %g px) and sequence.json to %s\n",
                sequence.frames.size(), sequence.columns.gray_bits, sequence.rows.gray_bits, options.shifts,
                sequence.columns.period_px, directory.c_str());
    return 0;
}

struct ReconstructRequest {
    std::string calibration, captures, manifest, cloud, mesh, preview;
    std::string second_calibration, second_captures;
    int mesh_step = 1;
    bool clean = false;
    DecodeOptions decode;
    Encoding encoding = Encoding::Binary;
};

int reconstruct(const ReconstructRequest& request) {
    const auto start = std::chrono::steady_clock::now();
    // Refuse bad output names before any work, so nothing is half done.
    check_extension(request.cloud, {".ply"}, "point cloud file");
    check_extension(request.mesh, {".stl", ".ply", ".obj"}, "mesh file");
    check_extension(request.preview, {".png"}, "preview file");
    for (const std::string& output : {request.cloud, request.mesh, request.preview}) {
        if (output.empty()) continue;
        const fs::path target = absolute_path(output);
        for (const std::string& captures : {request.captures, request.second_captures}) {
            if (captures.empty()) continue;
            const fs::path directory = absolute_path(captures);
            if (target == directory || is_inside(target, directory))
                throw Error(output, "output must not be written into the capture directory " + captures);
        }
        for (const std::string& input : {request.calibration, request.manifest, request.second_calibration})
            if (!input.empty() && target == absolute_path(input)) throw Error(output, "output would overwrite an input file");
    }
    const Calibration calibration = read_calibration(request.calibration);
    const ProgressCallback progress = terminal_progress();
    const CaptureSet captures = load_capture_set(request.captures, request.manifest, progress);
    check_camera_size(calibration, captures, request.calibration);
    const CorrespondenceMap correspondences = decode(captures, request.decode, progress);
    ScanView view = triangulate(correspondences, calibration, captures.white_colour, {}, progress);
    if (!request.second_calibration.empty()) {
        const Calibration second = read_calibration(request.second_calibration);
        const CaptureSet second_captures = load_capture_set(request.second_captures, request.manifest, progress);
        if (second_captures.images.front().size() != second.camera_size)
            throw Error(request.second_calibration, "camera_size differs from the second camera's captures");
        const CorrespondenceMap second_map = decode(second_captures, request.decode, progress);
        const int removed = reject_unconfirmed_points(view, calibration, second_map, second);
        std::printf("%d points not confirmed by the second camera removed\n", removed);
    }
    if (request.clean) {
        const CleanReport cleaned = clean_view(view, calibration.camera_matrix(0, 0));
        std::printf("cleaning removed %d points: %d grazing, %d outliers, %d with too few neighbours, %d in small "
                    "clusters\n",
                    cleaned.removed(), cleaned.by_grazing, cleaned.by_statistics, cleaned.by_radius, cleaned.by_cluster);
    }
    const PointCloud cloud = to_point_cloud(view);
    if (cloud.points.empty()) throw Error(request.captures, "no pixel could be decoded and triangulated");
    write_view_ply(view, request.cloud, request.encoding);  // keeps the pixel grid for clean and stitch
    std::printf("%zu points (%.1f %% of the camera pixels), %d fringe orders corrected -> %s\n", cloud.points.size(),
                100.0 * cloud.points.size() / view.points.total(), correspondences.order_corrections, request.cloud.c_str());
    if (!request.mesh.empty()) {
        GridMeshOptions mesh_options;
        mesh_options.pixel_step = request.mesh_step;
        const Mesh mesh = grid_mesh(view, calibration.camera_matrix(0, 0), mesh_options);
        write_mesh_file(mesh, request.mesh, request.encoding);
        std::printf("%zu triangles -> %s\n", mesh.faces.size(), request.mesh.c_str());
    }
    if (!request.preview.empty()) {
        write_preview_png(view, request.preview);
        std::printf("preview -> %s\n", request.preview.c_str());
    }
    std::printf("done in %.2f s\n", seconds_since(start));
    return 0;
}

int run_reconstruct(const Arguments& arguments) {
    ReconstructRequest request;
    request.calibration = arguments.required("--calibration");
    request.captures = arguments.required("--captures");
    request.manifest = arguments.text("--manifest");
    request.cloud = arguments.required("--out");
    request.mesh = arguments.text("--mesh");
    request.preview = arguments.text("--preview");
    request.mesh_step = arguments.integer("--mesh-step", 1);
    request.clean = arguments.flag("--clean");
    request.second_calibration = arguments.text("--second-calibration");
    request.second_captures = arguments.text("--second-captures");
    if (request.second_calibration.empty() != request.second_captures.empty())
        throw Error("--second-captures", "--second-calibration and --second-captures go together");
    if (request.mesh_step < 1 || request.mesh_step > 64) throw Error("--mesh-step", "must be 1..64");
    request.decode.binary_only = arguments.flag("--binary-only");
    request.decode.min_contrast = arguments.number("--min-contrast", request.decode.min_contrast);
    request.decode.min_modulation = arguments.number("--min-modulation", request.decode.min_modulation);
    request.encoding = arguments.flag("--ascii") ? Encoding::Ascii : Encoding::Binary;
    arguments.reject_unknown();
    return reconstruct(request);
}

SimulationOptions simulation_options(const Arguments& arguments) {
    SimulationOptions options;
    options.noise_sigma_dn = arguments.number("--noise", options.noise_sigma_dn);
    options.projector_gamma = arguments.number("--gamma", options.projector_gamma);
    options.blur_sigma_px = arguments.number("--blur", 0.7);
    options.seed = uint64_t(arguments.integer("--seed", 1));
    if (options.noise_sigma_dn < 0) throw Error("--noise", "must be >= 0");
    if (options.projector_gamma <= 0) throw Error("--gamma", "must be > 0");
    if (options.blur_sigma_px < 0) throw Error("--blur", "must be >= 0");
    return options;
}

int run_simulate(const Arguments& arguments) {
    const std::string directory = arguments.required("--out");
    const Calibration calibration =
        arguments.has("--calibration") ? read_calibration(arguments.text("--calibration")) : seed_rig_calibration();
    const Scene scene = arguments.has("--scene") ? read_scene(arguments.text("--scene")) : demo_scene();
    const PatternOptions patterns = pattern_options(arguments, calibration.projector_size);
    const SimulationOptions options = simulation_options(arguments);
    arguments.reject_unknown();
    require_empty_directory(directory);
    const CaptureSet captures =
        simulate_capture(make_pattern_sequence(patterns), calibration, scene, options, terminal_progress());
    write_capture_set(captures, directory);
    write_calibration(calibration, (fs::path(directory) / "calibration.yml").string());
    std::printf("wrote %zu simulated frames, sequence.json and calibration.yml to %s\n", captures.images.size(),
                directory.c_str());
    return 0;
}

int run_manifest(const Arguments& arguments) {
    const std::string preset = arguments.required("--preset");
    const cv::Size projector = arguments.size("--projector");
    const std::string out = arguments.required("--out");
    PatternSequence sequence;
    if (preset == "opencv-graycode") {
        sequence = make_opencv_graycode_sequence(projector, arguments.text("--prefix", ""),
                                                 arguments.text("--suffix", ".png"), arguments.integer("--first-index", 1));
    } else if (preset == "slstudio-gray") {
        sequence = make_slstudio_gray_sequence(projector, arguments.integer("--bits", gray_bits_for(projector.width)));
    } else if (preset == "slstudio-phase-cue") {
        sequence = make_slstudio_phase_cue_sequence(projector, arguments.integer("--periods", 16));
    } else if (preset == "slmaster-cgc") {
        sequence = make_slmaster_cgc_sequence(projector, arguments.integer("--shifts", 12), arguments.integer("--periods", 32));
    } else {
        throw Error("--preset", "unknown preset '" + preset + "' (opencv-graycode, slstudio-gray, slstudio-phase-cue, slmaster-cgc)");
    }
    arguments.reject_unknown();
    write_manifest(sequence, out);
    std::printf("wrote %s (%zu frames, %s)\n", out.c_str(), sequence.frames.size(), preset.c_str());
    return 0;
}

int run_response(const Arguments& arguments) {
    const std::string directory = arguments.required("--captures");
    const std::string input = arguments.required("--calibration");
    const std::string out = arguments.required("--out");
    arguments.reject_unknown();
    check_extension(out, {".yml", ".yaml"}, "calibration file (YAML)");
    if (absolute_path(out) == absolute_path(input)) throw Error(out, "would overwrite the input calibration; choose another --out");
    Calibration calibration = read_calibration(input);
    std::vector<int> levels;
    std::vector<cv::Mat> images;
    for (int level = 0; level < 256; ++level) {
        const fs::path file = fs::path(directory) / level_file(level);
        if (!fs::exists(file)) continue;
        cv::Mat image = cv::imread(file.string(), cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
        if (image.empty()) throw Error(file.string(), "unreadable or corrupt image");
        levels.push_back(level);
        images.push_back(image);
    }
    if (levels.size() < 3) throw Error(directory, "needs level_000.png, level_255.png and at least one level between");
    const ProjectorResponse response = measure_projector_response(levels, images);
    calibration.projector_inverse_response = response.inverse_lut;
    write_calibration(calibration, out);
    std::printf("projector response from %zu levels: gamma %.2f; calibration with the correction -> %s\n", levels.size(),
                response.gamma, out.c_str());
    return 0;
}

int run_calibrate(const Arguments& arguments) {
    const BoardSpec board = parse_board_spec(arguments.required("--board"));
    const std::vector<std::string> pose_directories = arguments.list("--captures");
    if (pose_directories.empty()) throw Error("--captures", "is required (see --help)");
    const std::string out = arguments.required("--out");
    const std::string manifest = arguments.text("--manifest");
    const std::string report_path = arguments.text("--report");
    check_extension(report_path, {".html", ".htm"}, "report file");
    CalibrateOptions options;
    options.max_view_rms_px = arguments.number("--max-pose-error", options.max_view_rms_px);
    arguments.reject_unknown();
    check_extension(out, {".yml", ".yaml"}, "calibration file (YAML)");
    for (const std::string& directory : pose_directories)
        if (absolute_path(out) == absolute_path(directory) || is_inside(absolute_path(out), absolute_path(directory)))
            throw Error(out, "must not be written into the capture directory " + directory);

    std::vector<PoseObservation> observations;
    for (const std::string& directory : pose_directories) {
        const CaptureSet pose = load_capture_set(directory, manifest);
        observations.push_back(observe_pose(pose, board, options));
        const PoseObservation& seen = observations.back();
        if (seen.problem.empty())
            std::printf("pose %s: %zu corners, %zu with projector points\n", directory.c_str(), seen.camera_points.size(),
                        seen.projector_points.size());
        else
            std::printf("pose %s: not used: %s\n", directory.c_str(), seen.problem.c_str());
    }
    const CalibrationReport report = calibrate_rig(observations, options, terminal_progress());
    write_calibration(report.calibration, out);
    for (const CalibrationPoseReport& pose : report.poses)
        if (pose.used)
            std::printf("  %-40s camera %.3f px, projector %.3f px\n", pose.name.c_str(), pose.camera_rms_px,
                        pose.projector_rms_px);
        else
            std::printf("  %-40s dropped: %s\n", pose.name.c_str(), pose.reason.c_str());
    const Calibration& c = report.calibration;
    std::printf("camera: f = %.2f, %.2f px, centre %.2f, %.2f; RMS %.3f px\n", c.camera_matrix(0, 0), c.camera_matrix(1, 1),
                c.camera_matrix(0, 2), c.camera_matrix(1, 2), report.camera_rms_px);
    std::printf("projector: f = %.2f, %.2f px, centre %.2f, %.2f; RMS %.3f px\n", c.projector_matrix(0, 0),
                c.projector_matrix(1, 1), c.projector_matrix(0, 2), c.projector_matrix(1, 2), report.projector_rms_px);
    std::printf("baseline %.3f mm; stereo RMS %.3f px\n", cv::norm(c.T), report.stereo_rms_px);
    for (const std::string& warning : report.warnings) std::printf("warning: %s\n", warning.c_str());
    std::printf("calibration -> %s\n", out.c_str());
    if (!report_path.empty()) {
        write_calibration_report(report, board, report_path);
        std::printf("report -> %s\n", report_path.c_str());
    }
    return 0;
}

#include "model_commands.inc"

int run_demo(const Arguments& arguments) {
    const fs::path directory = arguments.text("--out", "demo-output");
    const bool single_view = arguments.flag("--single-view");
    arguments.reject_unknown();
    if (!single_view) return run_demo_360(directory);
    const fs::path captures = directory / "captures";
    const fs::path marker = captures / ".picoscan-demo";
    if (fs::exists(captures)) {
        // Replace only the demo's own previous capture set (it carries a marker), never anything else.
        if (!fs::is_regular_file(marker))
            throw Error(captures.string(), "exists and was not made by 'picoscan demo'; choose another --out");
        fs::remove_all(captures);
    }
    const Calibration calibration = seed_rig_calibration();
    std::printf("simulating a scan of the built-in part (1600x1200 camera, 854x480 projector)...\n");
    PatternOptions patterns;
    patterns.projector_size = calibration.projector_size;
    SimulationOptions options;
    options.blur_sigma_px = 0.7;
    const CaptureSet simulated =
        simulate_capture(make_pattern_sequence(patterns), calibration, demo_scene(), options, terminal_progress());
    write_capture_set(simulated, captures.string());
    write_file_atomically(marker.string(), "made by picoscan demo; the next demo run replaces this folder\n");
    write_calibration(calibration, (directory / "calibration.yml").string());
    ReconstructRequest request;
    request.calibration = (directory / "calibration.yml").string();
    request.captures = captures.string();
    request.cloud = (directory / "cloud.ply").string();
    request.mesh = (directory / "part.stl").string();
    request.preview = (directory / "preview.png").string();
    request.mesh_step = 2;  // a 1-million-triangle STL rather than 4 million
    return reconstruct(request);
}

#include "capture_commands.inc"

}  // namespace

int main(int argc, char** argv) {
    const std::string command = argc > 1 ? argv[1] : "";
    if (command.empty() || command == "--help" || command == "-h" || command == "help") {
        std::fputs(kUsage, command.empty() ? stderr : stdout);
        return command.empty() ? 2 : 0;
    }
    struct Command {
        const char* help;
        std::function<int(const Arguments&)> run;
        std::set<std::string> flags;
    };
    // clean, stitch and mesh take their input files first, before the options.
    int first_option = 2;
    while (first_option < argc && std::string(argv[first_option]).rfind("--", 0) != 0) ++first_option;
    const std::vector<std::string> inputs(argv + std::min(2, argc), argv + first_option);
    auto one_input = [&](int (*run)(const Arguments&, const std::string&)) {
        return [&inputs, run](const Arguments& arguments) {
            if (inputs.size() != 1)
                throw Error(inputs.empty() ? std::string("input") : inputs[1], inputs.empty() ? "give one input file first (see --help)"
                                                                                                : "unexpected second input file");
            if (!fs::is_regular_file(inputs[0])) throw Error(inputs[0], "no such file");
            return run(arguments, inputs[0]);
        };
    };
    const std::map<std::string, Command> commands{
        {"clean", {kCleanHelp, one_input(run_clean), {}}},
        {"stitch", {kStitchHelp, [&inputs](const Arguments& arguments) {
             for (const std::string& input : inputs)
                 if (!fs::is_regular_file(input)) throw Error(input, "no such file");
             return run_stitch(arguments, inputs);
         }, {}}},
        {"mesh", {kMeshHelp, one_input(run_mesh), {}}},
        {"patterns", {kPatternsHelp, run_patterns, {"--rows", "--no-rows"}}},
        {"simulate", {kSimulateHelp, run_simulate, {"--rows", "--no-rows"}}},
        {"reconstruct", {kReconstructHelp, run_reconstruct, {"--binary-only", "--ascii", "--clean"}}},
        {"manifest", {kManifestHelp, run_manifest, {}}},
        {"calibrate", {kCalibrateHelp, run_calibrate, {}}},
        {"response", {kResponseHelp, run_response, {}}},
        {"demo", {kDemo360Help, run_demo, {"--single-view"}}},
        {"screens", {kScreensHelp, run_screens, {}}},
        {"capture", {kCaptureHelp, run_capture, {"--rows", "--no-rows", "--resume"}}},
        {"scan", {kScanHelp, run_scan, {"--rows", "--no-rows", "--resume", "--clean"}}},
    };
    const auto found = commands.find(command);
    if (found == commands.end()) {
        std::fprintf(stderr, "picoscan: unknown command '%s' (see picoscan --help)\n", command.c_str());
        return 2;
    }
    try {
        const bool takes_inputs = command == "clean" || command == "stitch" || command == "mesh";
        if (!takes_inputs && first_option != 2) throw Error(argv[2], "unexpected argument (options start with --)");
        Arguments arguments(argc, argv, first_option, found->second.flags);
        if (command == "calibrate") arguments.allow_several("--captures");
        if (command == "capture" || command == "scan") arguments.allow_several("--camera");
        if (arguments.has("--help") || arguments.has("-h")) {
            std::fputs(found->second.help, stdout);
            return 0;
        }
        return found->second.run(arguments);
    } catch (const std::exception& error) {
        // After a progress bar, start the error on a fresh line.
        std::fprintf(stderr, "%spicoscan %s: error: %s\n", isatty(STDERR_FILENO) ? "\n" : "", command.c_str(),
                     error.what());
        return 1;
    }
}
