// The complete model of two placements judged against the true part: each part scanned
// standing and on its side (the two-placement views the placement tests use), stitched as
// the demo stitches (each placement one turntable round, its step estimated; the placements
// joined by shape), meshed by the demo's recipe (Poisson), then measured: enclosed volume,
// truth -> mesh over the whole outer surface of the true part, mesh -> truth over the whole
// mesh, and the share the mesh says it filled in.
#include "picoscan/deviation.h"
#include "picoscan/pipeline.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <string>

using namespace picoscan;
using test_support::kViewsPerPlacement;
using test_support::PlacementPart;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Points spread evenly over a mesh's surface (by area).
std::vector<cv::Vec3f> surface_samples(const Mesh& mesh, double per_mm2) {
    std::mt19937 random(11);
    std::uniform_real_distribution<double> unit(0, 1);
    std::vector<cv::Vec3f> samples;
    for (const cv::Vec3i& face : mesh.faces) {
        const cv::Vec3d a(mesh.vertices[face[0]]), b(mesh.vertices[face[1]]), c(mesh.vertices[face[2]]);
        for (double expected = 0.5 * cv::norm((b - a).cross(c - a)) * per_mm2; expected > 0; expected -= 1) {
            if (expected < 1 && unit(random) > expected) break;
            double u = unit(random), w = unit(random);
            if (u + w > 1) u = 1 - u, w = 1 - w;
            samples.emplace_back(a + u * (b - a) + w * (c - a));
        }
    }
    return samples;
}

// The true parts are built of solids standing on each other (the mechanical part's boss sunk
// 1 mm into the block, the step on the slab, the peg on the hex): the faces where they meet
// lie inside the part. Each part's true volume, and a test for those inner faces.
struct TruePart {
    double volume_mm3;
    std::function<bool(const cv::Vec3f&)> inner;  // part frame
};

TruePart true_part(PlacementPart part) {
    const double eps = 1e-4;
    switch (part) {
    case PlacementPart::GreyMechanical:
    case PlacementPart::SpeckledMechanical: {
        const MechanicalPartShape s;
        const double volume = s.length_mm * s.width_mm * s.height_mm - s.chamfer_mm * s.chamfer_mm / 2 * s.height_mm -
                              kPi * std::pow(s.hole_diameter_mm / 2, 2) * s.height_mm +
                              kPi * std::pow(s.boss_diameter_mm / 2, 2) * s.boss_height_mm;
        return {volume, [s, eps](const cv::Vec3f& p) {
                    return cv::norm(cv::Vec2d(p[0], p[1]) - s.boss_centre_mm) < s.boss_diameter_mm / 2 + eps &&
                           p[2] < s.height_mm + eps;
                }};
    }
    case PlacementPart::SteppedBlock:  // 46 x 30 x 12 slab, 20 x 30 x 14 step on x 3..23
        return {46.0 * 30 * 12 + 20.0 * 30 * 14,
                [eps](const cv::Vec3f& p) { return std::abs(p[2] - 12) < eps && p[0] > 3 - eps; }};
    case PlacementPart::HexWithPeg: {  // hexagon of radius 20, 18 high; 32-gon peg of radius 3.5 at (8, 3), 6 high
        const double hex = 1.5 * std::sqrt(3.0) * 20 * 20, peg = 16 * 3.5 * 3.5 * std::sin(2 * kPi / 32);
        return {hex * 18 + peg * 6,
                [eps](const cv::Vec3f& p) { return std::abs(p[2] - 18) < eps && cv::norm(cv::Vec2d(p[0] - 8, p[1] - 3)) < 3.5 + eps; }};
    }
    default: break;
    }
    throw std::logic_error("no true volume for this part");
}

// Where a deviation lies on the true part: the point, and the faces of the truth within
// 0.1 mm of it by their outward normals (one: a face; two: an edge; three: a corner). A
// faceted cylinder's facets count as one surface when their normals are within 15 degrees.
std::string place_on_truth(const Mesh& truth, const cv::Vec3f& at) {
    const cv::Vec3d p(at);
    std::vector<std::pair<double, cv::Vec3d>> faces;  // distance, outward normal
    double nearest = 1e30;
    for (const cv::Vec3i& f : truth.faces) {
        const cv::Vec3d a(truth.vertices[f[0]]), b(truth.vertices[f[1]]), c(truth.vertices[f[2]]);
        const cv::Vec3d n = (b - a).cross(c - a);
        if (cv::norm(n) < 1e-12) continue;
        const double d = cv::norm(test_support::closest_on_triangle(p, a, b, c) - p);
        nearest = std::min(nearest, d);
        faces.emplace_back(d, cv::normalize(n));
    }
    std::vector<cv::Vec3d> surfaces;
    for (const auto& [d, n] : faces) {
        if (d > nearest + 0.1) continue;
        bool known = false;
        for (const cv::Vec3d& s : surfaces) known = known || s.dot(n) > std::cos(15 * kPi / 180);
        if (!known) surfaces.push_back(n);
    }
    char text[400];
    int used = std::snprintf(text, sizeof text, "at (%.2f, %.2f, %.2f), %.3f mm from the truth, %s", p[0], p[1], p[2],
                             nearest, surfaces.size() == 1 ? "a face" : surfaces.size() == 2 ? "an edge" : "a corner");
    for (const cv::Vec3d& n : surfaces)
        used += std::snprintf(text + used, sizeof text - size_t(used), " (%.2f %.2f %.2f)", n[0], n[1], n[2]);
    return text;
}

// The sample farthest from the other surface.
size_t farthest(const DeviationMap& map) {
    size_t worst = 0;
    for (size_t i = 0; i < map.distances_mm.size(); ++i)
        if (std::abs(map.distances_mm[i]) > std::abs(map.distances_mm[worst])) worst = i;
    return worst;
}

struct ModelAccuracy {
    double volume_mm3 = 0, true_volume_mm3 = 0;
    double volume_error() const { return volume_mm3 / true_volume_mm3 - 1; }
    double filled = 0;                                        // share of the mesh's area filled in
    DeviationStatistics truth_to_mesh, mesh_to_truth;         // mm
    bool closed = false;
    int views_merged = 0;
};

// Stitched (or, to judge the meshing alone, merged with the true poses) and meshed as the
// demo does it; measured in the true part's frame.
ModelAccuracy complete_model(PlacementPart part, bool stitch_views_first) {
    const test_support::TurntableScan& scan = test_support::two_placement_scan(part);
    PointCloud merged;
    int views_merged = 0;
    if (stitch_views_first) {
        StitchOptions stitch;
        for (size_t v = 0; v < scan.views.size(); ++v)
            stitch.placement_of_view.push_back(static_cast<int>(v / kViewsPerPlacement));
        stitch.registration.turntable_round = true;
        StitchResult stitched = stitch_views(scan.views, scan.names, stitch);
        merged = std::move(stitched.merged);
        views_merged = static_cast<int>(stitched.merged_views.size());
    } else {
        std::vector<ScanView> views = scan.views;
        for (size_t v = 0; v < views.size(); ++v) views[v].pose = scan.true_view_to_model[v];
        merged = merge_views(views);
        views_merged = static_cast<int>(views.size());
    }
    const Mesh model = mesh_points(merged, MeshOptions{});
    // The model frame is the first view's camera; into the part's frame.
    const Mesh mesh = transformed(model, scan.part_to_camera[0].inv());
    const MeshCheck check = check_mesh(mesh);
    const TruePart truth = true_part(part);
    ModelAccuracy accuracy;
    accuracy.views_merged = views_merged;
    accuracy.closed = check.closed_volume;
    accuracy.volume_mm3 = check.volume_mm3;
    accuracy.true_volume_mm3 = truth.volume_mm3;
    accuracy.filled = check.filled_fraction;
    std::vector<cv::Vec3f> outer;
    for (const cv::Vec3f& p : surface_samples(scan.part, 4.0))
        if (!truth.inner(p)) outer.push_back(p);
    const DeviationMap truth_to_mesh = measure_deviation(outer, mesh);
    const std::vector<cv::Vec3f> mesh_samples = surface_samples(mesh, 4.0);
    const DeviationMap mesh_to_truth = measure_deviation(mesh_samples, scan.part);
    accuracy.truth_to_mesh = truth_to_mesh.statistics;
    accuracy.mesh_to_truth = mesh_to_truth.statistics;
    const std::string name = test_support::placement_part_name(part);
    std::printf("%s, two placements, %s: %d of %zu views merged; %s\n", name.c_str(),
                stitch_views_first ? "stitched" : "true poses", accuracy.views_merged, scan.views.size(),
                check.summary().c_str());
    std::printf("%s: volume %.1f mm^3, true %.1f mm^3 (%+.3f %%); filled %.1f %%\n", name.c_str(), accuracy.volume_mm3,
                truth.volume_mm3, 100 * accuracy.volume_error(), 100 * accuracy.filled);
    std::printf("%s: truth -> mesh over %zu points of the outer surface: mean %.1f um, p95 %.1f um, max %.1f um\n",
                name.c_str(), outer.size(), 1000 * accuracy.truth_to_mesh.mean_abs_mm,
                1000 * accuracy.truth_to_mesh.p95_abs_mm, 1000 * accuracy.truth_to_mesh.max_abs_mm);
    std::printf("%s: mesh -> truth over %zu points of the mesh: mean %.1f um, p95 %.1f um, max %.1f um\n", name.c_str(),
                accuracy.mesh_to_truth.count, 1000 * accuracy.mesh_to_truth.mean_abs_mm,
                1000 * accuracy.mesh_to_truth.p95_abs_mm, 1000 * accuracy.mesh_to_truth.max_abs_mm);
    const size_t worst_truth = farthest(truth_to_mesh), worst_mesh = farthest(mesh_to_truth);
    std::printf("%s: truth -> mesh max %+.1f um %s\n", name.c_str(), 1000 * truth_to_mesh.distances_mm[worst_truth],
                place_on_truth(scan.part, outer[worst_truth]).c_str());
    std::printf("%s: mesh -> truth max %+.1f um %s\n", name.c_str(), 1000 * mesh_to_truth.distances_mm[worst_mesh],
                place_on_truth(scan.part, mesh_samples[worst_mesh]).c_str());
    return accuracy;
}

}  // namespace

// The built-in part (plain grey), the demo's case. Issue 12's targets: volume within 0.5 %,
// truth -> mesh mean 15 um, p95 40 um, max 150 um; mesh -> truth p95 40 um, max 150 um. The
// volume, the means and the p95s are met since edges are sharpened and the hole's unseen
// middle is put on its fitted wall (sharpen.cpp). Since the unseen wall also goes on to the
// bottom face it opens on (the rim an edge, no longer Poisson's rounding) and edge points are
// judged by their distance from the edge's line (2026-11-23, branch maxima): max 92-107 um and
// 135-155 um in the runs listed in docs/multiview.md (before: 230-341 and 227-424 um, the rim;
// before the sharpening 984 and 1426 um). Since the rim's cuts that land on one point of the
// line are one vertex (branch corners, 2026-11-24): 101-106 and 39-117 um in four runs (the
// stitching is not the same in every run; before, on the same views: 106.7 and 152.5 um); the
// issue's 150 um asserted.
TEST(PlacementModel, MechanicalPartCompleteModelAgainstTheTruth) {
    const ModelAccuracy model = complete_model(PlacementPart::GreyMechanical, true);
    EXPECT_EQ(model.views_merged, 16);
    ASSERT_TRUE(model.closed);
    EXPECT_LT(std::abs(model.volume_error()), 0.002);
    EXPECT_LT(model.filled, 0.06);
    EXPECT_LT(model.truth_to_mesh.mean_abs_mm, 0.010);
    EXPECT_LT(model.truth_to_mesh.p95_abs_mm, 0.020);
    EXPECT_LT(model.truth_to_mesh.max_abs_mm, 0.150);
    EXPECT_LT(model.mesh_to_truth.p95_abs_mm, 0.020);
    EXPECT_LT(model.mesh_to_truth.max_abs_mm, 0.150);
}

// Beyond the demo part: a stepped block and a hexagon with a peg, meshed by the same recipe.
// Their views are merged with the true poses (their stitching is judged in test_placements),
// which keeps this suite's time down and judges the meshing alone. Both placements see all of
// them: nothing is filled in, and what is left is at a few corners (reached, block / hex, since
// edge points are judged by their distance from the edge's line: max 185-299 / 39-80 um and
// 143-166 / 37-140 um; before, 239-332 / 142-230 um and 190-231 / 151-254 um; before the
// sharpening 476 / 363 um and 289 / 257 um; means and p95s as asserted, see docs/multiview.md).
// Since the corners are sharpened (branch corners, 2026-11-24): 102 / 72 um and 104 / 55 um
// (before, on the same views: 184 / 80 um and 149 / 154 um); the 150 um asserted.
TEST(PlacementModel, OtherPartsCompleteModelsAgainstTheTruth) {
    for (PlacementPart part : {PlacementPart::SteppedBlock, PlacementPart::HexWithPeg}) {
        const ModelAccuracy model = complete_model(part, false);
        EXPECT_EQ(model.views_merged, 16);
        ASSERT_TRUE(model.closed);
        EXPECT_LT(std::abs(model.volume_error()), 0.002);
        EXPECT_LT(model.filled, 0.01);
        EXPECT_LT(model.truth_to_mesh.mean_abs_mm, 0.004);
        EXPECT_LT(model.truth_to_mesh.p95_abs_mm, 0.006);
        EXPECT_LT(model.truth_to_mesh.max_abs_mm, 0.150);
        EXPECT_LT(model.mesh_to_truth.p95_abs_mm, 0.006);
        EXPECT_LT(model.mesh_to_truth.max_abs_mm, 0.150);
    }
}
