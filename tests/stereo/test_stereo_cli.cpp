// The binocular path through the real CLI: reconstruct chooses it by the calibration's kind,
// calibrate --stereo writes the file it reads.
#include "picoscan/capture_set.h"
#include "picoscan/fit.h"
#include "picoscan/io.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "picoscan/stereo.h"

#include "stereo/board_poses.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>

using namespace picoscan;
using picoscan::test_support::run_picoscan;

namespace {

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// A sphere scanned by both cameras (8 shifts, rows too), written as two capture folders and a
// stereo calibration file.
const std::string& stereo_scan_folder() {
    static const std::string folder = [] {
        const std::string root = test_support::make_temp_dir("stereo_cli");
        const SeedStereoRig rig = seed_stereo_rig();
        PatternOptions patterns;
        patterns.shifts = 8;
        Scene scene;
        scene.spheres.push_back({cv::Vec3d(0, 0, 400), 25.0, 0.9});
        SimulationOptions options;
        options.full_scale_dn = 250;
        const auto captures = simulate_stereo_capture(make_pattern_sequence(patterns), rig, scene, options);
        write_capture_set(captures.first, root + "/left");
        write_capture_set(captures.second, root + "/right");
        write_stereo_calibration(rig.stereo, root + "/stereo.yml");
        write_calibration(rig.left, root + "/left_projector.yml");
        return root;
    }();
    return folder;
}

}  // namespace

TEST(StereoCli, ReconstructChoosesTheBinocularPathByTheCalibration) {
    const std::string& root = stereo_scan_folder();
    const auto result = run_picoscan("reconstruct --calibration " + root + "/stereo.yml --captures " + root +
                                     "/left --second-captures " + root + "/right --out " + root + "/cloud.ply --preview " +
                                     root + "/preview.png --mesh " + root + "/mesh.stl");
    std::printf("%s", result.output.c_str());
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_TRUE(contains(result.output, "left-right consistency"));
    const ScanView view = read_view_ply(root + "/cloud.ply");
    const SphereFit fit = fit_sphere(to_point_cloud(view).points);
    EXPECT_GT(fit.point_count, 50000u);
    EXPECT_LT(std::abs(2 * fit.radius_mm - 50), 0.010);
    EXPECT_LT(fit.rms_mm, 0.020);
    EXPECT_TRUE(std::filesystem::exists(root + "/preview.png"));
    EXPECT_TRUE(std::filesystem::exists(root + "/mesh.stl"));
}

TEST(StereoCli, WrongCombinationsAreRefusedWithTheReason) {
    const std::string& root = stereo_scan_folder();
    auto missing = run_picoscan("reconstruct --calibration " + root + "/stereo.yml --captures " + root + "/left --out " + root +
                                "/a.ply");
    EXPECT_EQ(missing.exit_code, 1);
    EXPECT_TRUE(contains(missing.output, "--second-captures: " + root + "/stereo.yml is a stereo calibration")) << missing.output;
    auto both = run_picoscan("reconstruct --calibration " + root + "/stereo.yml --captures " + root + "/left --second-captures " +
                             root + "/right --second-calibration " + root + "/left_projector.yml --out " + root + "/b.ply");
    EXPECT_EQ(both.exit_code, 1);
    EXPECT_TRUE(contains(both.output, "give only --second-captures")) << both.output;
    auto refine = run_picoscan("reconstruct --calibration " + root + "/left_projector.yml --captures " + root +
                               "/left --refine-stereo-pose --out " + root + "/c.ply");
    EXPECT_EQ(refine.exit_code, 1);
    EXPECT_TRUE(contains(refine.output, "--refine-stereo-pose: needs a stereo calibration")) << refine.output;
    // The cameras swapped: the first camera's captures do not fit camera 1.
    auto swapped = run_picoscan("reconstruct --calibration " + root + "/stereo.yml --captures " + root +
                                "/right --second-captures " + root + "/left --out " + root + "/d.ply");
    std::printf("swapped: %s", swapped.output.c_str());
    EXPECT_EQ(swapped.exit_code, 1);
    EXPECT_TRUE(contains(swapped.output, "does not fit these captures")) << swapped.output;
    EXPECT_FALSE(std::filesystem::exists(root + "/d.ply"));
}

TEST(StereoCli, CalibrateStereoFromBoardImages) {
    const std::string root = test_support::make_temp_dir("stereo_cli_calibrate");
    const std::vector<StereoBoardView> views = test_support::board_views(4);
    std::string first, second;
    for (size_t index = 0; index < views.size(); ++index) {
        const std::string left = root + "/pose" + std::to_string(index) + "_cam1", right = root + "/pose" + std::to_string(index) + "_cam2";
        std::filesystem::create_directories(left);
        std::filesystem::create_directories(right);
        cv::imwrite(left + "/board.png", views[index].left);
        cv::imwrite(right + "/board.png", views[index].right);
        first += " " + left;
        second += " " + right;
    }
    const auto result = run_picoscan(std::string("calibrate --stereo --board ") + test_support::kStereoBoardSpec + " --captures" + first + " --second-captures" +
                                     second + " --out " + root + "/stereo.yml --report " + root + "/report.html");
    std::printf("%s", result.output.c_str());
    ASSERT_EQ(result.exit_code, 0) << result.output;
    const StereoCalibration c = read_stereo_calibration(root + "/stereo.yml");
    EXPECT_NEAR(c.baseline_mm(), 200, 0.5);
    EXPECT_NEAR(c.left_matrix(0, 0), 2500, 10);
    EXPECT_TRUE(contains(result.output, "warning: only 4 usable poses"));
    EXPECT_TRUE(std::filesystem::exists(root + "/report.html"));
    const auto uneven = run_picoscan(std::string("calibrate --stereo --board ") + test_support::kStereoBoardSpec + " --captures" + first + " --second-captures " +
                                     root + "/pose0_cam2 --out " + root + "/other.yml");
    EXPECT_EQ(uneven.exit_code, 1);
    EXPECT_TRUE(contains(uneven.output, "--second-captures: needs one folder per pose of --captures (4), got 1")) << uneven.output;
}

TEST(StereoCli, ScanWithTwoVirtualCameras) {
    const std::string root = test_support::make_temp_dir("stereo_scan");
    {
        std::FILE* scene = std::fopen((root + "/sphere.yml").c_str(), "w");
        ASSERT_NE(scene, nullptr);
        std::fputs("spheres: [{centre: [0, 0, 400], radius_mm: 25, albedo: 0.9}]\n", scene);
        std::fclose(scene);
    }
    const auto result = run_picoscan("scan --camera virtual --camera virtual --latency-ms 0 --shifts 4 --no-rows --scene " +
                                     root + "/sphere.yml --out " + root + "/scan");
    std::printf("%s", result.output.c_str());
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_TRUE(contains(result.output, "with 2 cameras"));
    EXPECT_TRUE(contains(result.output, "left-right consistency"));
    for (const char* file : {"/scan/stereo.yml", "/scan/captures/camera_1/sequence.json", "/scan/captures/camera_2/sequence.json",
                             "/scan/preview.png"})
        EXPECT_TRUE(std::filesystem::exists(root + file)) << file;
    const SphereFit fit = fit_sphere(to_point_cloud(read_view_ply(root + "/scan/cloud.ply")).points);
    std::printf("two-camera scan of the sphere: %zu points, diameter error %+.2f um, RMS %.2f um\n", fit.point_count,
                2000 * (fit.radius_mm - 25), 1000 * fit.rms_mm);
    EXPECT_GT(fit.point_count, 50000u);
    EXPECT_LT(std::abs(2 * fit.radius_mm - 50), 0.010);
    EXPECT_LT(fit.rms_mm, 0.020);
    // The captures reconstruct again through 'reconstruct' with the written stereo calibration.
    const auto again = run_picoscan("reconstruct --calibration " + root + "/scan/stereo.yml --captures " + root +
                                    "/scan/captures/camera_1 --second-captures " + root + "/scan/captures/camera_2 --out " +
                                    root + "/again.ply");
    EXPECT_EQ(again.exit_code, 0) << again.output;
    // Two real cameras need the stereo calibration; a camera-projector one is refused.
    const auto no_calibration = run_picoscan("scan --camera 0 --camera 1 --projector-screen 1 --out " + root + "/real");
    EXPECT_EQ(no_calibration.exit_code, 1);
    EXPECT_TRUE(contains(no_calibration.output, "--calibration: is required with real cameras")) << no_calibration.output;
    write_calibration(seed_rig_calibration(), root + "/camera_projector.yml");
    const auto wrong_kind = run_picoscan("scan --camera 0 --camera 1 --projector-screen 1 --calibration " + root +
                                         "/camera_projector.yml --out " + root + "/real");
    EXPECT_EQ(wrong_kind.exit_code, 1);
    EXPECT_TRUE(contains(wrong_kind.output, "is a camera-projector calibration; two cameras need")) << wrong_kind.output;
    EXPECT_FALSE(std::filesystem::exists(root + "/real"));
}
