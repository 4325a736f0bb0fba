// Binocular reconstruction on the simulated two-camera rig (two 1600x1200 cameras 200 mm
// apart, the seed projector between them, camera noise sigma = 1 DN), and on real captures.
#include "picoscan/decode.h"
#include "picoscan/fit.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"
#include "picoscan/patterns.h"
#include "picoscan/preview.h"
#include "picoscan/simulate.h"
#include "picoscan/stereo.h"
#include "picoscan/triangulate.h"

#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

using namespace picoscan;
using picoscan::test_support::error_of;

namespace {

const cv::Vec3d kCentre(0, 0, 400);

SimulationOptions camera_options(double gamma = 1.0) {
    SimulationOptions options;
    options.full_scale_dn = 250;
    options.noise_sigma_dn = 1.0;
    options.blur_sigma_px = 0.5;
    options.projector_gamma = gamma;
    return options;
}

DecodeOptions metrology_decode() {
    DecodeOptions options;
    options.min_modulation = 25;  // as the accuracy suite: faint fringes (grazing light) dropped
    return options;
}

struct StereoScan {
    SeedStereoRig rig;
    CorrespondenceMap left, right;
    cv::Mat colour;
};

StereoScan scan(const Scene& scene, const PatternSequence& sequence, double gamma = 1.0,
                const DecodeOptions& decode_options = metrology_decode()) {
    StereoScan result;
    result.rig = seed_stereo_rig();
    const auto captures = simulate_stereo_capture(sequence, result.rig, scene, camera_options(gamma));
    result.left = decode(captures.first, decode_options);
    result.right = decode(captures.second, decode_options);
    result.colour = captures.first.white_colour;
    return result;
}

PatternSequence seed_sequence(bool rows = true) {
    PatternOptions options;
    options.rows = rows;
    return make_pattern_sequence(options);
}

Scene sphere_scene() {
    Scene scene;
    scene.spheres.push_back({kCentre, 25.0, 0.9});
    return scene;
}

std::vector<cv::Vec3f> sphere_points(const ScanView& view) {
    std::vector<cv::Vec3f> points;
    for (const cv::Vec3f& point : to_point_cloud(view).points)
        if (cv::norm(cv::Vec3d(point) - kCentre) < 27) points.push_back(point);
    return points;
}

// Sphere scans of the rig, shared by the tests (each one renders 2 x 88 frames).
const StereoScan& sphere_scan(double gamma) {
    if (gamma == 1.0) {
        static const StereoScan linear = scan(sphere_scene(), seed_sequence(), 1.0);
        return linear;
    }
    static const StereoScan gamma_22 = scan(sphere_scene(), seed_sequence(), 2.2);
    return gamma_22;
}

// The method as a picture: both cameras' decoded projector columns (colour), one left image
// row and, in the right image, where its points were found (the epipolar curve), and the
// reconstructed view.
void draw_binocular_figure(const StereoScan& data, const ScanView& view, int row, const std::string& path) {
    auto colour_codes = [](const cv::Mat& codes) {
        cv::Mat scaled;
        codes.convertTo(scaled, CV_8U, 255.0 / 854);
        cv::Mat coloured;
        cv::applyColorMap(scaled, coloured, cv::COLORMAP_TURBO);
        coloured.setTo(cv::Scalar(40, 40, 40), codes != codes);
        return coloured;
    };
    cv::Mat left = colour_codes(data.left.projector_u), right = colour_codes(data.right.projector_u);
    cv::Mat preview = render_preview(view);
    cv::line(left, {0, row}, {left.cols - 1, row}, cv::Scalar(255, 255, 255), 3);
    const cv::Matx33d& R = data.rig.stereo.R;
    const cv::Vec3d& T = data.rig.stereo.T;
    std::vector<cv::Point3d> in_right;
    std::vector<cv::Point> left_pixels;
    for (int x = 0; x < view.points.cols; x += 1) {
        const cv::Vec3f point = view.points.at<cv::Vec3f>(row, x);
        if (!std::isfinite(point[2])) continue;
        const cv::Vec3d moved = R * cv::Vec3d(point) + T;
        in_right.emplace_back(moved[0], moved[1], moved[2]);
        left_pixels.emplace_back(x, row);
    }
    std::vector<cv::Point2d> right_pixels;
    cv::projectPoints(in_right, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(data.rig.stereo.right_matrix),
                      data.rig.stereo.right_distortion, right_pixels);
    for (const cv::Point2d& pixel : right_pixels) cv::circle(right, pixel, 2, cv::Scalar(255, 255, 255), cv::FILLED);
    for (size_t index = 0; index < right_pixels.size(); index += right_pixels.size() / 6 + 1) {
        cv::circle(left, left_pixels[index], 12, cv::Scalar(0, 0, 0), 4);
        cv::circle(right, right_pixels[index], 12, cv::Scalar(0, 0, 0), 4);
    }
    cv::Mat panels;
    cv::hconcat(std::vector<cv::Mat>{left, right, preview}, panels);
    cv::resize(panels, panels, cv::Size(), 0.4, 0.4, cv::INTER_AREA);
    cv::Mat figure(panels.rows + 40, panels.cols, CV_8UC3, cv::Scalar(255, 255, 255));
    panels.copyTo(figure(cv::Rect(0, 40, panels.cols, panels.rows)));
    const int third = panels.cols / 3;
    cv::putText(figure, "first camera: projector column, one row", {10, 28}, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    cv::putText(figure, "second camera: where that row's codes were found", {third + 10, 28}, cv::FONT_HERSHEY_SIMPLEX, 0.6,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    cv::putText(figure, "reconstructed view (first camera)", {2 * third + 10, 28}, cv::FONT_HERSHEY_SIMPLEX, 0.6,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    std::vector<uint8_t> png;
    cv::imencode(".png", figure, png);
    write_file_atomically(path, std::string(png.begin(), png.end()));
}

// A sphere and a box in front of a plane: shadows, occlusions seen by one camera only, depth
// jumps; scanned once with rows.
Scene objects_scene() {
    Scene scene;
    scene.spheres.push_back({cv::Vec3d(-30, 10, 390), 20.0, 0.8});
    scene.boxes.push_back({cv::Vec3d(35, -15, 400), cv::Vec3d(15, 20, 15), cv::Matx33d::eye(), 0.7});
    scene.planes.push_back({cv::Vec3d(0, 0, 440), cv::Vec3d(0, 0, -1), 0.6});
    return scene;
}

const StereoScan& objects_scan() {
    static const StereoScan instance = scan(objects_scene(), seed_sequence());
    return instance;
}

// Three views (the projector calibrated with the first camera) against two on the sphere. Run
// inside the sphere test: CTest gives every test its own process, and the scan is the
// expensive part.
void check_three_views(const StereoScan& data) {
    const StereoReconstruction two = StereoMatcher(data.rig.stereo).reconstruct(data.left, data.right);
    const StereoReconstruction three = StereoMatcher(data.rig.stereo, data.rig.left).reconstruct(data.left, data.right);
    const std::vector<cv::Vec3f> two_points = sphere_points(two.view), three_points = sphere_points(three.view);
    const SphereFit two_fit = fit_sphere(two_points), three_fit = fit_sphere(three_points);
    const SphereFit single_fit = fit_sphere(sphere_points(Triangulator(data.rig.left).triangulate(data.left)));
    std::printf("sphere, three views: %zu points, RMS %.2f um, diameter error %+.2f um, median projector residual %.4f px; "
                "two views: %zu points, RMS %.2f um, diameter error %+.2f um; camera-projector path RMS %.2f um\n",
                three_points.size(), 1000 * three_fit.rms_mm, 2000 * (three_fit.radius_mm - 25),
                three.statistics.median_projector_residual_px, two_points.size(), 1000 * two_fit.rms_mm,
                2000 * (two_fit.radius_mm - 25), 1000 * single_fit.rms_mm);
    EXPECT_GT(three.statistics.three_view, 0.95 * three.statistics.valid);
    EXPECT_LT(three.statistics.median_projector_residual_px, 0.1);
    EXPECT_LE(three_fit.rms_mm, two_fit.rms_mm);
    EXPECT_LE(std::abs(2 * three_fit.radius_mm - 50), 0.005);
    EXPECT_EQ(two.statistics.three_view, 0);
    // The second camera's projector calibration in the first camera's place: refused.
    const std::string message =
        error_of([&] { StereoMatcher(data.rig.stereo, data.rig.right).reconstruct(data.left, data.right); });
    EXPECT_NE(message.find("projector calibration: does not fit these cameras"), std::string::npos) << message;
}

}  // namespace

TEST(StereoReconstruct, SphereOnTheTwoCameraRig) {
    const StereoScan& data = sphere_scan(1.0);
    const StereoReconstruction result = StereoMatcher(data.rig.stereo).reconstruct(data.left, data.right, data.colour);
    const std::vector<cv::Vec3f> points = sphere_points(result.view);
    const SphereFit fit = fit_sphere(points);
    const StereoStatistics& s = result.statistics;
    std::printf("stereo sphere: %zu points, diameter error %+.2f um, RMS %.2f um, centre off by %.1f um; "
                "%d decoded, %d matched, %d ambiguous, left-right consistency %.4f %%, median epipolar error %.4f px\n",
                points.size(), 2000 * (fit.radius_mm - 25), 1000 * fit.rms_mm, 1000 * cv::norm(fit.centre - kCentre),
                s.left_decoded, s.matched, s.ambiguous, 100 * s.left_right_consistency(), s.median_epipolar_error_px);
    EXPECT_GT(points.size(), 60000u);
    EXPECT_LE(std::abs(2 * fit.radius_mm - 50), 0.005);
    EXPECT_LE(fit.rms_mm, 0.008);
    EXPECT_LT(cv::norm(fit.centre - kCentre), 0.010);
    EXPECT_GT(s.left_right_consistency(), 0.98);
    EXPECT_LT(s.median_epipolar_error_px, 0.1);
    // Every point is on the sphere (no stray points elsewhere in the empty scene).
    EXPECT_EQ(size_t(result.view.valid_count()), points.size());
    check_three_views(data);
}


TEST(StereoReconstruct, ProjectorGammaLargelyCancels) {
    const StereoScan& linear = sphere_scan(1.0);
    const StereoScan& gamma = sphere_scan(2.2);
    const StereoMatcher matcher(linear.rig.stereo);
    const SphereFit stereo_linear = fit_sphere(sphere_points(matcher.reconstruct(linear.left, linear.right).view));
    const SphereFit stereo_gamma = fit_sphere(sphere_points(matcher.reconstruct(gamma.left, gamma.right).view));
    // The camera-projector path on the same left captures, for comparison.
    const Triangulator triangulator(linear.rig.left);
    const SphereFit single_linear = fit_sphere(sphere_points(triangulator.triangulate(linear.left)));
    const SphereFit single_gamma = fit_sphere(sphere_points(triangulator.triangulate(gamma.left)));
    std::printf("projector gamma 2.2, no correction: stereo RMS %.2f um (gamma 1: %.2f um, ratio %.2f), diameter error %+.2f um; "
                "camera-projector path RMS %.2f um (gamma 1: %.2f um, ratio %.2f), diameter error %+.2f um\n",
                1000 * stereo_gamma.rms_mm, 1000 * stereo_linear.rms_mm, stereo_gamma.rms_mm / stereo_linear.rms_mm,
                2000 * (stereo_gamma.radius_mm - 25), 1000 * single_gamma.rms_mm, 1000 * single_linear.rms_mm,
                single_gamma.rms_mm / single_linear.rms_mm, 2000 * (single_gamma.radius_mm - 25));
    EXPECT_LE(stereo_gamma.rms_mm, 1.5 * stereo_linear.rms_mm);
    EXPECT_LE(std::abs(2 * stereo_gamma.radius_mm - 50), 0.010);
}

TEST(StereoReconstruct, WithFewShiftsGammaBiasesTheProjectorPathOnly) {
    // 4 shifts: a gamma-distorted fringe's harmonics 3 and 5 bias the phase, the same way in
    // both cameras (the same projector column), so the binocular match does not see it.
    PatternOptions patterns;
    patterns.shifts = 4;
    patterns.rows = false;
    const PatternSequence sequence = make_pattern_sequence(patterns);
    const StereoScan linear = scan(sphere_scene(), sequence, 1.0), gamma = scan(sphere_scene(), sequence, 2.2);
    const StereoMatcher matcher(linear.rig.stereo);
    const Triangulator triangulator(linear.rig.left);
    const SphereFit stereo_linear = fit_sphere(sphere_points(matcher.reconstruct(linear.left, linear.right).view));
    const SphereFit stereo_gamma = fit_sphere(sphere_points(matcher.reconstruct(gamma.left, gamma.right).view));
    const SphereFit single_linear = fit_sphere(sphere_points(triangulator.triangulate(linear.left)));
    const SphereFit single_gamma = fit_sphere(sphere_points(triangulator.triangulate(gamma.left)));
    std::printf("4 shifts, columns only, projector gamma 2.2: stereo RMS %.2f um (gamma 1: %.2f um, ratio %.2f); "
                "camera-projector path RMS %.2f um (gamma 1: %.2f um, ratio %.2f)\n",
                1000 * stereo_gamma.rms_mm, 1000 * stereo_linear.rms_mm, stereo_gamma.rms_mm / stereo_linear.rms_mm,
                1000 * single_gamma.rms_mm, 1000 * single_linear.rms_mm, single_gamma.rms_mm / single_linear.rms_mm);
    EXPECT_LE(stereo_gamma.rms_mm, 1.1 * stereo_linear.rms_mm);
    EXPECT_GE(single_gamma.rms_mm, 1.15 * single_linear.rms_mm);
}

TEST(StereoReconstruct, PointsAgreeWithTheTrueSurfaceAtOcclusionsAndEdges) {
    const StereoScan& data = objects_scan();
    // Columns alone suffice: the row codes are left out.
    CorrespondenceMap left = data.left, right = data.right;
    left.projector_v = cv::Mat();
    right.projector_v = cv::Mat();
    const Scene scene = objects_scene();
    const StereoReconstruction result = StereoMatcher(data.rig.stereo).reconstruct(left, right);
    const Simulator truth(data.rig.left, scene, camera_options());
    int points = 0, within_50um = 0, beyond_1mm = 0;
    for (int y = 0; y < result.view.points.rows; ++y)
        for (int x = 0; x < result.view.points.cols; ++x) {
            const cv::Vec3f point = result.view.points.at<cv::Vec3f>(y, x);
            if (!std::isfinite(point[2])) continue;
            const cv::Vec3f expected = truth.geometry().points.at<cv::Vec3f>(y, x);
            const double error = std::isfinite(expected[2]) ? cv::norm(point - expected) : 1e9;
            ++points;
            within_50um += error < 0.05;
            beyond_1mm += error > 1.0;
        }
    std::printf("edges and occlusions (columns only): %d points, %.3f %% within 50 um of the true surface, %d beyond 1 mm; "
                "left-right consistency %.3f %%, %d ambiguous\n",
                points, 100.0 * within_50um / points, beyond_1mm, 100 * result.statistics.left_right_consistency(),
                result.statistics.ambiguous);
    EXPECT_GT(points, 1000000);
    EXPECT_GT(double(within_50um) / points, 0.999);
    EXPECT_LE(double(beyond_1mm) / points, 1e-4);
    if (const char* figures = std::getenv("PICOSCAN_FIGURES_DIR"))
        draw_binocular_figure(data, result.view, 600, std::string(figures) + "/stereo_matching.png");
}

TEST(StereoReconstruct, AWrongCalibrationIsRefusedWhenRowsAreProjected) {
    const StereoScan& data = sphere_scan(1.0);
    // Swapped cameras, and a calibration one degree off about the baseline.
    EXPECT_NE(error_of([&] { StereoMatcher(data.rig.stereo).reconstruct(data.right, data.left); }).find("does not fit these captures"),
              std::string::npos);
    StereoCalibration tilted = data.rig.stereo;
    cv::Matx33d turn;
    cv::Rodrigues(cv::Vec3d(1.0 * CV_PI / 180, 0, 0), turn);
    tilted.R = turn * tilted.R;
    const std::string message = error_of([&] { StereoMatcher(tilted).reconstruct(data.left, data.right); });
    std::printf("one degree off: %s\n", message.c_str());
    EXPECT_NE(message.find("does not fit these captures"), std::string::npos);
    // Wrong sizes are named.
    SeedStereoRig other = seed_stereo_rig();
    other.stereo.left_size = cv::Size(1280, 1024);
    EXPECT_NE(error_of([&] { StereoMatcher(other.stereo).reconstruct(data.left, data.right); }).find("camera1_size is 1280x1024"),
              std::string::npos);
}

TEST(StereoReconstruct, ForeignGrayCodeSequence) {
    // OpenCV's GrayCodePattern (binary code only): coarse, but every point near the sphere.
    const PatternSequence sequence = make_opencv_graycode_sequence(cv::Size(854, 480), "", ".png", 1);
    DecodeOptions decode_options;
    const StereoScan data = scan(sphere_scene(), sequence, 1.0, decode_options);
    const StereoReconstruction result = StereoMatcher(data.rig.stereo).reconstruct(data.left, data.right);
    const std::vector<cv::Vec3f> points = sphere_points(result.view);
    const SphereFit fit = fit_sphere(points);
    std::printf("OpenCV Gray code: %zu points of %d valid, diameter error %+.1f um, RMS %.1f um, LR consistency %.2f %%\n",
                points.size(), result.view.valid_count(), 2000 * (fit.radius_mm - 25), 1000 * fit.rms_mm,
                100 * result.statistics.left_right_consistency());
    EXPECT_GT(points.size(), 40000u);
    EXPECT_EQ(size_t(result.view.valid_count()), points.size());
    EXPECT_LT(fit.rms_mm, 0.150);
    EXPECT_LT(std::abs(2 * fit.radius_mm - 50), 0.100);
}

TEST(StereoReconstruct, StatueWithItsOwnStereoCalibration) {
    PICOSCAN_REQUIRE_DATASETS();
    const std::string folder = test_support::datasets_dir() + "/gsoc2015-statue/";
    const StereoCalibration calibration = read_stereo_calibration(folder + "calibrationParameters.yml");
    const std::string manifests = test_support::make_temp_dir("stereo_statue");
    auto load = [&](int camera) {
        const PatternSequence sequence =
            make_opencv_graycode_sequence({1280, 800}, "pattern_cam" + std::to_string(camera) + "_im", ".jpg", 1);
        const std::string manifest = manifests + "/cam" + std::to_string(camera) + ".json";
        write_manifest(sequence, manifest);
        DecodeOptions options;
        options.min_contrast = 40;  // dark, low-contrast JPEGs (PROVENANCE)
        return decode(load_capture_set(folder + "statue_front_side", manifest), options);
    };
    const CorrespondenceMap left = load(1), right = load(2);
    // The file's R, T do not fit the images (PROVENANCE: ~74 px median epipolar error): refused.
    const std::string message = error_of([&] { StereoMatcher(calibration).reconstruct(left, right); });
    std::printf("statue with calibrationParameters.yml as written: %s\n", message.c_str());
    EXPECT_NE(message.find("does not fit these captures"), std::string::npos);

    // Its intrinsics and baseline length with the pose re-estimated from the shared codes.
    const ExtrinsicsRefinement refined = refine_stereo_extrinsics(left, right, calibration);
    const StereoReconstruction result = StereoMatcher(refined.calibration).reconstruct(left, right);
    const StereoStatistics& s = result.statistics;
    const double decoded_fraction = double(s.left_decoded) / left.projector_u.total();
    const double valid_fraction = double(s.valid) / left.projector_u.total();
    std::printf("statue, pose refined from %d shared codes (%d inliers): median epipolar error %.2f px before, %.2f px after, "
                "rotation changed by %.2f deg; %.1f %% of the first camera's pixels decoded, %.1f %% valid points "
                "(%.1f %% of the decoded), left-right consistency %.2f %%, %d ambiguous, median row-code epipolar error %.2f px\n",
                refined.pairs, refined.inliers, refined.median_epipolar_before_px, refined.median_epipolar_after_px,
                refined.rotation_change_deg, 100 * decoded_fraction, 100 * valid_fraction, 100.0 * s.valid / s.left_decoded,
                100 * s.left_right_consistency(), s.ambiguous, s.median_epipolar_error_px);
    EXPECT_GT(refined.median_epipolar_before_px, 20);
    EXPECT_LT(refined.median_epipolar_after_px, 1.0);
    EXPECT_GT(double(s.valid) / s.left_decoded, 0.4);
    EXPECT_GT(s.left_right_consistency(), 0.9);
    // The statue stands about 2 m away (PROVENANCE): depths in a plausible band.
    std::vector<float> depths;
    for (const cv::Vec3f& point : to_point_cloud(result.view).points) depths.push_back(point[2]);
    std::sort(depths.begin(), depths.end());
    const float p5 = depths[depths.size() / 20], p95 = depths[depths.size() * 19 / 20];
    std::printf("statue depths p5 %.0f mm, p95 %.0f mm\n", p5, p95);
    EXPECT_GT(p5, 1000);
    EXPECT_LT(p95, 4000);
    EXPECT_LT(p95 - p5, 1000);
}

TEST(StereoReconstruct, RefiningTheCamerasPoseFromTheCodes) {
    const StereoScan& data = objects_scan();
    StereoCalibration moved = data.rig.stereo;
    cv::Matx33d turn;
    cv::Rodrigues(cv::Vec3d(0.5 * CV_PI / 180, -0.3 * CV_PI / 180, 0.2 * CV_PI / 180), turn);
    moved.R = turn * moved.R;
    const ExtrinsicsRefinement refined = refine_stereo_extrinsics(data.left, data.right, moved);
    cv::Vec3d error;
    cv::Rodrigues(cv::Mat(refined.calibration.R.t() * data.rig.stereo.R), error);
    const double direction_error_deg =
        std::acos(std::min(1.0, cv::normalize(refined.calibration.T).dot(cv::normalize(data.rig.stereo.T)))) * 180 / CV_PI;
    std::printf("pose refinement: %d pairs, %d inliers, epipolar %.2f -> %.4f px, rotation error %.4f deg, baseline direction "
                "error %.4f deg\n",
                refined.pairs, refined.inliers, refined.median_epipolar_before_px, refined.median_epipolar_after_px,
                cv::norm(error) * 180 / CV_PI, direction_error_deg);
    // The codes fit the refined pose to a tenth of a pixel; the rotation and the baseline's
    // direction trade off against each other within a few hundredths of a degree.
    EXPECT_LT(cv::norm(error) * 180 / CV_PI, 0.1);
    EXPECT_LT(direction_error_deg, 0.1);
    EXPECT_LT(refined.median_epipolar_after_px, 0.1);
    EXPECT_GT(refined.median_epipolar_before_px, 10);
}
