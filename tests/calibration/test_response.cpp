// Projector response (gamma) calibration on the simulated rig.
#include "picoscan/response.h"
#include "picoscan/calibration.h"
#include "picoscan/decode.h"
#include "picoscan/error.h"
#include "picoscan/fit.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "picoscan/triangulate.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

using namespace picoscan;

namespace {

// Camera noise off and 16-bit images (as if many frames were averaged per pattern): a plane's
// RMS then measures the systematic, fringe-periodic ripple the projector's response causes,
// which 4 shifts cannot average out; with noise it would hide under random error.
SimulationOptions gamma_projector() {
    SimulationOptions options;
    options.projector_gamma = 2.2;
    options.full_scale_dn = 250;
    options.noise_sigma_dn = 0.0;
    options.blur_sigma_px = 0.5;
    options.bit_depth = 16;
    return options;
}

Scene tilted_plane() {
    Scene scene;
    const double tilt = 20 * M_PI / 180;
    scene.planes.push_back({cv::Vec3d(0, 0, 400), cv::Vec3d(std::sin(tilt), 0, -std::cos(tilt)), 0.9});
    return scene;
}

// Captures of every frame with the patterns passed through `lut` (empty: none).
CaptureSet capture(const Simulator& simulator, const PatternSequence& sequence, const cv::Mat& lut) {
    CaptureSet captures;
    captures.sequence = sequence;
    int index = 0;
    for (const Frame& frame : sequence.frames) captures.images.push_back(simulator.render(render_pattern(sequence, frame, lut), index++));
    return captures;
}

double plane_rms_um(const CaptureSet& captures, const Calibration& calibration) {
    const ScanView view = triangulate(decode(captures), calibration);
    const std::vector<cv::Vec3f> points = to_point_cloud(view).points;
    return 1000 * fit_plane(points).rms_mm;
}

}  // namespace

TEST(ProjectorResponse, GammaIsMeasuredAndLinearised) {
    const Calibration rig = seed_rig_calibration();
    const Simulator simulator(rig, tilted_plane(), gamma_projector());
    const std::vector<int> levels = response_levels(17);
    std::vector<cv::Mat> flats;
    for (int level : levels)
        flats.push_back(simulator.render(cv::Mat(rig.projector_size, CV_8U, cv::Scalar(level)), 1000 + level));
    const ProjectorResponse response = measure_projector_response(levels, flats);
    std::printf("measured projector gamma %.3f (simulated 2.2)\n", response.gamma);
    EXPECT_NEAR(response.gamma, 2.2, 0.15);
    // Half light needs level 255 * 0.5^(1/2.2) = 186.
    EXPECT_NEAR(response.inverse_lut.at<uint8_t>(128), 186, 4);

    // A 4-shift scan is very sensitive to the fringe harmonics a gamma creates.
    PatternOptions options;
    options.projector_size = rig.projector_size;
    options.shifts = 4;
    const PatternSequence sequence = make_pattern_sequence(options);
    const double uncompensated = plane_rms_um(capture(simulator, sequence, cv::Mat()), rig);
    const double compensated = plane_rms_um(capture(simulator, sequence, response.inverse_lut), rig);
    std::printf("4-shift plane RMS: %.1f um without response correction, %.1f um with it (%.1fx)\n", uncompensated,
                compensated, uncompensated / compensated);
    EXPECT_GE(uncompensated / compensated, 3.0);
}

TEST(ProjectorResponse, StoredInTheCalibrationFile) {
    Calibration calibration = seed_rig_calibration();
    calibration.projector_inverse_response.create(1, 256, CV_8U);
    for (int level = 0; level < 256; ++level)
        calibration.projector_inverse_response.at<uint8_t>(level) = uint8_t(std::lround(255 * std::pow(level / 255.0, 1 / 2.2)));
    const std::string path = test_support::make_temp_dir("response") + "/calibration.yml";
    write_calibration(calibration, path);
    const Calibration read = read_calibration(path);
    ASSERT_EQ(read.projector_inverse_response.total(), 256u);
    EXPECT_EQ(cv::norm(read.projector_inverse_response, calibration.projector_inverse_response, cv::NORM_INF), 0);
}

TEST(ProjectorResponse, BadMeasurementsAreRefused) {
    const std::vector<int> levels = response_levels(5);
    std::vector<cv::Mat> flat(5, cv::Mat(100, 100, CV_8U, cv::Scalar(40)));
    EXPECT_THROW(measure_projector_response(levels, flat), Error);  // no light change seen
    EXPECT_THROW(measure_projector_response({0, 100, 50, 255}, std::vector<cv::Mat>(4, flat[0])), Error);
    EXPECT_THROW(response_levels(2), Error);
}
