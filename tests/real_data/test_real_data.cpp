// Real capture sets from other scanners (../shared/datasets), reconstructed with their own
// calibration. Skipped with a message when the datasets are absent.
#include "picoscan/board.h"
#include "picoscan/calibrate.h"
#include "picoscan/calibration.h"
#include "picoscan/capture_set.h"
#include "picoscan/decode.h"
#include "picoscan/patterns.h"
#include "picoscan/triangulate.h"
#include "support/mat_file.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/structured_light.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

using namespace picoscan;

namespace {

std::string dataset(const std::string& relative) { return test_support::datasets_dir() + "/" + relative; }

std::string write_temp_manifest(const PatternSequence& sequence, const std::string& name) {
    const std::string path = test_support::make_temp_dir(name) + "/sequence.json";
    write_manifest(sequence, path);
    return path;
}

double median(std::vector<double> values) {
    if (values.empty()) return std::nan("");
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    return values[values.size() / 2];
}

double percentile(std::vector<double> values, double fraction) {
    std::sort(values.begin(), values.end());
    return values[std::min(values.size() - 1, size_t(fraction * values.size()))];
}

}  // namespace

TEST(RealData, SlmasterEyeReliefHybrid) {
    PICOSCAN_REQUIRE_DATASETS();
    const std::string root = dataset("slmaster-sinuscgc/monocularCamera");
    const Calibration calibration = read_calibration(root + "/caliInfo.yml");
    const std::string manifest = write_temp_manifest(make_slmaster_cgc_sequence({1920, 1080}, 12, 32), "slmaster");
    const CaptureSet captures = load_capture_set(root + "/L", manifest);
    const CorrespondenceMap map = decode(captures);
    const ScanView view = triangulate(map, calibration, captures.white_colour);

    // A wrong fringe order moves a point by a whole period: tens of millimetres here. Count
    // pixels far from the median of their 5x5 neighbourhood.
    cv::Mat depth(view.points.size(), CV_32F, cv::Scalar(0));
    std::vector<double> depths, steps;
    for (int y = 0; y < view.points.rows; ++y)
        for (int x = 0; x < view.points.cols; ++x) {
            const cv::Vec3f p = view.points.at<cv::Vec3f>(y, x);
            if (!std::isfinite(p[2])) continue;
            depth.at<float>(y, x) = p[2];
            depths.push_back(p[2]);
            if (x + 1 < view.points.cols && std::isfinite(view.points.at<cv::Vec3f>(y, x + 1)[2]))
                steps.push_back(cv::norm(p - view.points.at<cv::Vec3f>(y, x + 1)));
        }
    cv::Mat local_median;
    cv::medianBlur(depth, local_median, 5);
    long order_errors = 0;
    for (int y = 0; y < depth.rows; ++y)
        for (int x = 0; x < depth.cols; ++x)
            order_errors += depth.at<float>(y, x) > 0 && local_median.at<float>(y, x) > 0 &&
                            std::abs(depth.at<float>(y, x) - local_median.at<float>(y, x)) > 10;
    std::printf("SLMaster eye: %zu points, depth median %.1f mm (p1 %.1f, p99 %.1f), neighbour step median %.3f mm, "
                "%ld points > 10 mm off their neighbourhood, %d orders corrected\n",
                depths.size(), median(depths), percentile(depths, 0.01), percentile(depths, 0.99), median(steps),
                order_errors, map.order_corrections);
    EXPECT_GT(depths.size(), 180000u);
    // The relief sits 695..774 mm from the camera (PROVENANCE).
    EXPECT_GT(percentile(depths, 0.05), 690);
    EXPECT_LT(percentile(depths, 0.95), 780);
    // A continuous relief: neighbouring pixels ~0.4 mm apart, (almost) no fringe order errors.
    EXPECT_LT(median(steps), 0.6);
    EXPECT_LT(double(order_errors) / depths.size(), 0.001);
}

TEST(RealData, SlstudioSkullMatchesSlstudiosOwnCloud) {
    PICOSCAN_REQUIRE_DATASETS();
    const std::string root = dataset("slstudio-skull");
    const Calibration calibration = read_calibration(root + "/calibration/calibration.xml");
    const std::string manifest = write_temp_manifest(make_slstudio_gray_sequence({1824, 1140}, 10), "slstudio");
    const CaptureSet captures = load_capture_set(root + "/skull_gray", manifest);
    const ScanView view = triangulate(decode(captures), calibration, captures.white_colour);

    const auto arrays = test_support::read_mat_file(root + "/skull_gray/pointCloud.mat");
    ASSERT_TRUE(arrays.count("xyz"));
    const test_support::MatArray& reference = arrays.at("xyz");
    ASSERT_EQ(reference.dimensions, (std::vector<int>{1352, 1688, 3}));
    std::vector<double> distances, dz;
    int reference_valid = 0;
    for (int y = 0; y < 1352; ++y)
        for (int x = 0; x < 1688; ++x) {
            const cv::Vec3d theirs(reference.at(y, x, 0), reference.at(y, x, 1), reference.at(y, x, 2));
            if (!std::isfinite(theirs[2]) || theirs[2] == 0) continue;
            ++reference_valid;
            const cv::Vec3f ours = view.points.at<cv::Vec3f>(y, x);
            if (!std::isfinite(ours[2])) continue;
            distances.push_back(cv::norm(cv::Vec3d(ours) - theirs));
            dz.push_back(ours[2] - theirs[2]);
        }
    std::printf("SLStudio skull: %d reference pixels, %zu in common, median distance %.3f mm (p90 %.3f), median dz %+.3f mm\n",
                reference_valid, distances.size(), median(distances), percentile(distances, 0.9), median(dz));
    EXPECT_GT(distances.size(), size_t(0.8 * reference_valid));
    EXPECT_LE(median(distances), 0.5);
}

TEST(RealData, StatueViewsDecodeLikeOpenCvGrayCode) {
    PICOSCAN_REQUIRE_DATASETS();
    const std::string root = dataset("gsoc2015-statue");
    for (const std::string side : {"statue_front_side", "statue_back_side"}) {
        for (int camera : {1, 2}) {
            const std::string prefix = "pattern_cam" + std::to_string(camera) + "_im";
            const PatternSequence sequence = make_opencv_graycode_sequence({1280, 800}, prefix, ".jpg", 1);
            const CaptureSet captures = load_capture_set(root + "/" + side, write_temp_manifest(sequence, "statue"));
            DecodeOptions options;
            options.min_contrast = 40;  // dark, low-contrast JPEGs (PROVENANCE)
            const CorrespondenceMap map = decode(captures, options);

            // Continuity of the column code along image rows.
            long pairs = 0, jumps = 0;
            for (int y = 0; y < map.projector_u.rows; ++y)
                for (int x = 0; x + 1 < map.projector_u.cols; ++x) {
                    const float a = map.projector_u.at<float>(y, x), b = map.projector_u.at<float>(y, x + 1);
                    if (!std::isfinite(a) || !std::isfinite(b)) continue;
                    ++pairs;
                    jumps += std::abs(a - b) > 8;
                }
            // The same pixels decoded by OpenCV contrib's own GrayCodePattern.
            auto graycode = cv::structured_light::GrayCodePattern::create(1280, 800);
            graycode->setWhiteThreshold(int(options.min_bit_margin));
            std::vector<cv::Mat> patterns(captures.images.begin(), captures.images.end() - 2);
            long compared = 0, agreeing = 0;
            for (int y = 0; y < map.projector_u.rows; y += 7)
                for (int x = 0; x < map.projector_u.cols; x += 7) {
                    const float u = map.projector_u.at<float>(y, x), v = map.projector_v.at<float>(y, x);
                    if (!std::isfinite(u) || !std::isfinite(v)) continue;
                    cv::Point projector_pixel;
                    if (graycode->getProjPixel(patterns, x, y, projector_pixel)) continue;  // true = OpenCV failed
                    ++compared;
                    agreeing += std::lround(u) == projector_pixel.x && std::lround(v) == projector_pixel.y;
                }
            const int valid = cv::countNonZero(map.mask);
            std::printf("statue %s cam%d: %d valid pixels (%.1f %%), %.4f %% column jumps > 8 px, %.2f %% of %ld "
                        "sampled pixels agree with OpenCV getProjPixel\n",
                        side.c_str(), camera, valid, 100.0 * valid / map.mask.total(), 100.0 * jumps / pairs,
                        100.0 * agreeing / compared, compared);
            EXPECT_GT(valid, 100000);
            EXPECT_LT(double(jumps) / pairs, 0.001);
            EXPECT_GT(compared, 2000);
            EXPECT_GT(double(agreeing) / compared, 0.98);
        }
    }
}

TEST(RealData, SlstudioRigCalibratedFromItsBoardCaptures) {
    PICOSCAN_REQUIRE_DATASETS();
    const std::string root = dataset("slstudio-skull");
    const std::string manifest = write_temp_manifest(make_slstudio_phase_cue_sequence({1824, 1140}, 16), "slstudio-cue");
    const BoardSpec board = parse_board_spec("chessboard:13x9:10");
    std::vector<PoseObservation> poses;
    for (int pose : {1, 3, 4, 5, 6}) {
        const CaptureSet captures = load_capture_set(root + "/calibration/calseq" + std::to_string(pose), manifest);
        poses.push_back(observe_pose(captures, board));
        EXPECT_EQ(poses.back().problem, "") << captures.directory;
    }
    // Five poses: the lens model SLStudio uses (k1 only, camera principal point at the centre).
    CalibrateOptions options;
    options.radial_k1_only = true;
    options.camera_principal_point_at_centre = true;
    const CalibrationReport full_report = calibrate_rig(poses);
    std::printf("full lens model: camera RMS %.3f px, projector RMS %.3f px, baseline %.2f mm\n", full_report.camera_rms_px,
                full_report.projector_rms_px, cv::norm(full_report.calibration.T));
    const CalibrationReport report = calibrate_rig(poses, options);
    const Calibration ours = report.calibration;
    const Calibration theirs = read_calibration(root + "/calibration/calibration.xml");
    cv::Mat rotation_difference;
    cv::Rodrigues(cv::Mat(ours.R.t() * theirs.R), rotation_difference);
    const double rotation_deg = cv::norm(rotation_difference) * 180 / M_PI;
    std::printf("SLStudio calibration: camera RMS %.3f px (SLStudio 0.28), projector RMS %.3f px (SLStudio 0.46); "
                "camera f %.1f vs %.1f, projector f %.1f vs %.1f, baseline %.2f vs %.2f mm, rotation differs by %.3f deg\n",
                report.camera_rms_px, report.projector_rms_px, ours.camera_matrix(0, 0), theirs.camera_matrix(0, 0),
                ours.projector_matrix(0, 0), theirs.projector_matrix(0, 0), cv::norm(ours.T), cv::norm(theirs.T),
                rotation_deg);
    EXPECT_LE(report.camera_rms_px, 0.5);
    EXPECT_LE(report.projector_rms_px, 0.8);
    EXPECT_NEAR(ours.camera_matrix(0, 0) / theirs.camera_matrix(0, 0), 1.0, 0.01);
    EXPECT_NEAR(ours.projector_matrix(0, 0) / theirs.projector_matrix(0, 0), 1.0, 0.015);
    EXPECT_NEAR(cv::norm(ours.T) / cv::norm(theirs.T), 1.0, 0.02);
    EXPECT_LT(rotation_deg, 1.0);

    // The skull through both calibrations, pixel by pixel.
    const std::string skull_manifest = write_temp_manifest(make_slstudio_gray_sequence({1824, 1140}, 10), "skull");
    const CaptureSet skull = load_capture_set(root + "/skull_gray", skull_manifest);
    const CorrespondenceMap map = decode(skull);
    const ScanView with_ours = triangulate(map, ours), with_theirs = triangulate(map, theirs);
    std::vector<double> distances;
    for (int y = 0; y < map.mask.rows; ++y)
        for (int x = 0; x < map.mask.cols; ++x) {
            const cv::Vec3f a = with_ours.points.at<cv::Vec3f>(y, x), b = with_theirs.points.at<cv::Vec3f>(y, x);
            if (std::isfinite(a[2]) && std::isfinite(b[2])) distances.push_back(cv::norm(a - b));
        }
    std::printf("skull through our calibration vs SLStudio's: %zu points, median distance %.3f mm, p90 %.3f mm\n",
                distances.size(), median(distances), percentile(distances, 0.9));
    EXPECT_GT(distances.size(), 80000u);
    EXPECT_LT(median(distances), 2.0);
}
