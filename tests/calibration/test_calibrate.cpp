// Calibration of the simulated seed-like rig from simulated board poses, and its bad input.
#include "picoscan/board.h"
#include "picoscan/calibrate.h"
#include "picoscan/calibration.h"
#include "picoscan/decode.h"
#include "picoscan/error.h"
#include "picoscan/fit.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "picoscan/triangulate.h"

#include <gtest/gtest.h>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;

cv::Matx33d rotation_deg(double about_x, double about_y, double about_z) {
    cv::Mat matrix;
    cv::Rodrigues(cv::Vec3d(about_x, 0, 0) * (kPi / 180), matrix);
    cv::Matx33d rx(matrix);
    cv::Rodrigues(cv::Vec3d(0, about_y, 0) * (kPi / 180), matrix);
    cv::Matx33d ry(matrix);
    cv::Rodrigues(cv::Vec3d(0, 0, about_z) * (kPi / 180), matrix);
    return cv::Matx33d(matrix) * ry * rx;
}

// A 9x6-corner board of 18 mm squares centred at `centre`, tilted as given.
CalibrationBoard board_at(const cv::Vec3d& centre, double about_x, double about_y, double about_z) {
    CalibrationBoard board;
    board.inner_corners = {9, 6};
    board.square_mm = 18;
    board.margin_mm = 12;
    board.rotation = rotation_deg(about_x, about_y, about_z);
    const cv::Vec3d middle(4 * 18.0, 2.5 * 18.0, 0);
    board.translation = centre - board.rotation * middle;
    return board;
}

BoardSpec board_spec() { return parse_board_spec("chessboard:9x6:18"); }

PatternSequence calibration_sequence(const Calibration& rig) {
    PatternOptions options;
    options.projector_size = rig.projector_size;
    options.shifts = 8;  // plenty for corners: each homography averages hundreds of pixels
    return make_pattern_sequence(options);
}

SimulationOptions camera_noise() {
    SimulationOptions options;
    options.noise_sigma_dn = 1.0;
    options.blur_sigma_px = 0.7;
    return options;
}

PoseObservation observe(const Calibration& rig, const CalibrationBoard& board, const std::string& name, uint64_t seed) {
    Scene scene;
    scene.boards.push_back(board);
    SimulationOptions options = camera_noise();
    options.seed = seed;
    CaptureSet pose = simulate_capture(calibration_sequence(rig), rig, scene, options);
    pose.directory = name;
    return observe_pose(pose, board_spec());
}

// Twelve poses tilted up to ~30 degrees in different directions, 360..440 mm away.
std::vector<CalibrationBoard> rehearsal_poses() {
    return {board_at({0, 0, 400}, 0, 0, 0),           board_at({-30, -20, 380}, 25, -20, 5),
            board_at({30, -20, 380}, 25, 20, -5),     board_at({-30, 20, 420}, -25, -20, 10),
            board_at({30, 20, 420}, -25, 20, -10),    board_at({0, -25, 360}, 30, 0, 0),
            board_at({0, 25, 440}, -30, 0, 0),        board_at({-40, 0, 400}, 0, -30, 0),
            board_at({40, 0, 400}, 0, 30, 0),         board_at({0, 0, 370}, 15, 15, 30),
            board_at({10, 5, 430}, -15, -15, -30),    board_at({-10, -5, 390}, 20, -25, 15)};
}

double angle_between_deg(const cv::Matx33d& a, const cv::Matx33d& b) {
    cv::Mat axis_angle;
    cv::Rodrigues(cv::Mat(a.t() * b), axis_angle);
    return cv::norm(axis_angle) * 180 / kPi;
}

}  // namespace

TEST(Calibrate, BoardSpecsParseAndExplainMistakes) {
    const BoardSpec chessboard = parse_board_spec("chessboard:9x13:10");
    EXPECT_EQ(chessboard.kind, BoardKind::Chessboard);
    EXPECT_EQ(chessboard.size, cv::Size(9, 13));
    EXPECT_DOUBLE_EQ(chessboard.square_mm, 10);
    EXPECT_EQ(board_points(chessboard).size(), 117u);
    EXPECT_EQ(board_points(chessboard)[10], cv::Point3f(10, 10, 0));
    const BoardSpec charuco = parse_board_spec("charuco:12x9:15:11");
    EXPECT_EQ(charuco.kind, BoardKind::Charuco);
    EXPECT_EQ(board_points(charuco).size(), size_t(11 * 8));
    EXPECT_EQ(parse_board_spec("acircles:4x11:20").kind, BoardKind::AsymmetricCircles);
    for (const char* bad : {"chessboard", "chessboard:9x:10", "triangles:9x6:10", "chessboard:9x6:-1", "charuco:5x5:10:12"}) {
        try {
            parse_board_spec(bad);
            ADD_FAILURE() << "accepted " << bad;
        } catch (const Error& error) {
            EXPECT_EQ(error.subject(), "--board") << bad;
        }
    }
}

TEST(Calibrate, SimulatedSeedRigIsRecoveredAccurately) {
    const Calibration truth = seed_rig_calibration();
    std::vector<PoseObservation> poses;
    uint64_t seed = 11;
    for (const CalibrationBoard& board : rehearsal_poses()) {
        poses.push_back(observe(truth, board, "pose" + std::to_string(poses.size()), seed++));
        EXPECT_EQ(poses.back().problem, "") << poses.back().name;
        EXPECT_EQ(poses.back().camera_points.size(), 54u) << poses.back().name;
    }
    const CalibrationReport report = calibrate_rig(poses);
    const Calibration& found = report.calibration;

    const double camera_focal_error = std::abs(found.camera_matrix(0, 0) / truth.camera_matrix(0, 0) - 1);
    const double principal_error = cv::norm(cv::Vec2d(found.camera_matrix(0, 2) - truth.camera_matrix(0, 2),
                                                      found.camera_matrix(1, 2) - truth.camera_matrix(1, 2)));
    const double projector_focal_error = std::max(std::abs(found.projector_matrix(0, 0) / truth.projector_matrix(0, 0) - 1),
                                                  std::abs(found.projector_matrix(1, 1) / truth.projector_matrix(1, 1) - 1));
    const double baseline_error = std::abs(cv::norm(found.T) / cv::norm(truth.T) - 1);
    const double rotation_error = angle_between_deg(found.R, truth.R);
    std::printf("camera f error %.4f %%, principal point off %.3f px, projector f error %.4f %%, baseline error %.4f %%, "
                "rotation error %.4f deg, camera RMS %.4f px, projector RMS %.4f px, %zu warnings\n",
                100 * camera_focal_error, principal_error, 100 * projector_focal_error, 100 * baseline_error,
                rotation_error, report.camera_rms_px, report.projector_rms_px, report.warnings.size());
    for (const auto& warning : report.warnings) std::printf("warning: %s\n", warning.c_str());
    EXPECT_LT(camera_focal_error, 0.001);
    EXPECT_LT(principal_error, 1.0);
    EXPECT_LT(projector_focal_error, 0.002);
    EXPECT_LT(baseline_error, 0.002);
    EXPECT_LT(rotation_error, 0.05);
    EXPECT_LE(report.camera_rms_px, 0.15);
    EXPECT_LE(report.projector_rms_px, 0.25);

    // A 25 mm sphere scanned with the true rig, reconstructed with the recovered calibration.
    Scene scene;
    scene.spheres.push_back({cv::Vec3d(0, 0, 400), 25.0, 0.9});
    SimulationOptions options = camera_noise();
    options.full_scale_dn = 250;
    PatternOptions patterns;
    patterns.projector_size = truth.projector_size;
    const CaptureSet captures = simulate_capture(make_pattern_sequence(patterns), truth, scene, options);
    DecodeOptions decode_options;
    decode_options.min_modulation = 25;
    const ScanView view = triangulate(decode(captures, decode_options), found);
    const std::vector<cv::Vec3f> points = to_point_cloud(view).points;
    const SphereFit fit = fit_sphere(points);
    std::printf("sphere through the recovered calibration: diameter error %+.1f um, RMS %.1f um\n",
                2000 * (fit.radius_mm - 25), 1000 * fit.rms_mm);
    EXPECT_LE(std::abs(2 * fit.radius_mm - 50), 0.020);
}

TEST(Calibrate, TooFewPosesAndUnusablePosesAreNamed) {
    const Calibration truth = seed_rig_calibration();
    std::vector<PoseObservation> poses;
    poses.push_back(observe(truth, board_at({0, 0, 400}, 20, 10, 0), "good-pose", 1));
    poses.push_back(observe(truth, board_at({0, 0, 400}, -20, -10, 0), "second-pose", 2));
    // The board far outside the view: not found.
    poses.push_back(observe(truth, board_at({900, 0, 400}, 0, 0, 0), "empty-pose", 3));
    EXPECT_EQ(poses.back().problem, "board not found in the white frame");
    try {
        calibrate_rig(poses);
        FAIL() << "calibrated from two usable poses";
    } catch (const Error& error) {
        const std::string message = error.what();
        EXPECT_NE(message.find("only 2 usable board poses"), std::string::npos) << message;
        EXPECT_NE(message.find("empty-pose: board not found"), std::string::npos) << message;
    }
}

TEST(Calibrate, ParallelPosesAreDegenerate) {
    const Calibration truth = seed_rig_calibration();
    std::vector<PoseObservation> poses;
    for (int index = 0; index < 4; ++index)
        poses.push_back(observe(truth, board_at({-20.0 + 12 * index, 0, 380.0 + 15 * index}, 0, 0, 0),
                                "flat" + std::to_string(index), uint64_t(20 + index)));
    try {
        calibrate_rig(poses);
        FAIL() << "calibrated from parallel poses";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("degenerate"), std::string::npos) << error.what();
    }
}

TEST(Calibrate, PoseWithoutProjectorCodesAndMismatchedSizes) {
    const Calibration truth = seed_rig_calibration();
    Scene scene;
    scene.boards.push_back(board_at({0, 0, 400}, 10, 10, 0));
    CaptureSet pose = simulate_capture(calibration_sequence(truth), truth, scene, camera_noise());
    pose.directory = "dark-codes";
    // Every coded frame black (the projector was unplugged after the white frame).
    for (size_t index = 0; index < pose.images.size(); ++index)
        if (pose.sequence.frames[index].kind != FrameKind::White) pose.images[index].setTo(0);
    const PoseObservation observation = observe_pose(pose, board_spec());
    EXPECT_EQ(observation.camera_points.size(), 54u);
    EXPECT_NE(observation.problem.find("projector codes cover only 0 of 54 corners"), std::string::npos)
        << observation.problem;

    std::vector<PoseObservation> poses(3, observation);
    poses[1].camera_size = {800, 600};
    poses[1].name = "small-camera";
    try {
        calibrate_rig(poses);
        FAIL();
    } catch (const Error& error) {
        EXPECT_EQ(error.subject(), "small-camera");
    }
}

TEST(Calibrate, CharucoAndCircleGridsAreDetected) {
    // ChArUco: OpenCV's own drawing of a 7x5-square board, slightly blurred.
    const BoardSpec charuco = parse_board_spec("charuco:7x5:30:22");
    const auto dictionary = cv::aruco::getPredefinedDictionary(charuco.dictionary);
    const auto board = cv::aruco::CharucoBoard::create(7, 5, 30.f, 22.f, dictionary);
    cv::Mat image;
    board->draw(cv::Size(1400, 1000), image, 40, 1);
    cv::GaussianBlur(image, image, cv::Size(0, 0), 1.0);
    BoardDetection detection;
    ASSERT_TRUE(detect_board(image, charuco, detection));
    EXPECT_EQ(detection.image_points.size(), size_t(6 * 4));
    // The corners and their ids agree with the board's geometry: one homography maps the model
    // points onto all detections within a fraction of a pixel.
    const std::vector<cv::Point3f> model = board_points(charuco);
    std::vector<cv::Point2f> model_points;
    for (int id : detection.point_ids) model_points.emplace_back(model[size_t(id)].x, model[size_t(id)].y);
    const cv::Mat homography = cv::findHomography(model_points, detection.image_points, 0);
    std::vector<cv::Point2f> mapped;
    cv::perspectiveTransform(model_points, mapped, homography);
    for (size_t index = 0; index < mapped.size(); ++index)
        EXPECT_LT(cv::norm(mapped[index] - detection.image_points[index]), 0.3) << index;

    // A symmetric 6x4 grid of dark circles on white.
    cv::Mat circles(600, 800, CV_8U, cv::Scalar(255));
    for (int row = 0; row < 4; ++row)
        for (int column = 0; column < 6; ++column)
            cv::circle(circles, cv::Point(150 + column * 100, 150 + row * 100), 25, cv::Scalar(0), cv::FILLED, cv::LINE_AA);
    ASSERT_TRUE(detect_board(circles, parse_board_spec("circles:6x4:20"), detection));
    ASSERT_EQ(detection.image_points.size(), 24u);
    EXPECT_NEAR(detection.image_points.front().y, 150, 0.5);
    EXPECT_FALSE(detect_board(circles, parse_board_spec("chessboard:6x4:20"), detection));
}
