// Two cameras sharing the projector: camera-camera triangulation and stray-light rejection.
#include "picoscan/decode.h"
#include "picoscan/fit.h"
#include "picoscan/multi_camera.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "picoscan/triangulate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

using namespace picoscan;

namespace {

// Camera 2: 120 mm left of camera 1, turned to look at (0, 0, 400). Returns its calibration
// with the shared projector, and camera 1 -> camera 2 (X_2 = rotation X_1 + translation).
Calibration second_camera(const Calibration& first, cv::Matx33d& rotation, cv::Vec3d& translation) {
    const cv::Vec3d centre(-120, 0, 0);
    const cv::Vec3d z = cv::normalize(cv::Vec3d(0, 0, 400) - centre), y(0, 1, 0);
    const cv::Vec3d x = y.cross(z);
    rotation = cv::Matx33d(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
    translation = -(rotation * centre);
    Calibration second = first;
    second.R = first.R * rotation.t();
    second.T = first.T - first.R * rotation.t() * translation;
    return second;
}

CorrespondenceMap scan(const Calibration& rig, const Scene& scene, uint64_t seed) {
    PatternOptions patterns;
    patterns.projector_size = rig.projector_size;
    SimulationOptions options;
    options.full_scale_dn = 250;
    options.blur_sigma_px = 0.5;
    options.seed = seed;
    DecodeOptions decode_options;
    decode_options.min_modulation = 25;
    return decode(simulate_capture(make_pattern_sequence(patterns), rig, scene, options), decode_options);
}

struct TwoCameraScan {
    Calibration first, second;
    CorrespondenceMap map_first, map_second;
};

const TwoCameraScan& sphere_scan() {
    static const TwoCameraScan instance = [] {
        TwoCameraScan result;
        result.first = seed_rig_calibration();
        cv::Matx33d rotation;
        cv::Vec3d translation;
        result.second = second_camera(result.first, rotation, translation);
        const cv::Vec3d centre(0, 0, 400);
        Scene first_scene, second_scene;
        first_scene.spheres.push_back({centre, 25.0, 0.9});
        first_scene.planes.push_back({cv::Vec3d(0, 0, 470), cv::Vec3d(0, 0, -1), 0.6});
        second_scene.spheres.push_back({rotation * centre + translation, 25.0, 0.9});
        second_scene.planes.push_back({rotation * cv::Vec3d(0, 0, 470) + translation, rotation * cv::Vec3d(0, 0, -1), 0.6});
        result.map_first = scan(result.first, first_scene, 1);
        result.map_second = scan(result.second, second_scene, 2);
        return result;
    }();
    return instance;
}

}  // namespace

TEST(MultiCamera, CameraToCameraPoseComesThroughTheProjector) {
    const Calibration first = seed_rig_calibration();
    cv::Matx33d rotation;
    cv::Vec3d translation;
    const Calibration second = second_camera(first, rotation, translation);
    const cv::Matx44d pose = camera_to_camera(first, second);
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(pose(r, c), rotation(r, c), 1e-12);
        EXPECT_NEAR(pose(r, 3), translation[r], 1e-9);
    }
}

TEST(MultiCamera, CameraPairTriangulatesTheSphere) {
    const TwoCameraScan& data = sphere_scan();
    const ScanView view = triangulate_camera_pair(data.map_first, data.first, data.map_second, data.second);
    std::vector<cv::Vec3f> sphere;
    for (const cv::Vec3f& point : to_point_cloud(view).points)
        if (cv::norm(cv::Vec3d(point) - cv::Vec3d(0, 0, 400)) < 30) sphere.push_back(point);
    const SphereFit fit = fit_sphere(sphere);
    std::printf("camera-camera sphere: %zu points, diameter error %+.1f um, RMS %.1f um\n", sphere.size(),
                2000 * (fit.radius_mm - 25), 1000 * fit.rms_mm);
    EXPECT_GT(sphere.size(), 40000u);
    EXPECT_LT(std::abs(2 * fit.radius_mm - 50), 0.030);
    EXPECT_LT(fit.rms_mm, 0.030);
}

TEST(MultiCamera, StrayLightPointsAreRejectedWhenTheOtherCameraDisagrees) {
    const TwoCameraScan& data = sphere_scan();
    // Stray light: 5 % of camera 1's decoded pixels get wrong codes.
    CorrespondenceMap corrupted = data.map_first;
    corrupted.projector_u = data.map_first.projector_u.clone();
    corrupted.projector_v = data.map_first.projector_v.clone();
    cv::Mat is_outlier(corrupted.projector_u.size(), CV_8U, cv::Scalar(0));
    std::mt19937 random(5);
    std::uniform_real_distribution<float> any_u(0, 853), any_v(0, 479), chance(0, 1);
    for (int y = 0; y < corrupted.projector_u.rows; ++y)
        for (int x = 0; x < corrupted.projector_u.cols; ++x)
            if (std::isfinite(corrupted.projector_u.at<float>(y, x)) && chance(random) < 0.05f) {
                const float u = any_u(random);
                if (std::abs(u - corrupted.projector_u.at<float>(y, x)) < 3) continue;  // not actually wrong
                corrupted.projector_u.at<float>(y, x) = u;
                corrupted.projector_v.at<float>(y, x) = any_v(random);
                is_outlier.at<uint8_t>(y, x) = 1;
            }
    ScanView view = triangulate(corrupted, data.first);
    cv::Mat was_valid(view.points.size(), CV_8U);
    for (int y = 0; y < view.points.rows; ++y)
        for (int x = 0; x < view.points.cols; ++x) was_valid.at<uint8_t>(y, x) = std::isfinite(view.points.at<cv::Vec3f>(y, x)[2]);
    const int removed = reject_unconfirmed_points(view, data.first, data.map_second, data.second);
    // Good points on the part of the sphere both cameras face (camera 2 at (-120, 0, 0)).
    long outliers = 0, outliers_removed = 0, good = 0, good_removed = 0, both_see = 0, both_see_removed = 0;
    auto seen_by_both = [](const cv::Vec3f& point) {
        const cv::Vec3d p(point), centre(0, 0, 400);
        if (std::abs(cv::norm(p - centre) - 25) > 1) return false;
        const cv::Vec3d normal = cv::normalize(p - centre);
        return normal.dot(cv::normalize(-p)) > 0.3 && normal.dot(cv::normalize(cv::Vec3d(-120, 0, 0) - p)) > 0.3;
    };
    const ScanView original = triangulate(corrupted, data.first);
    for (int y = 0; y < view.points.rows; ++y)
        for (int x = 0; x < view.points.cols; ++x) {
            if (!was_valid.at<uint8_t>(y, x)) continue;
            const bool gone = !std::isfinite(view.points.at<cv::Vec3f>(y, x)[2]);
            if (is_outlier.at<uint8_t>(y, x)) {
                ++outliers;
                outliers_removed += gone;
            } else {
                ++good;
                good_removed += gone;
                if (seen_by_both(original.points.at<cv::Vec3f>(y, x))) {
                    ++both_see;
                    both_see_removed += gone;
                }
            }
        }
    std::printf("stray light: %ld of %ld outliers removed (%.2f %%); good points removed: %ld of %ld seen by both cameras "
                "(%.3f %%), %ld of %ld in all (the rest only camera 1 sees); %d in all\n",
                outliers_removed, outliers, 100.0 * outliers_removed / outliers, both_see_removed, both_see,
                100.0 * both_see_removed / both_see, good_removed, good, removed);
    EXPECT_GT(outliers, 10000);
    EXPECT_GE(double(outliers_removed) / outliers, 0.95);
    EXPECT_GT(both_see, 20000);
    EXPECT_LT(double(both_see_removed) / both_see, 0.01);
}
