// One placement of the mechanical part (the turntable views merged with their true poses; the
// bottom never seen), closed at the table, left open, or refused; the shape of the capped
// mesh itself (chamfer angle, 90 degree edges, hole diameter); the meshing budget and
// cancelling. One Poisson run per test (each test runs in its own process).
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "picoscan/mesh.h"
#include "picoscan/pipeline.h"
#include "picoscan/preview.h"
#include "support/test_support.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

using namespace picoscan;

namespace {

// The views of the disturbed turntable scan merged with their true poses, in view 0's frame.
struct OnePlacement {
    PointCloud merged;
    cv::Matx44d part_to_model;
};

const OnePlacement& one_placement() {
    static const OnePlacement placement = [] {
        const test_support::TurntableScan& scan = test_support::disturbed_turntable_scan();
        std::vector<ScanView> views = scan.views;
        for (size_t i = 0; i < views.size(); ++i) views[i].pose = scan.true_view_to_model[i];
        return OnePlacement{merge_views(views), scan.part_to_camera[0]};
    }();
    return placement;
}

double true_volume_mm3(const MechanicalPartShape& shape) {
    const double block = shape.length_mm * shape.width_mm * shape.height_mm;
    const double chamfer = shape.chamfer_mm * shape.chamfer_mm / 2 * shape.height_mm;
    const double hole = CV_PI * std::pow(shape.hole_diameter_mm / 2, 2) * shape.height_mm;
    const double boss = CV_PI * std::pow(shape.boss_diameter_mm / 2, 2) * shape.boss_height_mm;
    return block - chamfer - hole + boss;
}

// The mesh's vertices in the part frame.
std::vector<cv::Vec3d> in_part_frame(const Mesh& mesh, const cv::Matx44d& part_to_model) {
    const cv::Matx44d model_to_part = part_to_model.inv();
    std::vector<cv::Vec3d> out;
    for (const cv::Vec3f& v : mesh.vertices) {
        const cv::Vec4d p = model_to_part * cv::Vec4d(v[0], v[1], v[2], 1);
        out.emplace_back(p[0], p[1], p[2]);
    }
    return out;
}

// Unit normal of the least-squares plane through the points.
cv::Vec3d plane_normal(const std::vector<cv::Vec3d>& points) {
    cv::Vec3d centre(0, 0, 0);
    for (const cv::Vec3d& p : points) centre += p;
    centre *= 1.0 / static_cast<double>(points.size());
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (const cv::Vec3d& p : points) scatter += (p - centre) * (p - centre).t();
    cv::Matx31d values;
    cv::Matx33d vectors;
    cv::eigen(scatter, values, vectors);
    return {vectors(2, 0), vectors(2, 1), vectors(2, 2)};
}

double angle_deg(const cv::Vec3d& a, const cv::Vec3d& b) {
    return std::acos(std::min(1.0, std::abs(a.dot(b)))) * 180 / CV_PI;
}

}  // namespace

// The table cap: the plane fitted from the rim of the unseen side (no axis given). The volume
// is the part's, the cap is declared filled, and the shape holds on the mesh itself.
TEST(MeshFill, TableCapClosesOnePlacementAtThePartsVolume) {
    const OnePlacement& placement = one_placement();
    MeshOptions options;
    options.fill = MeshFill::Table;
    const Mesh mesh = mesh_points(placement.merged, options);
    const MeshCheck check = check_mesh(mesh);
    const MechanicalPartShape shape;
    const double truth = true_volume_mm3(shape);
    std::printf("one placement, table cap: %s\n", check.summary().c_str());
    std::printf("volume %.1f mm^3, true %.1f mm^3 (%+.2f %%)\n", check.volume_mm3, truth,
                100 * (check.volume_mm3 / truth - 1));
    // The merged cloud and the mesh's contact sheet, for the docs and the CLI.
    const std::string folder = std::string(PICOSCAN_TEST_CACHE_DIR) + "/one-placement";
    std::filesystem::create_directories(folder);
    write_ply(placement.merged, folder + "/merged.ply");
    write_contact_sheet_png(mesh, folder + "/table_cap.png");
    std::printf("merged cloud and contact sheet in %s\n", folder.c_str());
    ASSERT_TRUE(check.closed_volume);
    EXPECT_NEAR(check.volume_mm3, truth, 0.01 * truth);
    // The cap (50 x 36 mm less the hole and chamfer: about 19 % of the surface) and the hole's
    // unseen lower wall are filled, not measured.
    EXPECT_GT(check.filled_fraction, 0.15);
    EXPECT_LT(check.filled_fraction, 0.35);
    EXPECT_NE(check.summary().find("WARNING"), std::string::npos);

    // Nothing below the table, and the cap is flat on it.
    const std::vector<cv::Vec3d> part = in_part_frame(mesh, placement.part_to_model);
    double lowest = 1e9;
    for (const cv::Vec3d& p : part) lowest = std::min(lowest, p[2]);
    std::printf("lowest vertex %.3f mm above the true table\n", lowest);
    EXPECT_NEAR(lowest, 0.0, 0.1);

    // The shape, measured on the mesh's vertices in regions of the part away from edges.
    const double hx = shape.length_mm / 2, hy = shape.width_mm / 2, h = shape.height_mm, c = shape.chamfer_mm;
    std::vector<cv::Vec3d> chamfer, right, back, front, top;
    std::vector<cv::Vec2d> hole_wall;
    const double margin = 1.5, near = 0.3;
    for (const cv::Vec3d& p : part) {
        const bool mid_height = p[2] > margin && p[2] < h - margin;
        const double along_chamfer = (p[1] - p[0] + hx - hy + c) / std::sqrt(2.0);  // 0 .. c * sqrt 2
        if (mid_height && std::abs((p[0] + p[1] - (hx + hy - c)) / std::sqrt(2.0)) < near && along_chamfer > margin &&
            along_chamfer < c * std::sqrt(2.0) - margin)
            chamfer.push_back(p);
        if (mid_height && std::abs(p[0] - hx) < near && p[1] > -hy + margin && p[1] < hy - c - margin) right.push_back(p);
        if (mid_height && std::abs(p[1] - hy) < near && p[0] > -hx + margin && p[0] < hx - c - margin) back.push_back(p);
        if (mid_height && std::abs(p[1] + hy) < near && p[0] > -hx + margin && p[0] < hx - margin) front.push_back(p);
        const cv::Vec2d xy(p[0], p[1]);
        if (std::abs(p[2] - h) < near && std::abs(p[0]) < hx - margin && std::abs(p[1]) < hy - margin &&
            p[0] + p[1] < hx + hy - c - margin &&
            cv::norm(xy - shape.boss_centre_mm) > shape.boss_diameter_mm / 2 + margin &&
            cv::norm(xy - shape.hole_centre_mm) > shape.hole_diameter_mm / 2 + margin)
            top.push_back(p);
        if (p[2] > 2 && p[2] < h - 2 && std::abs(cv::norm(xy - shape.hole_centre_mm) - shape.hole_diameter_mm / 2) < 0.5)
            hole_wall.push_back(xy);
    }
    for (const auto* region : {&chamfer, &right, &back, &front, &top}) ASSERT_GT(region->size(), 50u);
    ASSERT_GT(hole_wall.size(), 50u);
    const double chamfer_to_right = angle_deg(plane_normal(chamfer), plane_normal(right));
    const double chamfer_to_back = angle_deg(plane_normal(chamfer), plane_normal(back));
    const double right_to_front = angle_deg(plane_normal(right), plane_normal(front));
    const double top_to_front = angle_deg(plane_normal(top), plane_normal(front));
    const double top_to_right = angle_deg(plane_normal(top), plane_normal(right));
    const double diameter = test_support::circle_diameter(hole_wall);
    std::printf("on the mesh: chamfer %.3f / %.3f deg to its sides (true 45), right-front %.3f deg, top-front %.3f deg, "
                "top-right %.3f deg (true 90); hole %.4f mm from %zu vertices (true %.4f, %+.1f um)\n",
                chamfer_to_right, chamfer_to_back, right_to_front, top_to_front, top_to_right, diameter,
                hole_wall.size(), shape.hole_diameter_mm, 1000 * (diameter - shape.hole_diameter_mm));
    EXPECT_NEAR(chamfer_to_right, 45.0, 0.1);
    EXPECT_NEAR(chamfer_to_back, 45.0, 0.1);
    EXPECT_NEAR(right_to_front, 90.0, 0.1);
    EXPECT_NEAR(top_to_front, 90.0, 0.1);
    EXPECT_NEAR(top_to_right, 90.0, 0.1);
    EXPECT_NEAR(diameter, shape.hole_diameter_mm, 0.020);
}

// The turntable axis given (the part's z in the model frame, either sign): the same cap. A
// wrong axis (across the part) is refused: the unseen side's edge is not on a plane across it.
TEST(MeshFill, TableFromTheTurntableAxisAndAWrongAxisRefused) {
    const OnePlacement& placement = one_placement();
    MeshOptions options;
    options.fill = MeshFill::Table;
    options.sample_spacing_mm = 0.8;  // coarser: this test is about the plane, not the detail
    const cv::Vec3d up(placement.part_to_model(0, 2), placement.part_to_model(1, 2), placement.part_to_model(2, 2));
    options.table_axis = -up;
    const Mesh mesh = mesh_points(placement.merged, options);
    const MeshCheck check = check_mesh(mesh);
    const double truth = true_volume_mm3(MechanicalPartShape{});
    std::printf("table from the axis: %s (%+.2f %%)\n", check.summary().c_str(), 100 * (check.volume_mm3 / truth - 1));
    ASSERT_TRUE(check.closed_volume);
    EXPECT_NEAR(check.volume_mm3, truth, 0.015 * truth);

    options.table_axis = cv::Vec3d(placement.part_to_model(0, 0), placement.part_to_model(1, 0), placement.part_to_model(2, 0));
    try {
        mesh_points(placement.merged, options);
        FAIL() << "capped across a wrong axis";
    } catch (const Error& e) {
        std::printf("wrong axis refused: %s\n", e.what());
        EXPECT_NE(std::string(e.what()).find("mesh.fill"), std::string::npos);
    }
}

// Open: nothing invented; the bottom stays open and no vertex is below the table.
TEST(MeshFill, OpenLeavesTheUnseenSideOpen) {
    const OnePlacement& placement = one_placement();
    MeshOptions options;
    options.fill = MeshFill::Open;
    options.sample_spacing_mm = 0.8;
    const Mesh mesh = mesh_points(placement.merged, options);
    const MeshCheck check = check_mesh(mesh);
    std::printf("one placement, open: %s\n", check.summary().c_str());
    EXPECT_FALSE(check.watertight());
    EXPECT_GT(check.border_edges, 100u);
    EXPECT_LT(check.filled_fraction, 0.02);
    EXPECT_EQ(check.summary().find("WARNING"), std::string::npos);
    double lowest = 1e9;
    for (const cv::Vec3d& p : in_part_frame(mesh, placement.part_to_model)) lowest = std::min(lowest, p[2]);
    // A vertex counts as measured within twice the spacing of the points (1.6 mm here): the
    // open edge may hang that far past the lowest points, no farther.
    EXPECT_GT(lowest, -1.7);
}

namespace {

// A bumpy closed surface sampled as densely as one full camera view: 1600 x 1200 points
// (0.2 mm apart on a 60 mm ball), normals outwards.
PointCloud dense_ball() {
    PointCloud cloud;
    for (int y = 0; y < 1200; ++y)
        for (int x = 0; x < 1600; ++x) {
            const double theta = CV_PI * (y + 0.5) / 1200, phi = 2 * CV_PI * x / 1600;
            const cv::Vec3d direction(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
            const double radius = 30 + 1.5 * std::sin(3 * phi) * std::sin(2 * theta);
            cloud.points.emplace_back(cv::Vec3f(direction * radius + cv::Vec3d(0, 0, 400)));
            cloud.normals.emplace_back(cv::Vec3f(direction));  // close enough to the bumps' normals for the sign
        }
    return cloud;
}

// Two meshings of the same points: the same vertices in the same order, the same faces.
void expect_same_mesh(const char* what, const Mesh& first, const Mesh& second) {
    std::printf("%s, meshed twice: %zu and %zu vertices\n", what, first.vertices.size(), second.vertices.size());
    ASSERT_EQ(first.vertices.size(), second.vertices.size());
    EXPECT_TRUE(first.vertices == second.vertices);
    EXPECT_TRUE(first.faces == second.faces);
}

}  // namespace

// The budget bounds the work whatever the data: 1.9 million points meshed with a small budget
// give a mesh the size of the budget (timings are in bench_mesh, not here).
TEST(MeshBudget, PointAndFaceBudgetsBoundTheMesh) {
    const PointCloud ball = dense_ball();
    MeshOptions options;
    options.sample_spacing_mm = 0;  // keep every point: only the budget thins
    options.max_points = 20000;
    options.max_faces = 60000;
    std::vector<std::string> stages;
    const Mesh mesh = mesh_points(ball, options, [&](double, const std::string& stage) {
        if (stages.empty() || stages.back() != stage) stages.push_back(stage);
        return true;
    });
    const MeshCheck check = check_mesh(mesh);
    std::printf("1.9 M points on a ball, budget 20 000 points / 60 000 faces: %s\n", check.summary().c_str());
    for (const std::string& stage : stages) std::printf("  stage: %s\n", stage.c_str());
    EXPECT_LT(check.faces, 60000u);
    EXPECT_GT(check.faces, 5000u);
    EXPECT_NE(std::find(stages.begin(), stages.end(), "Poisson: meshing the surface"), stages.end());
}

// Cancelling stops the reconstruction in each stage, also from inside CGAL's normal
// estimation, Delaunay refinement and surface mesher (their second reports come from there)
// and from the assembly of the linear system: no further progress is reported.
TEST(MeshBudget, CancelStopsPoissonInEachStage) {
    const PointCloud ball = dense_ball();
    const std::pair<std::string, int> stops[] = {{"estimating normals", 2},
                                                 {"Poisson: triangulating the points", 1},
                                                 {"Poisson: refining the triangulation", 2},
                                                 {"Poisson: assembling the system", 1},
                                                 {"Poisson: solving the implicit function", 1},
                                                 {"Poisson: meshing the surface", 2}};
    for (const auto& [stop_at, nth] : stops) {
        MeshOptions options;
        options.max_points = 20000;
        int seen = 0, calls_after = 0;
        bool cancelled = false;
        try {
            mesh_points(ball, options, [&, stop_at = stop_at, nth = nth](double, const std::string& stage) {
                if (cancelled) ++calls_after;
                if (stage == stop_at && ++seen == nth) cancelled = true;
                return !cancelled;
            });
            FAIL() << "meshing went on after cancel at " << stop_at;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("cancel"), std::string::npos) << e.what();
        }
        EXPECT_TRUE(cancelled) << stop_at;
        EXPECT_EQ(calls_after, 0) << stop_at;
    }
}

// The points' preparation (PCA normals, then the average spacing: 2 to 8 s on a 462 613-point
// view) reports from inside CGAL and stops there on cancel, the spacing too. 120 000 points kept
// (no thinning): each stage reports many times before it is cancelled near its start.
TEST(MeshBudget, CancelStopsTheNormalsAndSpacingEstimation) {
    const PointCloud dense = dense_ball();
    PointCloud ball;  // every 16th point: 120 000
    for (size_t i = 0; i < dense.points.size(); i += 16) {
        ball.points.push_back(dense.points[i]);
        ball.normals.push_back(dense.normals[i]);
    }
    for (const std::string stop_at : {"estimating normals", "measuring the spacing"}) {
        MeshOptions options;
        options.sample_spacing_mm = 0;
        options.max_points = 200000;  // above the 120 000: nothing thinned
        std::vector<double> fractions;  // reported in the stopped stage
        int calls_after = 0;
        bool cancelled = false;
        try {
            mesh_points(ball, options, [&](double fraction, const std::string& stage) {
                if (cancelled) ++calls_after;
                if (stage != stop_at) return !cancelled;
                fractions.push_back(fraction);
                // The third report: from inside CGAL (the normals' first report comes before it starts).
                if (fractions.size() == 3) cancelled = true;
                return !cancelled;
            });
            FAIL() << "meshing went on after cancel at " << stop_at;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find("cancel"), std::string::npos) << e.what();
        }
        ASSERT_EQ(fractions.size(), 3u) << stop_at;
        std::printf("%s: cancelled at %.4f of the meshing (reports at %.4f %.4f %.4f)\n", stop_at.c_str(), fractions[2],
                    fractions[0], fractions[1], fractions[2]);
        // Reports advance inside the stage, within the preparation's tenth of the meshing.
        EXPECT_LT(fractions[0], fractions[1]) << stop_at;
        EXPECT_LT(fractions[1], fractions[2]) << stop_at;
        EXPECT_LT(fractions[2], 0.1) << stop_at;
        EXPECT_EQ(calls_after, 0) << stop_at;
    }
}

// Poisson then simplification to a few thousand faces (the FreeCAD case: spacing 1 mm, 4000
// faces) on two parts of different shapes, the views merged with their true poses: the simplified
// surface must not cross itself (edge collapses near the through hole and the boss folded
// faces through each other).
TEST(MeshBudget, SimplifiedPoissonMeshDoesNotCrossItself) {
    struct Case {
        std::string name;
        PointCloud merged;
    };
    std::vector<Case> cases{{"mechanical part", one_placement().merged}};
    for (test_support::PlainPart part : {test_support::PlainPart::SteppedBlock}) {
        const test_support::TurntableScan& scan = test_support::plain_turntable_scan(part);
        std::vector<ScanView> views = scan.views;
        for (size_t i = 0; i < views.size(); ++i) views[i].pose = scan.true_view_to_model[i];
        cases.push_back({test_support::plain_part_name(part), merge_views(views)});
    }
    for (const Case& c : cases) {
        for (int target : {4000, 1500}) {
            MeshOptions options;
            options.sample_spacing_mm = 1.0;
            options.target_faces = target;
            const MeshCheck check = check_mesh(mesh_points(c.merged, options));
            std::printf("%s, spacing 1 mm, target %d faces: %s\n", c.name.c_str(), target, check.summary().c_str());
            EXPECT_FALSE(check.self_intersecting) << c.name << ", target " << target;
            EXPECT_TRUE(check.watertight()) << c.name << ", target " << target;
            // The budget is hard: collapses that would make the surface cross itself are refused,
            // others made instead (it used to grow 1.5 times per retry, up to 5060 faces for 1500).
            EXPECT_LE(check.faces, size_t(target * 1.05)) << c.name;
            EXPECT_GE(check.faces, size_t(target * 0.95)) << c.name;
        }
    }
}

// One view closed by Poisson (its unseen side invented): the surface mesher leaves holes in the
// closing bubble (188 border edges and 4 components on the mechanical view before they were
// filled), and the filled holes crossed the bubble's other sheet (about 300 pairs of faces before
// the repair). The mesh must be one closed component that does not cross itself, with the unseen
// side marked filled. Two different parts: the mechanical part and the plain stepped block.
// The same points give the same mesh, also the second time in one process (FreeCAD, MeshLab):
// CGAL's mesher orders its queues by handle, and with memory addresses as handles the order
// followed the heap's state (three meshings of one view in one process gave three meshes).
TEST(MeshFill, PoissonGivesTheSameMeshAgainInOneProcess) {
    const ScanView& view = test_support::plain_turntable_scan(test_support::PlainPart::SteppedBlock).views[0];
    MeshOptions options;
    options.fill = MeshFill::Poisson;
    options.sample_spacing_mm = 2.0;
    const Mesh first = mesh_view(view, options);
    const auto stirred = test_support::stir_heap();
    const Mesh second = mesh_view(view, options);
    expect_same_mesh("stepped block view 0 at 2 mm", first, second);
}

// Poisson's own triangulation splits its worst cells first, and of equally bad cells (many, on
// points of an exact grid) the one whose handle sorts first: with handles ordered by memory
// address, the same points gave another surface after an unrelated meshing in the process (the
// holed block of test_sharpen: its unseen hole wall 519 um off the true wall alone, 1.2 um after
// Mesh.EmptyAndDegenerateCloudsAreRefused). A box sampled on an exact grid, meshed, then again
// after an advancing-front meshing of a flat sheet (the trigger found) and a stirred heap.
TEST(MeshFill, PoissonIgnoresWhatRanBeforeInTheProcess) {
    PointCloud box;
    const int nx = 40, ny = 32, nz = 24;  // 0.5 mm steps: a 20 x 16 x 12 mm box
    auto add = [&](double x, double y, double z, float nxv, float nyv, float nzv) {
        box.points.emplace_back(float(0.5 * x), float(0.5 * y), float(0.5 * z));
        box.normals.emplace_back(nxv, nyv, nzv);
    };
    for (int i = 0; i <= nx; ++i)
        for (int j = 0; j <= ny; ++j) add(i, j, 0, 0, 0, -1), add(i, j, nz, 0, 0, 1);
    for (int i = 0; i <= nx; ++i)
        for (int k = 1; k < nz; ++k) add(i, 0, k, 0, -1, 0), add(i, ny, k, 0, 1, 0);
    for (int j = 1; j < ny; ++j)
        for (int k = 1; k < nz; ++k) add(0, j, k, -1, 0, 0), add(nx, j, k, 1, 0, 0);
    MeshOptions options;
    options.fill = MeshFill::Poisson;
    const Mesh first = mesh_cloud(box, options);
    PointCloud sheet;
    for (int y = 0; y < 40; ++y)
        for (int x = 0; x < 40; ++x) sheet.points.emplace_back(x * 0.5f, y * 0.5f, 400.f), sheet.normals.emplace_back(0.f, 0.f, -1.f);
    MeshOptions open_surface;
    open_surface.method = MeshMethod::AdvancingFront;
    ASSERT_GT(mesh_cloud(sheet, open_surface).faces.size(), 2000u);
    const auto stirred = test_support::stir_heap();
    const Mesh second = mesh_cloud(box, options);
    expect_same_mesh("grid box", first, second);
}

TEST(MeshFill, PoissonClosesASingleView) {
    const std::vector<std::pair<std::string, const ScanView*>> views = {
        {"mechanical view 2", &test_support::disturbed_turntable_scan().views[2]},
        {"stepped block view 0", &test_support::plain_turntable_scan(test_support::PlainPart::SteppedBlock).views[0]}};
    for (const auto& [name, view] : views) {
        MeshOptions options;
        options.fill = MeshFill::Poisson;
        const MeshCheck check = check_mesh(mesh_view(*view, options));
        std::printf("%s alone, fill poisson: %s\n", name.c_str(), check.summary().c_str());
        EXPECT_TRUE(check.watertight()) << name;
        EXPECT_EQ(check.border_edges, 0u) << name;
        EXPECT_EQ(check.components, 1u) << name;
        EXPECT_FALSE(check.self_intersecting) << name;
        EXPECT_TRUE(check.closed_volume) << name;
        EXPECT_GT(check.volume_mm3, 0) << name;
        // One view sees about a third of the part: most of the closed surface is invented.
        EXPECT_GT(check.filled_fraction, 0.4) << name;
    }
}
