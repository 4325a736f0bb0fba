// Stereo calibration from simulated board poses seen by both cameras of the two-camera rig.
#include "picoscan/simulate.h"
#include "picoscan/stereo.h"

#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include <cmath>
#include <cstdio>

using namespace picoscan;
using picoscan::test_support::error_of;

namespace {

constexpr double kPi = 3.14159265358979323846;

cv::Matx33d rotation_deg(double x, double y, double z) {
    cv::Matx33d rx, ry, rz;
    cv::Rodrigues(cv::Vec3d(x * kPi / 180, 0, 0), rx);
    cv::Rodrigues(cv::Vec3d(0, y * kPi / 180, 0), ry);
    cv::Rodrigues(cv::Vec3d(0, 0, z * kPi / 180), rz);
    return rz * ry * rx;
}

// The board's white-lit image in both cameras for each pose; the board's middle at `target`.
std::vector<StereoBoardView> board_views(const SeedStereoRig& rig, int count, uint64_t seed) {
    struct Pose { cv::Vec3d target, tilt_deg; };
    const std::vector<Pose> poses = {
        {{0, 0, 400}, {20, 0, 0}},     {{-30, -20, 390}, {0, 25, 5}},  {{30, 20, 410}, {-20, 0, -5}},
        {{-30, 20, 420}, {0, -25, 0}}, {{30, -20, 380}, {15, 15, 10}}, {{0, 25, 400}, {-15, -20, 0}},
        {{0, -25, 430}, {25, 10, -10}}, {{-35, 0, 370}, {-10, 30, 0}}, {{35, 0, 400}, {10, -30, 5}},
        {{20, 10, 440}, {30, 0, 15}},  {{-20, -10, 360}, {-25, 10, -15}}, {{0, 0, 410}, {5, 35, 0}},
    };
    std::vector<StereoBoardView> views;
    cv::Matx44d left_to_right = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) left_to_right(r, c) = rig.stereo.R(r, c);
        left_to_right(r, 3) = rig.stereo.T[r];
    }
    const cv::Mat white(rig.left.projector_size, CV_8U, cv::Scalar(255));
    for (int index = 0; index < count; ++index) {
        CalibrationBoard board;
        board.inner_corners = {9, 6};
        board.square_mm = 12;
        board.rotation = rotation_deg(poses[size_t(index)].tilt_deg[0], poses[size_t(index)].tilt_deg[1], poses[size_t(index)].tilt_deg[2]);
        const cv::Vec3d middle(4 * 12, 2.5 * 12, 0);
        board.translation = poses[size_t(index)].target - board.rotation * middle;
        Scene scene;
        scene.boards.push_back(board);
        SimulationOptions options;
        options.full_scale_dn = 250;
        options.blur_sigma_px = 0.5;
        options.seed = seed + uint64_t(index);
        StereoBoardView view;
        view.name = "pose" + std::to_string(index);
        view.left = Simulator(rig.left, scene, options).render(white, 0);
        view.right = Simulator(rig.right, transformed(scene, left_to_right), options).render(white, 1);
        views.push_back(view);
    }
    return views;
}

double rotation_error_deg(const cv::Matx33d& a, const cv::Matx33d& b) {
    cv::Vec3d vector;
    cv::Rodrigues(cv::Mat(a.t() * b), vector);
    return cv::norm(vector) * 180 / kPi;
}

}  // namespace

TEST(StereoCalibrate, TwelveBoardPosesGiveTheRig) {
    const SeedStereoRig rig = seed_stereo_rig();
    BoardSpec board;
    board.size = {9, 6};
    board.square_mm = 12;
    const StereoCalibrationReport report = calibrate_stereo(board_views(rig, 12, 3), board);
    const StereoCalibration& c = report.calibration;
    const StereoCalibration& truth = rig.stereo;
    int used = 0;
    for (const StereoPoseReport& pose : report.poses) used += pose.used;
    const double focal_errors[4] = {c.left_matrix(0, 0) / truth.left_matrix(0, 0) - 1, c.left_matrix(1, 1) / truth.left_matrix(1, 1) - 1,
                                    c.right_matrix(0, 0) / truth.right_matrix(0, 0) - 1,
                                    c.right_matrix(1, 1) / truth.right_matrix(1, 1) - 1};
    const double baseline_error = c.baseline_mm() / truth.baseline_mm() - 1;
    const double rotation_error = rotation_error_deg(c.R, truth.R);
    std::printf("stereo calibration, %d of 12 poses: RMS %.3f / %.3f px, epipolar RMS %.3f px; focal errors %+.4f %% %+.4f %% "
                "%+.4f %% %+.4f %%, baseline %.3f mm (error %+.4f %%), rotation error %.4f deg\n",
                used, report.left_rms_px, report.right_rms_px, report.epipolar_rms_px, 100 * focal_errors[0],
                100 * focal_errors[1], 100 * focal_errors[2], 100 * focal_errors[3], c.baseline_mm(), 100 * baseline_error,
                rotation_error);
    EXPECT_EQ(used, 12);
    for (double error : focal_errors) EXPECT_LE(std::abs(error), 0.0005);
    EXPECT_LE(std::abs(baseline_error), 0.0005);
    EXPECT_LE(rotation_error, 0.01);
    EXPECT_LT(report.epipolar_rms_px, 0.2);
    EXPECT_TRUE(report.warnings.empty());

    const std::string folder = test_support::make_temp_dir("stereo_calibrate");
    write_stereo_calibration_report(report, folder + "/report.html");
    write_stereo_calibration(c, folder + "/stereo.yml");
    EXPECT_LT(cv::norm(read_stereo_calibration(folder + "/stereo.yml").T - c.T), 1e-9);
}

TEST(StereoCalibrate, TooFewOrParallelPosesAreRefused) {
    const SeedStereoRig rig = seed_stereo_rig();
    BoardSpec board;
    board.size = {9, 6};
    board.square_mm = 12;
    std::vector<StereoBoardView> views = board_views(rig, 2, 5);
    EXPECT_NE(error_of([&] { calibrate_stereo(views, board); }).find("only 2 usable board poses"), std::string::npos);
    // A pose where the second camera sees nothing is reported, not used.
    views.push_back(views[0]);
    views.back().name = "blank";
    views.back().right = cv::Mat(views[0].right.size(), CV_8U, cv::Scalar(10));
    const std::string message = error_of([&] { calibrate_stereo(views, board); });
    EXPECT_NE(message.find("blank: board not found in the second camera's image"), std::string::npos) << message;
    // Wrong board size: none found.
    BoardSpec wrong = board;
    wrong.size = {7, 5};
    EXPECT_NE(error_of([&] { calibrate_stereo(board_views(rig, 3, 7), wrong); }).find("board not found"), std::string::npos);
}
