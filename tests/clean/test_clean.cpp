// Cleaning a view: stray-light outliers go, good points stay.
#include "picoscan/clean.h"
#include "picoscan/decode.h"
#include "picoscan/error.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "picoscan/triangulate.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

using namespace picoscan;

namespace {

const ScanView& demo_view() {
    static const ScanView view = [] {
        const Calibration rig = seed_rig_calibration();
        PatternOptions patterns;
        patterns.projector_size = rig.projector_size;
        patterns.shifts = 8;
        SimulationOptions options;
        options.blur_sigma_px = 0.7;
        const CaptureSet captures = simulate_capture(make_pattern_sequence(patterns), rig, demo_scene(), options);
        return triangulate(decode(captures), rig, captures.white_colour);
    }();
    return view;
}

}  // namespace

TEST(Clean, StrayLightOutliersGoAndGoodPointsStay) {
    ScanView view = demo_view();
    view.points = view.points.clone();
    view.normals = view.normals.clone();
    // Stray light: 5 % of the points decoded with wrong codes, i.e. moved along their camera ray.
    cv::Mat is_outlier(view.points.size(), CV_8U, cv::Scalar(0));
    std::mt19937 random(3);
    std::uniform_real_distribution<float> chance(0, 1), shift_mm(5, 100);
    int outliers = 0, good = 0;
    for (int y = 0; y < view.points.rows; ++y)
        for (int x = 0; x < view.points.cols; ++x) {
            cv::Vec3f& point = view.points.at<cv::Vec3f>(y, x);
            if (!std::isfinite(point[2])) continue;
            if (chance(random) < 0.05f) {
                const float depth = point[2] + (chance(random) < 0.5f ? -1.f : 1.f) * shift_mm(random);
                point *= depth / point[2];
                is_outlier.at<uint8_t>(y, x) = 1;
                ++outliers;
            } else {
                ++good;
            }
        }
    const CleanReport report = clean_view(view);
    int outliers_left = 0, good_removed = 0;
    for (int y = 0; y < view.points.rows; ++y)
        for (int x = 0; x < view.points.cols; ++x) {
            const bool kept = std::isfinite(view.points.at<cv::Vec3f>(y, x)[2]);
            if (is_outlier.at<uint8_t>(y, x)) outliers_left += kept;
            else if (!kept && std::isfinite(demo_view().points.at<cv::Vec3f>(y, x)[2])) ++good_removed;
        }
    std::printf("clean: removed by quality %d, grazing %d, volume %d, statistics %d, radius %d, clusters %d; "
                "outliers removed %.2f %% (%d left of %d), good points removed %.3f %% (%d of %d)\n",
                report.by_quality, report.by_grazing, report.by_working_volume, report.by_statistics, report.by_radius,
                report.by_cluster, 100.0 * (outliers - outliers_left) / outliers, outliers_left, outliers,
                100.0 * good_removed / good, good_removed, good);
    EXPECT_GE(double(outliers - outliers_left) / outliers, 0.95);
    EXPECT_LT(double(good_removed) / good, 0.01);
    EXPECT_EQ(report.remaining, view.valid_count());
    EXPECT_EQ(report.removed() + report.remaining, outliers + good);
}

TEST(Clean, WorkingVolumeQualityAndClusters) {
    ScanView view = demo_view();
    view.points = view.points.clone();
    CleanOptions options;
    options.use_working_volume = true;
    options.volume_min = {-1000, -1000, 0};
    options.volume_max = {1000, 1000, 440};  // drops the background plane at 460 mm
    options.min_quality = 1e9;               // then everything by quality
    CleanReport report = clean_view(view, options);
    EXPECT_EQ(report.remaining, 0);
    EXPECT_EQ(report.by_quality, demo_view().valid_count());

    view = demo_view();
    view.points = view.points.clone();
    options.min_quality = 0;
    report = clean_view(view, options);
    EXPECT_GT(report.by_working_volume, 500000);
    for (auto it = view.points.begin<cv::Vec3f>(); it != view.points.end<cv::Vec3f>(); ++it) {
        if (std::isfinite((*it)[2])) {
            ASSERT_LE((*it)[2], 440);
        }
    }

    // A lone 5x5 patch far in front of everything is a small cluster.
    view = demo_view();
    view.points = view.points.clone();
    for (int y = 100; y < 105; ++y)
        for (int x = 100; x < 105; ++x) view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(float(x - 800) * 0.05f, float(y - 600) * 0.05f, 300);
    report = clean_view(view, CleanOptions{});
    for (int y = 100; y < 105; ++y)
        for (int x = 100; x < 105; ++x) EXPECT_FALSE(std::isfinite(view.points.at<cv::Vec3f>(y, x)[2]));
    view.camera_matrix(0, 0) = 0;  // a view that does not know its camera
    EXPECT_THROW(clean_view(view, CleanOptions{}), Error);
}
