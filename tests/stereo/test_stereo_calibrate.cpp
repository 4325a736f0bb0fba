// Stereo calibration from simulated board poses seen by both cameras of the two-camera rig.
#include "picoscan/simulate.h"
#include "picoscan/stereo.h"

#include "stereo/board_poses.h"

#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>

using namespace picoscan;
using picoscan::test_support::stereo_board;
using picoscan::test_support::board_views;
using picoscan::test_support::error_of;

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string coefficients(const cv::Mat& values) {
    std::string text;
    for (size_t index = 0; index < values.total(); ++index) text += (index ? " " : "") + std::to_string(values.at<double>(int(index)));
    return text;
}

double rotation_error_deg(const cv::Matx33d& a, const cv::Matx33d& b) {
    cv::Vec3d vector;
    cv::Rodrigues(cv::Mat(a.t() * b), vector);
    return cv::norm(vector) * 180 / kPi;
}

}  // namespace

TEST(StereoCalibrate, TwelveBoardPosesGiveTheRig) {
    const SeedStereoRig rig = seed_stereo_rig();
    const StereoCalibrationReport report = calibrate_stereo(board_views(12), stereo_board());
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
    cv::Vec3d rotation_vector;
    cv::Rodrigues(cv::Mat(truth.R.t() * c.R), rotation_vector);
    std::printf("principal points off by (%+.2f, %+.2f) and (%+.2f, %+.2f) px; rotation error vector (%+.4f, %+.4f, %+.4f) deg; "
                "distortion %s / %s\n",
                c.left_matrix(0, 2) - truth.left_matrix(0, 2), c.left_matrix(1, 2) - truth.left_matrix(1, 2),
                c.right_matrix(0, 2) - truth.right_matrix(0, 2), c.right_matrix(1, 2) - truth.right_matrix(1, 2),
                rotation_vector[0] * 180 / kPi, rotation_vector[1] * 180 / kPi, rotation_vector[2] * 180 / kPi,
                coefficients(c.left_distortion).c_str(), coefficients(c.right_distortion).c_str());
    EXPECT_EQ(used, 12);
    for (double error : focal_errors) EXPECT_LE(std::abs(error), 0.0005);
    EXPECT_LE(std::abs(baseline_error), 0.0005);
    // The corners are unbiased (exact corners give 0 degrees); the rotation error is their
    // noise through the principal points, ~0.006 degrees RMS over noise draws with this board.
    EXPECT_LT(rotation_error, 0.01);
    EXPECT_LT(report.epipolar_rms_px, 0.2);
    EXPECT_TRUE(report.warnings.empty());

    const std::string folder = test_support::make_temp_dir("stereo_calibrate");
    write_stereo_calibration_report(report, folder + "/report.html");
    write_stereo_calibration(c, folder + "/stereo.yml");
    EXPECT_LT(cv::norm(read_stereo_calibration(folder + "/stereo.yml").T - c.T), 1e-9);
}

TEST(StereoCalibrate, TooFewPosesBlankImagesAndTheWrongBoardAreRefused) {
    const BoardSpec board = stereo_board();
    // Two poses at a third of the size: finding (or not finding) the board is then quick.
    std::vector<StereoBoardView> views = board_views(2);
    for (StereoBoardView& view : views) {
        cv::resize(view.left, view.left, cv::Size(), 1.0 / 3, 1.0 / 3, cv::INTER_AREA);
        cv::resize(view.right, view.right, cv::Size(), 1.0 / 3, 1.0 / 3, cv::INTER_AREA);
    }
    EXPECT_NE(error_of([&] { calibrate_stereo(views, board); }).find("only 2 usable board poses"), std::string::npos);
    // A pose where the second camera sees nothing is reported, not used.
    views.push_back(views[0]);
    views.back().name = "blank";
    views.back().right = cv::Mat(views[0].right.size(), CV_8U, cv::Scalar(10));
    const std::string message = error_of([&] { calibrate_stereo(views, board); });
    EXPECT_NE(message.find("blank: board not found in the second camera's image"), std::string::npos) << message;
    // The wrong board: not found.
    BoardSpec wrong = board;
    wrong.size = {15, 11};
    const std::string wrong_message = error_of([&] { calibrate_stereo({views[0]}, wrong); });
    EXPECT_NE(wrong_message.find("pose0: board not found"), std::string::npos) << wrong_message;
    // Images of different sizes in one camera.
    views[1].left = cv::Mat(100, 100, CV_8U, cv::Scalar(0));
    EXPECT_NE(error_of([&] { calibrate_stereo(views, board); }).find("pose1: first camera's image is 100x100"), std::string::npos);
}
