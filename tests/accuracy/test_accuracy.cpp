// Accuracy on the seed-like simulated rig: 1600x1200 camera, 854x480 projector, ~150 mm
// baseline, 400 mm working distance, 24 shifts, camera noise sigma = 1 DN.
#include "picoscan/decode.h"
#include "picoscan/fit.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "picoscan/triangulate.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Exposure set as a user would: a white reference part lit by the white frame lands just
// below saturation.
constexpr double kReferenceAlbedo = 0.9;  // matte white sphere / plate

SimulationOptions seed_like_camera() {
    SimulationOptions options;
    options.full_scale_dn = 250;
    options.noise_sigma_dn = 1.0;
    options.blur_sigma_px = 0.5;
    return options;
}

ScanView scan(const Scene& scene, bool binary_only, CorrespondenceMap* correspondences = nullptr) {
    const Calibration calibration = seed_rig_calibration();
    PatternOptions patterns;
    patterns.projector_size = calibration.projector_size;
    const CaptureSet captures = simulate_capture(make_pattern_sequence(patterns), calibration, scene, seed_like_camera());
    DecodeOptions options;
    options.binary_only = binary_only;
    // Metrology setting: drop points whose fringes are faint (grazing projector light), as
    // their phase noise grows as 1 / modulation.
    options.min_modulation = 25;
    CorrespondenceMap map = decode(captures, options);
    ScanView view = triangulate(map, calibration, captures.white_colour);
    if (correspondences) *correspondences = std::move(map);
    return view;
}

std::vector<cv::Vec3f> valid_points(const ScanView& view) { return to_point_cloud(view).points; }

Scene tilted_plane_scene(cv::Vec3d* normal_out, double* offset_out) {
    const double tilt = 20 * kPi / 180;
    const cv::Vec3d normal(std::sin(tilt), 0, -std::cos(tilt));
    const cv::Vec3d point(0, 0, 400);
    Scene scene;
    scene.planes.push_back({point, normal, kReferenceAlbedo});
    *normal_out = normal;
    *offset_out = normal.dot(point);
    return scene;
}

// Signed distance (µm) of every pixel of one image row to the true plane, NaN where invalid.
std::vector<double> row_residuals_um(const ScanView& view, int row, const cv::Vec3d& normal, double offset) {
    std::vector<double> residuals;
    for (int x = 0; x < view.points.cols; ++x) {
        const cv::Vec3f p = view.points.at<cv::Vec3f>(row, x);
        residuals.push_back(std::isfinite(p[2]) ? 1000 * (normal.dot(cv::Vec3d(p)) - offset) : std::nan(""));
    }
    return residuals;
}

// The seed's central claim as a picture: one row of a plane, binary-only vs hybrid.
void plot_cross_section(const std::vector<double>& binary, const std::vector<double>& hybrid, int first_column,
                        double binary_rms, double hybrid_rms, const std::string& path) {
    const int width = 1000, height = 520, left = 70, right = 20, top = 50, bottom = 60;
    cv::Mat plot(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
    const double range_um = 700;
    auto to_y = [&](double um) { return int(top + (height - top - bottom) * (0.5 - um / (2 * range_um))); };
    auto to_x = [&](size_t index) { return int(left + (width - left - right) * double(index) / (binary.size() - 1)); };
    for (int tick = -600; tick <= 600; tick += 200) {
        cv::line(plot, {left, to_y(tick)}, {width - right, to_y(tick)}, cv::Scalar(225, 225, 225));
        cv::putText(plot, std::to_string(tick), {8, to_y(tick) + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0));
    }
    auto draw = [&](const std::vector<double>& values, const cv::Scalar& colour) {
        for (size_t index = 1; index < values.size(); ++index)
            if (std::isfinite(values[index]) && std::isfinite(values[index - 1]))
                cv::line(plot, {to_x(index - 1), to_y(std::clamp(values[index - 1], -range_um, range_um))},
                         {to_x(index), to_y(std::clamp(values[index], -range_um, range_um))}, colour, 1, cv::LINE_AA);
    };
    draw(binary, cv::Scalar(40, 40, 220));
    draw(hybrid, cv::Scalar(200, 90, 20));
    char title[200];
    std::snprintf(title, sizeof title, "Tilted plane, camera row 600, columns %d-%d: distance to the true plane (um)",
                  first_column, first_column + int(binary.size()) - 1);
    cv::putText(plot, title, {left, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    std::snprintf(title, sizeof title, "binary Gray code only: RMS %.1f um", binary_rms * 1000);
    cv::putText(plot, title, {left, height - 32}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(40, 40, 220), 1, cv::LINE_AA);
    std::snprintf(title, sizeof title, "hybrid Gray + 24-shift phase: RMS %.1f um", hybrid_rms * 1000);
    cv::putText(plot, title, {left, height - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(200, 90, 20), 1, cv::LINE_AA);
    std::vector<uint8_t> png;
    cv::imencode(".png", plot, png);
    write_file_atomically(path, std::string(png.begin(), png.end()));
}

}  // namespace

TEST(Accuracy, SphereOfRadius25mm) {
    Scene scene;
    const cv::Vec3d centre(0, 0, 400);
    scene.spheres.push_back({centre, 25.0, kReferenceAlbedo});
    const ScanView view = scan(scene, false);
    const std::vector<cv::Vec3f> points = valid_points(view);
    const SphereFit fit = fit_sphere(points);
    std::printf("sphere: %zu points, diameter %.4f mm (error %+.1f um), RMS radial residual %.2f um, centre off by %.1f um\n",
                points.size(), 2 * fit.radius_mm, 2000 * (fit.radius_mm - 25.0), 1000 * fit.rms_mm,
                1000 * cv::norm(fit.centre - centre));
    EXPECT_GT(points.size(), 60000u);  // the sphere covers ~70 000 camera pixels
    EXPECT_LT(std::abs(2 * fit.radius_mm - 50.0), 0.010);
    EXPECT_LE(fit.rms_mm, 0.010);
    EXPECT_LT(cv::norm(fit.centre - centre), 0.020);
}

TEST(Accuracy, PlaneAndHybridVersusBinary) {
    cv::Vec3d normal;
    double offset;
    const Scene scene = tilted_plane_scene(&normal, &offset);
    const ScanView hybrid = scan(scene, false);
    const ScanView binary = scan(scene, true);
    const PlaneFit hybrid_fit = fit_plane(valid_points(hybrid));
    const PlaneFit binary_fit = fit_plane(valid_points(binary));
    // Against the true plane too: a fit can be flat yet in the wrong place.
    double sum_squares = 0;
    const std::vector<cv::Vec3f> points = valid_points(hybrid);
    for (const auto& point : points) sum_squares += std::pow(normal.dot(cv::Vec3d(point)) - offset, 2);
    const double rms_to_truth = std::sqrt(sum_squares / points.size());
    std::printf("plane: %zu points, hybrid RMS %.2f um (to the true plane %.2f um), binary-only RMS %.1f um, ratio %.1fx\n",
                hybrid_fit.point_count, 1000 * hybrid_fit.rms_mm, 1000 * rms_to_truth, 1000 * binary_fit.rms_mm,
                binary_fit.rms_mm / hybrid_fit.rms_mm);
    EXPECT_GT(hybrid_fit.point_count, 1000000u);
    EXPECT_LE(hybrid_fit.rms_mm, 0.010);
    EXPECT_LE(rms_to_truth, 0.010);
    EXPECT_GE(binary_fit.rms_mm, 10 * hybrid_fit.rms_mm);

    if (const char* figures = std::getenv("PICOSCAN_FIGURES_DIR")) {
        // A 200-pixel window, so the binary code's staircase is visible.
        auto window = [](std::vector<double> values) { return std::vector<double>(values.begin() + 700, values.begin() + 900); };
        plot_cross_section(window(row_residuals_um(binary, 600, normal, offset)),
                           window(row_residuals_um(hybrid, 600, normal, offset)), 700, binary_fit.rms_mm,
                           hybrid_fit.rms_mm, std::string(figures) + "/cross_section_binary_vs_hybrid.png");
    }
}
