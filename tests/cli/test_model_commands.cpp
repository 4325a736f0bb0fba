// picoscan clean / stitch / mesh, run as a user would on the turntable views of the
// mechanical part (written by write_view_ply, as 'picoscan reconstruct' writes them).
#include "picoscan/calibration.h"
#include "picoscan/io.h"
#include "picoscan/mesh.h"
#include "picoscan/register.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <tuple>

namespace fs = std::filesystem;
using namespace picoscan;
using test_support::cli_path;
using test_support::make_temp_dir;
using test_support::run_command;
using test_support::run_picoscan;
using Result = test_support::CliResult;

namespace {

std::string view_file(size_t index) {
    test_support::disturbed_turntable_scan();  // makes the cached view files
    return (fs::path(PICOSCAN_TEST_CACHE_DIR) / "turntable-v3-disturbed" / ("view_" + std::to_string(index) + ".ply")).string();
}

std::string file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
}

std::vector<cv::Matx44d> read_pose_file(const std::string& path) {
    std::ifstream in(path);
    std::vector<cv::Matx44d> poses;
    std::string line;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        cv::Matx44d pose;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) in >> pose(r, c);
        std::getline(in, line);
        poses.push_back(pose);
    }
    return poses;
}

// A small flat view: `rows` x 20 pixels of a 40 x 40 camera grid, at `depth_mm`.
ScanView flat_view(int rows, float depth_mm) {
    ScanView view;
    view.points = cv::Mat(40, 40, CV_32FC3, cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
    view.normals = cv::Mat::zeros(40, 40, CV_32FC3);
    for (int y = 0; y < rows; ++y)
        for (int x = 0; x < 20; ++x) {
            view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(0.5f * x, 0.5f * y, depth_mm);
            view.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(0, 0, -1);
        }
    view.camera_matrix = cv::Matx33d(2500, 0, 20, 0, 2500, 20, 0, 0, 1);
    return view;
}

}  // namespace

TEST(StitchCli, NeighbouringViewsMergeWithTheTruePoses) {
    const fs::path dir = make_temp_dir("stitch_cli");
    const std::string out = (dir / "merged.ply").string();
    const Result result = run_picoscan("stitch " + view_file(0) + " " + view_file(1) + " " + view_file(2) + " --out " + out);
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_NE(result.output.find("3 of 3 views merged"), std::string::npos) << result.output;
    const std::vector<cv::Matx44d> poses = read_pose_file((dir / "merged.poses.txt").string());
    ASSERT_EQ(poses.size(), 3u);
    const test_support::TurntableScan& scan = test_support::disturbed_turntable_scan();
    for (size_t i = 1; i < 3; ++i) {
        const PoseDifference error = pose_difference(scan.true_view_to_model[i], poses[i], scan.centroid(i));
        EXPECT_LT(error.rotation_deg, 0.05) << i;
        EXPECT_LT(error.translation_mm, 0.05) << i;
    }
    const Mesh merged = read_ply(out);
    EXPECT_EQ(merged.vertices.size(), static_cast<size_t>(scan.views[0].valid_count() + scan.views[1].valid_count() +
                                                          scan.views[2].valid_count()));
    EXPECT_EQ(merged.normals.size(), merged.vertices.size());
}

TEST(StitchCli, ViewsThatDoNotOverlapAreNamedAndWrittenUnmerged) {
    const fs::path dir = make_temp_dir("stitch_cli_apart");
    const std::string out = (dir / "merged.ply").string();
    const std::string before = file_bytes(view_file(4));
    const Result result = run_picoscan("stitch " + view_file(0) + " " + view_file(4) + " --out " + out);
    EXPECT_EQ(result.exit_code, 3) << result.output;
    EXPECT_NE(result.output.find("view_4.ply               NOT aligned"), std::string::npos) << result.output;
    EXPECT_NE(result.output.find("overlap"), std::string::npos) << result.output;
    EXPECT_TRUE(fs::exists(dir / "merged.unmerged-view_4.ply"));
    EXPECT_EQ(read_ply(out).vertices.size(), static_cast<size_t>(test_support::disturbed_turntable_scan().views[0].valid_count()));
    EXPECT_EQ(file_bytes(view_file(4)), before);  // inputs untouched
}

TEST(StitchCli, TheSameViewTwiceIsWarnedAboutAndAnotherOfTheSameSizeIsNot) {
    const fs::path dir = make_temp_dir("stitch_cli_same");
    const std::string a = (dir / "a.ply").string(), copy = (dir / "copy_of_a.ply").string();
    const std::string same_size = (dir / "b.ply").string(), smaller = (dir / "c.ply").string();
    write_view_ply(flat_view(20, 100), a);
    fs::copy_file(a, copy);
    write_view_ply(flat_view(20, 101), same_size);  // as many points: as many bytes, other bytes
    write_view_ply(flat_view(10, 100), smaller);
    ASSERT_EQ(fs::file_size(a), fs::file_size(same_size));
    ASSERT_NE(test_support::read_file_bytes(a), test_support::read_file_bytes(same_size));
    const Result result = run_picoscan("stitch " + a + " " + same_size + " " + smaller + " " + copy + " --out " +
                                       (dir / "merged.ply").string());
    const std::string warning = "picoscan stitch: warning: ";
    EXPECT_NE(result.output.find(warning + copy + " is the same view as " + a), std::string::npos) << result.output;
    size_t warnings = 0;
    for (size_t at = result.output.find(warning); at != std::string::npos; at = result.output.find(warning, at + 1)) ++warnings;
    EXPECT_EQ(warnings, 1u) << result.output;
}

TEST(MeshCli, PoissonOfStitchedViewsIsWatertightAndBadCloudsAreRefused) {
    const fs::path dir = make_temp_dir("mesh_cli");
    const std::string merged = (dir / "merged.ply").string();
    std::string views;
    for (size_t i = 0; i < 9; ++i) views += view_file(i) + " ";
    ASSERT_EQ(run_picoscan("stitch " + views + "--out " + merged).exit_code, 0);
    const std::string stl = (dir / "part.stl").string();
    const Result meshed = run_picoscan("mesh " + merged + " --out " + stl + " --spacing-mm 0.8 --target-faces 20000");
    ASSERT_EQ(meshed.exit_code, 0) << meshed.output;
    EXPECT_NE(meshed.output.find("; watertight;"), std::string::npos) << meshed.output;
    const MeshCheck check = check_mesh(read_stl(stl));
    EXPECT_TRUE(check.watertight()) << check.summary();
    // The target, or 1.5 or 2.25 times it where the simplified surface crossed itself and was
    // simplified again with more faces (27 258 faces in one run of three).
    EXPECT_GE(check.faces, 18000u) << check.summary();
    EXPECT_LE(check.faces, 45000u) << check.summary();
    EXPECT_FALSE(check.self_intersecting) << check.summary();

    const std::string empty = (dir / "empty.ply").string();
    write_ply(PointCloud{}, empty);
    const Result refused = run_picoscan("mesh " + empty + " --out " + (dir / "empty.stl").string());
    EXPECT_EQ(refused.exit_code, 1);
    EXPECT_NE(refused.output.find("empty: nothing to mesh"), std::string::npos) << refused.output;
    EXPECT_FALSE(fs::exists(dir / "empty.stl"));
    const Result bad_method = run_picoscan("mesh " + merged + " --out " + (dir / "x.stl").string() + " --method marching");
    EXPECT_EQ(bad_method.exit_code, 1);
    EXPECT_NE(bad_method.output.find("--method: must be poisson, advancing-front or grid"), std::string::npos);
    const Result missing = run_picoscan("mesh " + (dir / "nothing.ply").string() + " --out " + (dir / "x.stl").string());
    EXPECT_NE(missing.output.find("nothing.ply: no such file"), std::string::npos) << missing.output;
}

TEST(MeshCli, ACloudFarFromTheOriginIsRefusedOnOneLineNamingTheFile) {
    // A plane at 1e20 mm: before, CGAL printed a bare "not 3D" line (its lift of one point off a
    // flat cloud is lost to rounding there) and the command went on to "meshing produced no
    // triangles". A ball at 1e7 mm (float steps of 1 mm) was meshed into 41 pieces, exit 0.
    const fs::path dir = make_temp_dir("mesh_far");
    PointCloud plane, ball;
    for (int y = 0; y < 60; ++y)
        for (int x = 0; x < 60; ++x) {
            plane.points.emplace_back(1e20f + 1e13f * float(x), 1e20f + 1e13f * float(y), 1e20f);
            plane.normals.emplace_back(0.f, 0.f, 1.f);
            const double theta = CV_PI * (y + 0.5) / 60, phi = 2 * CV_PI * x / 60;
            const cv::Vec3f n(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)), float(std::cos(theta)));
            ball.points.push_back(cv::Vec3f(1e7f, 0.f, 0.f) + 20.f * n);
            ball.normals.push_back(n);
        }
    for (const auto& [cloud, method, distance] :
         {std::tuple{plane, "advancing-front", "1.73e+20"}, std::tuple{ball, "poisson", "1e+07"}}) {
        SCOPED_TRACE(method);
        const std::string far = (dir / "far.ply").string();
        write_ply(cloud, far);
        const Result refused = run_picoscan("mesh " + far + " --out " + (dir / "far.stl").string() + " --method " + method);
        EXPECT_EQ(refused.exit_code, 1);
        EXPECT_EQ(std::count(refused.output.begin(), refused.output.end(), '\n'), 1) << refused.output;
        EXPECT_NE(refused.output.find(far + ": point 0 lies " + distance + " mm from the origin, beyond 1 km"), std::string::npos)
            << refused.output;
        EXPECT_FALSE(fs::exists(dir / "far.stl"));
    }
}

TEST(CleanCli, FiltersReportTheirCountsAndTheInputStays) {
    const fs::path dir = make_temp_dir("clean_cli");
    const std::string calibration = (dir / "rig.yml").string();
    write_calibration(seed_rig_calibration(), calibration);
    const std::string input = view_file(0);
    const std::string before = file_bytes(input);
    const std::string out = (dir / "clean.ply").string();
    // A working-volume box that cuts the part in half (camera frame: keep x < 0).
    const Result result = run_picoscan("clean " + input + " --calibration " + calibration + " --out " + out +
                                       " --box -1000,-1000,0,0,1000,1000");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_NE(result.output.find("working volume: "), std::string::npos) << result.output;
    const ScanView cleaned = read_view_ply(out);
    const int kept = cleaned.valid_count(), had = read_view_ply(input).valid_count();
    EXPECT_GT(kept, had / 5);
    EXPECT_LT(kept, had * 4 / 5);
    for (const cv::Vec3f& p : to_point_cloud(cleaned).points) ASSERT_LT(p[0], 0.0f);
    EXPECT_EQ(file_bytes(input), before);

    // The view as its own background removes everything; the error says so and writes nothing.
    const Result all_gone = run_picoscan("clean " + input + " --calibration " + calibration + " --out " +
                                         (dir / "none.ply").string() + " --background " + input);
    EXPECT_EQ(all_gone.exit_code, 1);
    EXPECT_NE(all_gone.output.find("no point survived"), std::string::npos) << all_gone.output;
    EXPECT_FALSE(fs::exists(dir / "none.ply"));
    const Result overwrite = run_picoscan("clean " + input + " --calibration " + calibration + " --out " + input);
    EXPECT_NE(overwrite.output.find("would overwrite an input"), std::string::npos) << overwrite.output;
}

// A plain (unpainted) stepped block, 8 views of one turntable round. By features alone
// (--mode features), the views that cannot be placed for sure are named and left out, never
// merged wrongly; automatic (the default) tries features, falls back to the turntable round
// (axis estimated), which aligns all 8 onto the true part, and says which way placed each view.
// Built to fool the round: half the round (4 views 45 degrees apart, not a full round), where
// the round's equal steps would be 90 degrees; neither --turntable-round nor automatic may merge
// a view off its true pose.
TEST(StitchCli, PlainPartIsRightOrRefusedAndAutomaticFallsBackToTheRound) {
    const test_support::TurntableScan& scan = test_support::plain_turntable_scan(test_support::PlainPart::SteppedBlock);
    auto views_of = [&](size_t count) {
        std::string views;
        for (size_t i = 0; i < count; ++i)
            views += (fs::path(PICOSCAN_TEST_CACHE_DIR) / "plain-v2-stepped-block" / scan.names[i]).string() + " ";
        return views;
    };
    const fs::path dir = make_temp_dir("stitch_cli_plain");
    const std::string round = "turntable round (axis estimated)";
    struct Case {
        std::string name, options;
        size_t views;
        std::string kept;  // the method expected to place the views it merged
    };
    for (const Case& run : {Case{"features", " --mode features", 8, "features"}, Case{"automatic", "", 8, round},
                            Case{"round-half", " --turntable-round", 4, round}, Case{"automatic-half", "", 4, "features"}}) {
        const std::string out = (dir / (run.name + ".ply")).string();
        const Result result = run_picoscan("stitch " + views_of(run.views) + "--out " + out + run.options);
        const std::string all = std::to_string(run.views) + " of " + std::to_string(run.views) + " views";
        if (run.name == "automatic") {
            EXPECT_EQ(result.exit_code, 0) << result.output;
            EXPECT_NE(result.output.find(all + " merged"), std::string::npos) << result.output;
            // Features leave views out on the plain part; the round aligns them all and is kept.
            EXPECT_NE(result.output.find("by features: "), std::string::npos) << result.output;
            EXPECT_EQ(result.output.find("by features: " + all + " aligned"), std::string::npos) << result.output;
            EXPECT_NE(result.output.find("; not kept\nby " + round + ": " + all + " aligned; kept\n"), std::string::npos)
                << result.output;
        } else {
            EXPECT_TRUE(result.exit_code == 0 || result.exit_code == 3) << result.output;
            EXPECT_NE(result.output.find("by " + run.kept + ": "), std::string::npos) << result.output;
        }
        if (run.name == "automatic-half") {  // the round was tried and did not align more
            EXPECT_NE(result.output.find("by " + round + ": "), std::string::npos) << result.output;
            EXPECT_NE(result.output.find("; not kept\n"), std::string::npos) << result.output;
        }
        const std::vector<ViewPose> poses = read_poses(fs::path(out).replace_extension(".poses.txt").string());
        ASSERT_EQ(poses.size(), run.views);
        size_t merged = 0;
        for (size_t i = 0; i < poses.size(); ++i) {
            const std::string line_start = scan.names[i] + std::string(25 - scan.names[i].size(), ' ');
            if (!poses[i].aligned) {
                EXPECT_NE(result.output.find(line_start + "NOT aligned: "), std::string::npos) << result.output;
                continue;
            }
            ++merged;
            EXPECT_NE(result.output.find(line_start + "aligned by " + run.kept + ": residual "), std::string::npos)
                << result.output;
            if (i == 0) continue;
            const PoseDifference error = pose_difference(scan.true_view_to_model[i], poses[i].pose, scan.centroid(i));
            EXPECT_LT(error.rotation_deg, 0.1) << run.name << " " << i;
            EXPECT_LT(error.translation_mm, 0.1) << run.name << " " << i;
        }
        std::printf("%s (%zu views): %zu merged\n", run.name.c_str(), run.views, merged);
    }
    // --help teaches the modes; the mode is one of three, and not given with a guess of its own.
    const Result help = run_picoscan("stitch --help");
    EXPECT_EQ(help.exit_code, 0);
    EXPECT_NE(help.output.find("--mode automatic|features|turntable-round  see above (default automatic)"), std::string::npos)
        << help.output;
    const std::string out = (dir / "never.ply").string();
    const Result unknown = run_picoscan("stitch " + views_of(2) + "--out " + out + " --mode sideways");
    EXPECT_EQ(unknown.exit_code, 1);
    EXPECT_NE(unknown.output.find("--mode: must be automatic, features or turntable-round, got 'sideways'"), std::string::npos)
        << unknown.output;
    const Result with_axis = run_picoscan("stitch " + views_of(2) + "--out " + out + " --mode features --turntable 0,0,400,0,1,0");
    EXPECT_EQ(with_axis.exit_code, 1);
    EXPECT_NE(with_axis.output.find("--mode: give either --turntable (axis known) or --mode (no guess)"), std::string::npos)
        << with_axis.output;
    EXPECT_FALSE(fs::exists(out));
}

TEST(CleanCli, ViewsCarryTheirCameraSoNoCalibrationIsNeeded) {
    const fs::path dir = make_temp_dir("clean_camera");
    const std::string input = view_file(1);
    const Calibration rig = seed_rig_calibration();
    const ScanView view = read_view_ply(input);
    EXPECT_EQ(view.camera_matrix, rig.camera_matrix);
    EXPECT_EQ(cv::norm(view.camera_distortion, rig.camera_distortion), 0.0);

    const std::string out = (dir / "clean.ply").string();
    const Result cleaned = run_picoscan("clean " + input + " --out " + out);
    ASSERT_EQ(cleaned.exit_code, 0) << cleaned.output;
    EXPECT_EQ(read_view_ply(out).camera_matrix, rig.camera_matrix);
    const Result grid = run_picoscan("mesh " + out + " --method grid --mesh-step 2 --out " + (dir / "grid.stl").string());
    ASSERT_EQ(grid.exit_code, 0) << grid.output;
    EXPECT_GT(read_stl((dir / "grid.stl").string()).faces.size(), 10000u);

    // A view written before views stored their camera: clean asks for the calibration.
    ScanView old = view;
    old.camera_matrix = cv::Matx33d::zeros();
    const std::string old_file = (dir / "old.ply").string();
    write_view_ply(old, old_file);
    const Result refused = run_picoscan("clean " + old_file + " --out " + (dir / "old-clean.ply").string());
    EXPECT_EQ(refused.exit_code, 1);
    EXPECT_NE(refused.output.find(old_file + ": does not store its camera"), std::string::npos) << refused.output;
    EXPECT_FALSE(fs::exists(dir / "old-clean.ply"));
}

TEST(CleanCli, CoreRangeChecksNameTheFlag) {
    const fs::path dir = make_temp_dir("clean_ranges");
    const Result result = run_picoscan("clean " + view_file(0) + " --outlier-sigma 0.1 --out " + (dir / "c.ply").string());
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("error: --outlier-sigma: must be 0.5..1000"), std::string::npos) << result.output;
    const Result mesh = run_picoscan("mesh " + view_file(0) + " --spacing-mm -1 --out " + (dir / "m.stl").string());
    EXPECT_EQ(mesh.exit_code, 1);
    EXPECT_NE(mesh.output.find("error: --spacing-mm: must be 0..100"), std::string::npos) << mesh.output;
    EXPECT_FALSE(fs::exists(dir / "c.ply"));
    EXPECT_FALSE(fs::exists(dir / "m.stl"));
}

// One view meshed with --fill open: the band surface, open and all measured, its faces on the view's points.
TEST(MeshCli, FillOpenMeshesOneViewOnItsPoints) {
    const fs::path dir = make_temp_dir("mesh_fill_open");
    const std::string stl = (dir / "open.stl").string();
    const Result meshed = run_picoscan("mesh " + view_file(0) + " --fill open --out " + stl);
    ASSERT_EQ(meshed.exit_code, 0) << meshed.output;
    EXPECT_NE(meshed.output.find("NOT watertight"), std::string::npos) << meshed.output;
    EXPECT_NE(meshed.output.find("0 non-manifold edges, 0 non-manifold vertices"), std::string::npos) << meshed.output;
    EXPECT_NE(meshed.output.find("0.0 % of the surface filled in"), std::string::npos) << meshed.output;
    const Mesh mesh = read_stl(stl);
    EXPECT_GT(mesh.faces.size(), 50000u);
    // No face beyond the view's depth range (Poisson closed a view into a bubble behind it).
    const PointCloud cloud = to_point_cloud(read_view_ply(view_file(0)));
    float deepest = 0;
    for (const cv::Vec3f& p : cloud.points) deepest = std::max(deepest, p[2]);
    float mesh_deepest = 0;
    for (const cv::Vec3f& v : mesh.vertices) mesh_deepest = std::max(mesh_deepest, v[2]);
    EXPECT_LT(mesh_deepest, deepest + 1.0f);
}

// Two placements of the plain grey part (standing, then on its side), given with --then: each
// placement a turntable round about the same axis, the placements joined by shape alone. The
// poses file records each view's placement.
TEST(StitchCli, TwoPlacementsGivenWithThenMergeOnTheTruePart) {
    const test_support::TurntableScan& scan = test_support::two_placement_scan(test_support::PlacementPart::GreyMechanical);
    std::string views;
    for (size_t i = 0; i < scan.views.size(); ++i) {
        if (i == test_support::kViewsPerPlacement) views += "--then ";
        const std::string folder = i < test_support::kViewsPerPlacement ? "half-v1-grey-mechanical-standing"
                                                                        : "half-v1-grey-mechanical-on-its-side";
        views += (fs::path(PICOSCAN_TEST_CACHE_DIR) / folder / ("view_" + std::to_string(i % test_support::kViewsPerPlacement) + ".ply"))
                     .string() + " ";
    }
    const cv::Matx44d part = scan.part_to_camera[0];
    char axis[200];
    std::snprintf(axis, sizeof axis, " --turntable %.6f,%.6f,%.6f,%.6f,%.6f,%.6f", part(0, 3), part(1, 3), part(2, 3), part(0, 2),
                  part(1, 2), part(2, 2));
    const fs::path dir = make_temp_dir("stitch_cli_placements");
    const std::string out = (dir / "merged.ply").string();
    const Result result = run_picoscan("stitch " + views + "--out " + out + axis);
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_NE(result.output.find("16 of 16 views merged"), std::string::npos) << result.output;
    EXPECT_NE(result.output.find("placement 2              aligned to the others"), std::string::npos) << result.output;
    const std::vector<ViewPose> poses = read_poses(fs::path(out).replace_extension(".poses.txt").string());
    ASSERT_EQ(poses.size(), scan.views.size());
    EXPECT_EQ(poses[8].name, "half-v1-grey-mechanical-on-its-side_view_0.ply");  // file names repeat: folder_file
    for (size_t i = 0; i < poses.size(); ++i) {
        EXPECT_EQ(poses[i].placement, i < test_support::kViewsPerPlacement ? 0 : 1) << i;
        const PoseDifference error = pose_difference(scan.true_view_to_model[i], poses[i].pose, scan.centroid(i));
        EXPECT_LT(error.rotation_deg, 0.05) << i;
        EXPECT_LT(error.translation_mm, 0.05) << i;
    }
    // --then with no views before it, or placements of different sizes without a step: one-line errors.
    const Result empty_first = run_picoscan("stitch --then " + views.substr(0, views.find("--then")) + "--out " + out + "2.ply");
    EXPECT_EQ(empty_first.exit_code, 1);
    EXPECT_NE(empty_first.output.find("--then"), std::string::npos) << empty_first.output;
}
