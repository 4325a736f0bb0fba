// picoscan calibrate and response: measuring the rig.
#include "cli_support.h"
#include "commands.h"

#include "picoscan/calibrate.h"
#include "picoscan/calibration.h"
#include "picoscan/calibration_report.h"
#include "picoscan/capture_set.h"
#include "picoscan/error.h"
#include "picoscan/response.h"
#include "picoscan/stereo.h"

#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <filesystem>

namespace fs = std::filesystem;

namespace picoscan::cli {

namespace {

const char* kResponseHelp = R"(picoscan response --captures DIR --calibration IN.yml --out OUT.yml

Measures the projector's response (gamma) and stores its inverse in a copy of the calibration.
Show the frames of 'picoscan patterns --flat-levels 17' on a white, matte surface and capture
each as DIR/level_LLL.png (the same names). Patterns made with 'picoscan patterns
--calibration OUT.yml' are then corrected, so few-shift scans have no fringe-periodic ripple.

  --captures DIR       the flat-frame captures (level_000.png ... level_255.png)
  --calibration FILE   the rig's calibration (not modified)
  --out FILE           the calibration with the response table added

Example:
  picoscan patterns --projector 854x480 --flat-levels 17 --out levels/   # show and capture these
  picoscan response --captures shots/ --calibration rig.yml --out rig-corrected.yml
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

Two cameras (binocular scanning, the projector uncalibrated):
picoscan calibrate --stereo --board SPEC --captures POSE_DIR... --second-captures POSE_DIR... --out STEREO.yml
  --stereo             calibrate the two cameras and their relative pose instead
  --second-captures DIR...  the second camera's pose folders, in the same order as --captures
                       Each pose folder holds a capture set (its white frame is used) or just one
                       image of the board; no projector is needed.
  --report FILE        an HTML report: errors per pose and camera, the epipolar error, the rig

Example (a 9x6 chessboard of 20 mm squares, one capture folder per pose):
  picoscan calibrate --board chessboard:9x6:20 --captures pose_*/ --out rig.yml --report rig.html
)";
// The pose options, checked before the boards are searched for (seconds a pose): too few poses,
// or a limit no pose can meet, would fail only at the end.
double max_pose_error(const Arguments& arguments, double fallback, size_t poses, int min_views) {
    if (poses < size_t(min_views))
        throw Error("--captures", "gives " + std::to_string(poses) + " board pose(s); at least " +
                                      std::to_string(min_views) + " are needed (10 or more advised)");
    const double limit = arguments.number("--max-pose-error", fallback);
    if (!(limit > 0)) throw Error("--max-pose-error", "must be a positive reprojection error in pixels (default 1.0)");
    return limit;
}

int run_response(const Arguments& arguments) {
    const std::string directory = arguments.required("--captures");
    const std::string input = arguments.required("--calibration");
    const std::string out = arguments.required("--out");
    arguments.reject_unknown();
    check_extension(out, {".yml", ".yaml", ".xml", ".json"}, "calibration file (YAML, XML or JSON)");
    if (absolute_path(out) == absolute_path(input)) throw Error(out, "would overwrite the input calibration; choose another --out");
    Calibration calibration = read_calibration(input);
    std::vector<int> levels;
    std::vector<cv::Mat> images;
    for (int level = 0; level < 256; ++level) {
        const fs::path file = fs::path(directory) / flat_level_file(level);
        if (!fs::exists(file)) continue;
        cv::Mat image = read_image_file(file.string(), cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
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

int run_calibrate_stereo(const Arguments& arguments) {
    const BoardSpec board = parse_board_spec(arguments.required("--board"));
    const std::vector<std::string> first = arguments.list("--captures"), second = arguments.list("--second-captures");
    if (first.empty()) throw Error("--captures", "is required (see --help)");
    if (second.size() != first.size())
        throw Error("--second-captures", "needs one folder per pose of --captures (" + std::to_string(first.size()) +
                                             "), got " + std::to_string(second.size()));
    const std::string out = arguments.required("--out");
    const std::string manifest = arguments.text("--manifest");
    const std::string report_path = arguments.text("--report");
    check_extension(report_path, {".html", ".htm"}, "report file");
    StereoCalibrateOptions options;
    options.max_view_rms_px = max_pose_error(arguments, options.max_view_rms_px, first.size(), options.min_views);
    arguments.reject_unknown();
    check_extension(out, {".yml", ".yaml", ".xml", ".json"}, "calibration file (YAML, XML or JSON)");
    std::vector<std::string> folders = first;
    folders.insert(folders.end(), second.begin(), second.end());
    for (const std::string& output : {out, report_path}) refuse_overwriting(output, {manifest}, folders);

    std::vector<StereoBoardView> views;
    for (size_t index = 0; index < first.size(); ++index)
        views.push_back({first[index], load_board_image(first[index], manifest), load_board_image(second[index], manifest)});
    const StereoCalibrationReport report = calibrate_stereo(views, board, options, terminal_progress());
    write_stereo_calibration(report.calibration, out);
    for (const StereoPoseReport& pose : report.poses)
        if (pose.used)
            std::printf("  %-40s first camera %.3f px, second camera %.3f px, epipolar %.3f px\n", pose.name.c_str(),
                        pose.left_rms_px, pose.right_rms_px, pose.epipolar_rms_px);
        else
            std::printf("  %-40s not used: %s\n", pose.name.c_str(), pose.reason.c_str());
    const StereoCalibration& c = report.calibration;
    std::printf("first camera: f = %.2f, %.2f px, centre %.2f, %.2f; RMS %.3f px\n", c.left_matrix(0, 0), c.left_matrix(1, 1),
                c.left_matrix(0, 2), c.left_matrix(1, 2), report.left_rms_px);
    std::printf("second camera: f = %.2f, %.2f px, centre %.2f, %.2f; RMS %.3f px\n", c.right_matrix(0, 0),
                c.right_matrix(1, 1), c.right_matrix(0, 2), c.right_matrix(1, 2), report.right_rms_px);
    std::printf("baseline %.3f mm; stereo RMS %.3f px; epipolar error RMS %.3f px\n", c.baseline_mm(), report.stereo_rms_px,
                report.epipolar_rms_px);
    for (const std::string& warning : report.warnings) std::printf("warning: %s\n", warning.c_str());
    std::printf("stereo calibration -> %s\n", out.c_str());
    if (!report_path.empty()) {
        write_stereo_calibration_report(report, report_path);
        std::printf("report -> %s\n", report_path.c_str());
    }
    return 0;
}

int run_calibrate(const Arguments& arguments) {
    if (arguments.flag("--stereo")) return run_calibrate_stereo(arguments);
    if (arguments.has("--second-captures")) throw Error("--second-captures", "goes with --stereo");
    const BoardSpec board = parse_board_spec(arguments.required("--board"));
    const std::vector<std::string> pose_directories = arguments.list("--captures");
    if (pose_directories.empty()) throw Error("--captures", "is required (see --help)");
    const std::string out = arguments.required("--out");
    const std::string manifest = arguments.text("--manifest");
    const std::string report_path = arguments.text("--report");
    check_extension(report_path, {".html", ".htm"}, "report file");
    CalibrateOptions options;
    options.max_view_rms_px = max_pose_error(arguments, options.max_view_rms_px, pose_directories.size(), options.min_views);
    arguments.reject_unknown();
    check_extension(out, {".yml", ".yaml", ".xml", ".json"}, "calibration file (YAML, XML or JSON)");
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

}  // namespace

std::vector<Command> calibration_commands() {
    return {
        {"calibrate", "calibrate camera + projector from captures of a board in several poses", kCalibrateHelp,
         run_calibrate, {{"--stereo"}, {"--captures", "--second-captures"}, false}},
        {"response", "measure the projector's response (gamma) and store its correction", kResponseHelp, run_response,
         {}},
    };
}

}  // namespace picoscan::cli
