// picoscan screens, capture and scan: projecting the patterns and capturing them ('scan'
// then reconstructs exactly as 'reconstruct' does).
#include "cli_support.h"
#include "commands.h"

#include "picoscan/calibration.h"
#include "picoscan/capture.h"
#include "picoscan/virtual_camera.h"
#include "picoscan/capture_qt.h"
#include "picoscan/error.h"
#include "picoscan/simulate.h"
#include "picoscan/stereo.h"

#include <algorithm>
#include <cctype>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

namespace fs = std::filesystem;

namespace picoscan::cli {

namespace {

const char* kScreensHelp = R"(picoscan screens

Lists the screens the window system has, with their index, size and position. Plug the
projector in as a second display (not mirrored), then pass its index to
'picoscan capture --projector-screen N'. Needs a display (DISPLAY).

Example:
  picoscan screens
)";

const char* kCaptureHelp = R"(picoscan capture --projector-screen N --camera SOURCE [--camera SOURCE2] --out DIR [options]

Shows every pattern full screen on the projector and captures it with one or more cameras,
frame by frame: show -> wait for the projector's latency -> drop stale camera frames -> grab
(averaging --average frames) -> write. Each frame is on disk as soon as it is taken, next to
DIR/sequence.json, so an interrupted capture (Ctrl-C, unplugged camera, power cut) keeps what
it took and '--resume' completes it. With one camera DIR is the capture set; with several,
camera K writes DIR/camera_K (K from 1).

  --projector-screen N  the projector's screen ('picoscan screens'); a full-screen window
                        without border or cursor shows each pattern pixel for pixel
  --camera SOURCE       0, 1, ...    a V4L2 webcam by index (/dev/videoN)
                        /dev/videoN  a V4L2 webcam by device path
                        virtual      the simulated rig: renders --scene lit by what the
                                     projector shows (needs no hardware; without
                                     --projector-screen no window is opened at all)
                        screen       grabs the projector's screen itself (tests the window)
                        FILE         a video file or image sequence (frame_%03d.png) standing
                                     in for a webcam
                        Repeat --camera (or list several) for cameras grabbing the same pattern.
                        Two 'virtual' cameras without --calibration simulate the two-camera
                        seed rig and write its stereo calibration to DIR/stereo.yml.
  --out DIR             the capture set (created; must be empty or a capture to resume)
  --resume              complete a capture of the same sequence already in DIR
  --calibration FILE    the rig's calibration: its projector size must equal the screen's, its
                        gamma correction ('picoscan response') is applied to the patterns,
                        and the virtual camera simulates this rig (default: the seed rig)
  --shifts K, --period-bits N, --rows | --no-rows    the patterns, as for 'patterns'
  --average N           frames averaged per pattern (default 1; 4 halves the noise)
  --latency-ms MS       wait MS after showing each pattern instead of measuring the latency
                        (by default the latency is measured first: black, then a white flash,
                        timing the first camera frame that sees it; the wait is the slowest of
                        3 flashes + 20 % + 10 ms)
  --flush N             frames dropped before each grab, 0..100 (default 5: a webcam's buffer queue)
  --resolution WxH      ask the webcam for this frame size (an error if it gives another)
  --exposure E, --gain G, --focus F, --white-balance K
                        manual webcam settings in driver units (exposure in 100 us on V4L2);
                        a setting the driver refuses is reported and left automatic
  --scene FILE, --noise SIGMA, --gamma G, --blur SIGMA, --seed N
                        the virtual camera's scene and camera (as for 'simulate')

Example, a pico projector as screen 1 and two webcams:
  picoscan screens
  picoscan capture --projector-screen 1 --camera 0 --camera 1 --average 4 \
                   --calibration rig.yml --out scan1/
)";

const char* kScanHelp = R"(picoscan scan --camera SOURCE [--camera SOURCE2] --out DIR [--projector-screen N] [options]

Capture and reconstruct in one step: captures the patterns into DIR/captures (as 'picoscan
capture'), then decodes and triangulates them into DIR/cloud.ply with DIR/preview.png (as
'picoscan reconstruct'). A real camera needs --calibration. With '--camera virtual' and no
--calibration the seed rig is simulated and written to DIR/calibration.yml.

Two cameras, any projector: with two --camera sources, both capture every pattern (into
DIR/captures/camera_1 and camera_2, each with its sequence.json) and the cloud is
reconstructed binocularly with --calibration, a stereo calibration of the two cameras
('picoscan calibrate --stereo'); the projector needs no calibration. With
'--camera virtual --camera virtual' and no --calibration, the two-camera seed rig (200 mm
apart, the projector between them) is simulated and written to DIR/stereo.yml.

  --camera SOURCE        a camera (see 'picoscan capture --help'); twice for two cameras
  --out DIR              the scan folder (captures/, cloud.ply, preview.png)
  --calibration FILE     the rig's calibration
  --mesh FILE            also write a grid mesh (.stl, .ply or .obj)
  --clean                remove unreliable points (as 'reconstruct --clean')
  --resume               complete an interrupted scan's captures, then reconstruct
  Capture options as for 'picoscan capture': --projector-screen, --shifts, --period-bits,
  --rows/--no-rows, --average, --latency-ms, --flush, --resolution, --exposure, --gain,
  --focus, --white-balance, --scene, --noise, --gamma, --blur, --seed

Example without hardware:
  picoscan scan --camera virtual --latency-ms 0 --out scan/
)";

volatile std::sig_atomic_t capture_interrupted = 0;
void on_capture_interrupt(int) { capture_interrupted = 1; }

int run_screens(const Arguments& arguments) {
    arguments.reject_unknown();
    for (const ScreenInfo& screen : list_screens())
        std::printf("%d: %dx%d at +%d+%d (%s)\n", screen.index, screen.geometry.width, screen.geometry.height,
                    screen.geometry.x, screen.geometry.y, screen.name.c_str());
    return 0;
}

// What one capture needs, opened from the command line.
struct CaptureRig {
    std::unique_ptr<PatternDisplay> display;
    std::vector<std::unique_ptr<Camera>> cameras;
    PatternSequence sequence;
    Calibration calibration;
    bool has_calibration = false;
    CaptureOptions options;
    bool measure_latency = true;
    std::vector<std::string> directories;
};

CameraSettings camera_settings(const Arguments& arguments) {
    CameraSettings settings;
    if (arguments.has("--resolution")) settings.resolution = arguments.size("--resolution");
    settings.exposure = arguments.number("--exposure", settings.exposure);
    settings.gain = arguments.number("--gain", settings.gain);
    settings.focus = arguments.number("--focus", settings.focus);
    settings.white_balance_k = arguments.number("--white-balance", settings.white_balance_k);
    settings.flush_frames = arguments.integer("--flush", settings.flush_frames);
    if (settings.flush_frames < 0 || settings.flush_frames > 100) throw Error("--flush", "must be 0..100 frames");
    return settings;
}

// Parses and checks everything, then opens the display and the cameras. Nothing is written.
// `stereo_rig`: the simulated two-camera rig the virtual cameras render (camera K of the rig for
// the K-th --camera), instead of the camera-projector calibration.
CaptureRig open_capture_rig(const Arguments& arguments, const std::vector<std::string>& directories_for_cameras,
                            const std::string& calibration_path, const SeedStereoRig* stereo_rig = nullptr) {
    CaptureRig rig;
    const std::vector<std::string> sources = arguments.list("--camera");
    if (sources.empty()) throw Error("--camera", "is required (see --help)");
    const bool all_virtual = std::all_of(sources.begin(), sources.end(), [](const std::string& s) { return s == "virtual"; });
    const bool has_virtual = std::count(sources.begin(), sources.end(), "virtual") > 0;
    // A camera given as a file or device that is not there is named first, before what else is missing.
    for (const std::string& source : sources)
        if (source != "virtual" && source != "screen") check_camera_source_exists(source);
    const bool has_screen_index = arguments.has("--projector-screen");
    const int screen_index = arguments.integer("--projector-screen", -1);
    if (!has_screen_index && !all_virtual)
        throw Error("--projector-screen", "is required with a real camera (see 'picoscan screens')");
    if (stereo_rig) {
        rig.calibration = stereo_rig->left;
        rig.has_calibration = true;
    } else if (!calibration_path.empty()) {
        rig.calibration = read_calibration(calibration_path);
        rig.has_calibration = true;
    } else if (has_virtual) {
        rig.calibration = seed_rig_calibration();
        rig.has_calibration = true;
    }
    const Scene scene = arguments.has("--scene") ? read_scene(arguments.text("--scene")) : demo_scene();
    const SimulationOptions simulation = camera_options(arguments);
    const CameraSettings settings = camera_settings(arguments);
    rig.options.frames_per_pattern = arguments.integer("--average", 1);
    if (rig.options.frames_per_pattern < 1 || rig.options.frames_per_pattern > 64) throw Error("--average", "must be 1..64");
    rig.measure_latency = !arguments.has("--latency-ms");
    rig.options.wait_ms = arguments.number("--latency-ms", 0.0);
    if (rig.options.wait_ms < 0 || rig.options.wait_ms > 60000) throw Error("--latency-ms", "must be 0..60000");
    rig.options.resume = arguments.flag("--resume");
    // The patterns are parsed before the display opens, with a stand-in size, to catch errors early.
    (void)pattern_options(arguments, {854, 480});
    arguments.reject_unknown();

    // Webcams first: a missing one is the likelier mistake, and they need no display.
    std::vector<std::unique_ptr<Camera>> webcams;
    for (const std::string& source : sources) {
        if (source == "virtual" || source == "screen") continue;
        auto camera = std::make_unique<VideoCaptureCamera>(source, settings);
        for (const std::string& warning : camera->warnings()) std::printf("warning: %s\n", warning.c_str());
        webcams.push_back(std::move(camera));
    }

    // The display: the projector window, or for the virtual camera alone a display without window.
    if (has_screen_index) rig.display = std::make_unique<ProjectorWindow>(screen_index);
    else rig.display = std::make_unique<SimulatedDisplay>(rig.calibration.projector_size);
    const cv::Size projector = rig.display->size();
    if (rig.has_calibration && rig.calibration.projector_size != projector)
        throw Error(calibration_path.empty() ? "--projector-screen" : calibration_path,
                    "the calibration's projector is " + std::to_string(rig.calibration.projector_size.width) + "x" +
                        std::to_string(rig.calibration.projector_size.height) + " but screen " +
                        std::to_string(screen_index) + " is " + std::to_string(projector.width) + "x" +
                        std::to_string(projector.height) + " (is it the projector's screen, at its native resolution?)");
    rig.sequence = make_pattern_sequence(pattern_options(arguments, projector));
    if (rig.has_calibration) rig.options.projector_inverse_response = rig.calibration.projector_inverse_response;
    rig.directories = directories_for_cameras;
    check_capture_folders(rig.sequence, rig.directories, rig.options.resume);

    size_t next_webcam = 0;
    for (const std::string& source : sources) {
        if (source == "virtual" && stereo_rig && !rig.cameras.empty()) {
            // The second camera of the rig sees the scene from its own frame, with its own noise.
            cv::Matx44d left_to_right = cv::Matx44d::eye();
            for (int r = 0; r < 3; ++r) {
                for (int c = 0; c < 3; ++c) left_to_right(r, c) = stereo_rig->stereo.R(r, c);
                left_to_right(r, 3) = stereo_rig->stereo.T[r];
            }
            SimulationOptions second = simulation;
            second.seed = simulation.seed + 1;
            rig.cameras.push_back(std::make_unique<VirtualCamera>(stereo_rig->right, transformed(scene, left_to_right), second,
                                                                  *rig.display));
        } else if (source == "virtual") {
            rig.cameras.push_back(std::make_unique<VirtualCamera>(rig.calibration, scene, simulation, *rig.display));
        } else if (source == "screen") {
            if (!has_screen_index) throw Error("--camera screen", "needs --projector-screen");
            rig.cameras.push_back(std::make_unique<ScreenCamera>(screen_index));
        } else {
            rig.cameras.push_back(std::move(webcams[next_webcam++]));
        }
    }
    return rig;
}

std::vector<std::string> capture_directories(const std::string& out, size_t cameras) {
    if (cameras == 1) return {out};
    std::vector<std::string> directories;
    for (size_t index = 1; index <= cameras; ++index)
        directories.push_back((fs::path(out) / ("camera_" + std::to_string(index))).string());
    return directories;
}

// Runs the capture: latency measurement unless given, then the sequence.
void run_capture_rig(CaptureRig& rig) {
    std::signal(SIGINT, on_capture_interrupt);
    std::signal(SIGTERM, on_capture_interrupt);
    if (rig.measure_latency) {
        const LatencyMeasurement latency = measure_latency(*rig.display, *rig.cameras.front());
        rig.options.wait_ms = latency.recommended_wait_ms();
        std::printf("latency of %s: flashes seen after", rig.cameras.front()->name().c_str());
        for (double trial : latency.trials_ms) std::printf(" %.0f", trial);
        std::printf(" ms (black %.1f, white %.1f); waiting %.0f ms per pattern\n", latency.black_level_dn,
                    latency.white_level_dn, rig.options.wait_ms);
    }
    const ProgressCallback bar = terminal_progress();
    const ProgressCallback progress = [bar](double fraction, const std::string& stage) {
        if (capture_interrupted) return false;
        return bar ? bar(fraction, stage) : true;
    };
    std::vector<Camera*> cameras;
    for (auto& camera : rig.cameras) cameras.push_back(camera.get());
    const CaptureReport report = capture_sequence(rig.sequence, *rig.display, cameras, rig.directories, rig.options, progress);
    std::printf("captured %d frames", report.captured);
    if (report.already_present > 0) std::printf(" (%d were already there)", report.already_present);
    std::printf(" of %zu with %zu camera%s -> ", rig.sequence.frames.size(), cameras.size(), cameras.size() == 1 ? "" : "s");
    for (size_t index = 0; index < rig.directories.size(); ++index)
        std::printf("%s%s", index ? ", " : "", rig.directories[index].c_str());
    std::printf("\n");
}

int run_capture(const Arguments& arguments) {
    const std::string out = arguments.required("--out");
    const size_t camera_count = arguments.list("--camera").size();
    // Two virtual cameras without a calibration: the two-camera seed rig, its stereo
    // calibration written beside the captures for 'reconstruct'.
    std::optional<SeedStereoRig> seed;
    if (arguments.list("--camera") == std::vector<std::string>{"virtual", "virtual"} && !arguments.has("--calibration"))
        seed = seed_stereo_rig();
    CaptureRig rig = open_capture_rig(arguments, capture_directories(out, std::max<size_t>(camera_count, 1)),
                                      arguments.text("--calibration"), seed ? &*seed : nullptr);
    if (seed) {
        const std::string stereo = (fs::path(out) / "stereo.yml").string();
        if (!fs::exists(stereo)) write_stereo_calibration(seed->stereo, stereo);
        std::printf("two-camera seed rig -> %s\n", stereo.c_str());
    }
    run_capture_rig(rig);
    return 0;
}

// scan with two cameras: both capture, then the binocular reconstruction.
int run_stereo_scan(const Arguments& arguments, const fs::path& out, ReconstructRequest request) {
    const std::vector<std::string> sources = arguments.list("--camera");
    if (sources.size() != 2) throw Error("--camera", "scan takes one camera, or two for a binocular scan");
    const bool both_virtual = sources == std::vector<std::string>{"virtual", "virtual"};
    const std::vector<std::string> directories = capture_directories((out / "captures").string(), 2);
    request.captures = directories[0];
    request.second_captures = directories[1];
    std::optional<SeedStereoRig> seed;
    if (request.calibration.empty()) {
        if (!both_virtual)
            throw Error("--calibration", "is required with real cameras: the two cameras' stereo calibration "
                                         "(see 'picoscan calibrate --stereo')");
        seed = seed_stereo_rig();
        request.calibration = (out / "stereo.yml").string();
        if (fs::exists(request.calibration) && !arguments.flag("--resume"))
            throw Error(request.calibration, "exists; pass it as --calibration or choose another --out");
    } else {
        if (calibration_kind(request.calibration) != CalibrationKind::Stereo)
            throw Error("--calibration", request.calibration + " is a camera-projector calibration; two cameras need their "
                                                               "stereo calibration (see 'picoscan calibrate --stereo')");
        if (std::count(sources.begin(), sources.end(), "virtual") > 0)
            throw Error("--camera virtual", "simulates the seed rig: leave out --calibration for two virtual cameras");
        (void)read_stereo_calibration(request.calibration);  // a bad file is refused before capturing
    }
    // The outputs are checked before the capture, not after it.
    try {
        check_reconstruct_outputs(request);
    } catch (const Error& error) {
        throw Error("--mesh", error.what());
    }
    CaptureRig rig = open_capture_rig(arguments, directories, "", seed ? &*seed : nullptr);
    if (seed && !fs::exists(request.calibration)) {
        fs::create_directories(out);
        write_stereo_calibration(seed->stereo, request.calibration);
    }
    run_capture_rig(rig);
    return reconstruct_and_write(request);
}

int run_scan(const Arguments& arguments) {
    const fs::path out = arguments.required("--out");
    ReconstructRequest request;
    request.captures = (out / "captures").string();
    request.cloud = (out / "cloud.ply").string();
    request.preview = (out / "preview.png").string();
    request.mesh = arguments.text("--mesh");
    check_extension(request.mesh, {".stl", ".ply", ".obj"}, "mesh file");
    request.mesh_step = 1;
    request.options.clean = arguments.flag("--clean");
    request.calibration = arguments.text("--calibration");
    if (arguments.list("--camera").size() > 1) return run_stereo_scan(arguments, out, request);
    const bool write_seed_rig = request.calibration.empty();
    if (write_seed_rig) {
        if (arguments.list("--camera") != std::vector<std::string>{"virtual"})
            throw Error("--calibration", "is required with a real camera (see 'picoscan calibrate')");
        request.calibration = (out / "calibration.yml").string();
        if (fs::exists(request.calibration) && !arguments.flag("--resume"))
            throw Error(request.calibration, "exists; pass it as --calibration or choose another --out");
    }
    // The outputs are checked before the capture, not after it.
    try {
        check_reconstruct_outputs(request);
    } catch (const Error& error) {
        throw Error("--mesh", error.what());
    }
    CaptureRig rig = open_capture_rig(arguments, {request.captures}, write_seed_rig ? "" : request.calibration);
    if (write_seed_rig && !fs::exists(request.calibration)) {
        fs::create_directories(out);
        write_calibration(rig.calibration, request.calibration);
    }
    run_capture_rig(rig);
    return reconstruct_and_write(request);
}

}  // namespace

std::vector<Command> capture_commands() {
    return {
        {"screens", "list the screens (find the projector's index)", kScreensHelp, run_screens, {}},
        {"capture", "project the patterns and capture them with webcams (or the virtual camera)", kCaptureHelp,
         run_capture, {{"--rows", "--no-rows", "--resume"}, {"--camera"}, false}},
        {"scan", "capture + reconstruct in one step", kScanHelp, run_scan,
         {{"--rows", "--no-rows", "--resume", "--clean"}, {"--camera"}, false}},
    };
}

}  // namespace picoscan::cli

// The capture module's entry point (picoscan_capture.so): main.cpp loads the module and calls
// this only for these commands, so the others never load videoio and Qt.
extern "C" __attribute__((visibility("default"))) void picoscan_capture_commands(std::vector<picoscan::cli::Command>* commands) {
    *commands = picoscan::cli::capture_commands();
}
