// Several placements, one model: each part scanned on the turntable standing (8 views), then
// flipped (8 views); the placements are aligned to each other by shape alone. A placement
// reported as aligned must put every view on the true part; one that cannot be told apart
// (a symmetric part, another part) must be refused with the reason.
#include "picoscan/register.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <unordered_map>

using namespace picoscan;
using test_support::kViewsPerPlacement;
using test_support::PlacementPart;

namespace {

std::vector<PlacementPlan> two_placements(const test_support::TurntableScan& scan, bool known_axis, bool round) {
    std::vector<PlacementPlan> plans(2);
    for (size_t v = 0; v < scan.views.size(); ++v) plans[v / kViewsPerPlacement].views.push_back(v);
    for (PlacementPlan& plan : plans) {
        plan.turntable_round = round;
        if (!known_axis) continue;
        // The table stays where it is: one axis (camera frame) for both placements, the
        // standing part's z axis through its bottom.
        const cv::Matx44d part = scan.part_to_camera[0];
        plan.turntable = TurntableAxis{{part(0, 3), part(1, 3), part(2, 3)}, {part(0, 2), part(1, 2), part(2, 2)},
                                       360.0 / kViewsPerPlacement};
    }
    return plans;
}

double percentile(std::vector<double> values, double fraction) {
    if (values.empty()) return 0;
    const size_t at = std::min(values.size() - 1, static_cast<size_t>(fraction * static_cast<double>(values.size())));
    std::nth_element(values.begin(), values.begin() + static_cast<long>(at), values.end());
    return values[at];
}

cv::Vec3d apply(const cv::Matx44d& t, const cv::Vec3d& p) {
    const cv::Vec4d q = t * cv::Vec4d(p[0], p[1], p[2], 1);
    return {q[0], q[1], q[2]};
}

// Points spread evenly over a mesh's surface (by area), for the truth -> model distance.
std::vector<cv::Vec3d> surface_samples(const Mesh& mesh, double per_mm2) {
    std::mt19937 random(11);
    std::uniform_real_distribution<double> unit(0, 1);
    std::vector<cv::Vec3d> samples;
    for (const cv::Vec3i& face : mesh.faces) {
        const cv::Vec3d a(mesh.vertices[face[0]]), b(mesh.vertices[face[1]]), c(mesh.vertices[face[2]]);
        const double area = 0.5 * cv::norm((b - a).cross(c - a));
        double expected = area * per_mm2;
        for (; expected > 0; expected -= 1) {
            if (expected < 1 && unit(random) > expected) break;
            double u = unit(random), w = unit(random);
            if (u + w > 1) u = 1 - u, w = 1 - w;
            samples.push_back(a + u * (b - a) + w * (c - a));
        }
    }
    return samples;
}

// Distance from each query to the nearest of `points`, capped at `reach` (a hash grid).
std::vector<double> nearest_distances(const std::vector<cv::Vec3d>& points, const std::vector<cv::Vec3d>& queries, double reach) {
    auto key = [&](long long x, long long y, long long z) { return (x * 73856093LL) ^ (y * 19349663LL) ^ (z * 83492791LL); };
    auto cell = [&](double v) { return static_cast<long long>(std::floor(v / reach)); };
    std::unordered_map<long long, std::vector<size_t>> grid;
    for (size_t i = 0; i < points.size(); ++i) grid[key(cell(points[i][0]), cell(points[i][1]), cell(points[i][2]))].push_back(i);
    std::vector<double> distances;
    for (const cv::Vec3d& q : queries) {
        double best = reach;
        for (long long dx = -1; dx <= 1; ++dx)
            for (long long dy = -1; dy <= 1; ++dy)
                for (long long dz = -1; dz <= 1; ++dz) {
                    const auto found = grid.find(key(cell(q[0]) + dx, cell(q[1]) + dy, cell(q[2]) + dz));
                    if (found == grid.end()) continue;
                    for (size_t i : found->second) best = std::min(best, cv::norm(points[i] - q));
                }
        distances.push_back(best);
    }
    return distances;
}

struct WholeModel {
    int aligned = 0, wrong = 0;
    double worst_deg = 0, worst_mm = 0;   // pose error of the aligned views against the truth
    double model_to_truth_p95 = 0;        // mm, every aligned view's points in the model frame
    double truth_covered = 0;             // share of the true surface within 0.5 mm of a model point
    double truth_to_model_p95 = 0;        // mm, over the covered part
};

// Judges every aligned view against the simulator's truth: its pose, and its points on the
// true part; then the whole model against the whole true surface.
WholeModel judge(const test_support::TurntableScan& scan, const Alignment& alignment, const std::string& label) {
    const test_support::MeshDistance truth(scan.part, 2.0);
    const cv::Matx44d model_to_part = scan.part_to_camera[0].inv();
    WholeModel result;
    std::vector<double> distances;
    std::vector<cv::Vec3d> model_points;
    for (size_t i = 0; i < alignment.views.size(); ++i) {
        const ViewAlignment& view = alignment.views[i];
        if (!view.aligned) {
            std::printf("%s %s: refused: %s\n", label.c_str(), view.name.c_str(), view.problem.c_str());
            continue;
        }
        const PoseDifference error = pose_difference(scan.true_view_to_model[i], view.pose, scan.centroid(i));
        std::vector<double> own;
        const PointCloud cloud = to_point_cloud(scan.views[i]);
        for (size_t k = 0; k < cloud.points.size(); ++k) {
            const cv::Vec3d p = apply(model_to_part * view.pose, cv::Vec3d(cloud.points[k]));
            if (k % 5 == 0) own.push_back(truth(p));
            model_points.push_back(p);
        }
        const double p95 = percentile(own, 0.95);
        const bool wrong = p95 > 0.5;
        std::printf("%s %s (placement %d): pose error %.4f deg %.4f mm, surface p95 %.3f mm%s\n", label.c_str(),
                    view.name.c_str(), view.placement + 1, error.rotation_deg, error.translation_mm, p95,
                    wrong ? "  <-- WRONG" : "");
        ++result.aligned;
        if (wrong) ++result.wrong;
        result.worst_deg = std::max(result.worst_deg, error.rotation_deg);
        result.worst_mm = std::max(result.worst_mm, error.translation_mm);
        distances.insert(distances.end(), own.begin(), own.end());
    }
    for (const PlacementAlignment& p : alignment.placements)
        std::printf("%s %s: %s, %d views, overlap %.2f, rms %.4f mm (views' own %.4f), stability %.4f, free-space %.3f, "
                    "%d other fits%s%s\n",
                    label.c_str(), p.name.c_str(), p.aligned ? "aligned" : "REFUSED", p.aligned_views, p.overlap, p.rms_mm,
                    p.noise_mm, p.stability, p.free_space_conflict, p.alternatives, p.problem.empty() ? "" : ": ",
                    p.problem.c_str());
    for (size_t k = 0; k < alignment.placements.size(); ++k) {
        const size_t first = k * kViewsPerPlacement;
        if (first >= scan.views.size()) break;
        const PoseDifference error = pose_difference(scan.true_view_to_model[first], alignment.placements[k].pose, scan.centroid(first));
        std::printf("%s placement %zu pose error %.4f deg %.4f mm\n", label.c_str(), k + 1, error.rotation_deg, error.translation_mm);
    }
    result.model_to_truth_p95 = percentile(distances, 0.95);
    const std::vector<cv::Vec3d> true_surface = surface_samples(scan.part, 1.0);
    const std::vector<double> to_model = nearest_distances(model_points, true_surface, 2.0);
    std::vector<double> covered;
    for (double d : to_model)
        if (d <= 0.5) covered.push_back(d);
    result.truth_covered = to_model.empty() ? 0 : static_cast<double>(covered.size()) / static_cast<double>(to_model.size());
    result.truth_to_model_p95 = percentile(covered, 0.95);
    std::printf("%s: %d of %zu views aligned, %d wrongly; worst pose error %.4f deg %.4f mm; model -> truth p95 %.4f mm; "
                "%.1f %% of the true surface within 0.5 mm of the model (p95 there %.4f mm)\n",
                label.c_str(), result.aligned, scan.views.size(), result.wrong, result.worst_deg, result.worst_mm,
                result.model_to_truth_p95, 100 * result.truth_covered, result.truth_to_model_p95);
    return result;
}

class TwoPlacements : public ::testing::TestWithParam<PlacementPart> {};

// Every view of both placements aligned without a guess of how the part was flipped.
TEST_P(TwoPlacements, KnownAxisAlignsEveryViewOnTheTruePart) {
    const test_support::TurntableScan& scan = test_support::two_placement_scan(GetParam());
    const Alignment alignment = align_placements(scan.views, scan.names, two_placements(scan, true, false));
    const WholeModel model = judge(scan, alignment, test_support::placement_part_name(GetParam()) + " axis");
    EXPECT_EQ(model.wrong, 0);
    EXPECT_EQ(model.aligned, static_cast<int>(scan.views.size()));
    ASSERT_EQ(alignment.placements.size(), 2u);
    EXPECT_TRUE(alignment.placements[1].aligned) << alignment.placements[1].problem;
    // Pose errors at each view's centroid; the surface error is the one a print would show.
    EXPECT_LT(model.worst_deg, 0.2);
    EXPECT_LT(model.worst_mm, 0.05);
    EXPECT_LT(model.model_to_truth_p95, 0.08);
    // Both placements together see most of the part (not the inside of the mechanical part's
    // through hole, about 9 % of its surface, nor what the half-resolution views lose at edges).
    EXPECT_GT(model.truth_covered, 0.8);
}

INSTANTIATE_TEST_SUITE_P(Parts, TwoPlacements,
                         ::testing::Values(PlacementPart::SpeckledMechanical, PlacementPart::GreyMechanical,
                                           PlacementPart::SteppedBlock, PlacementPart::HexWithPeg),
                         [](const ::testing::TestParamInfo<PlacementPart>& info) {
                             std::string name = test_support::placement_part_name(info.param);
                             std::replace(name.begin(), name.end(), '-', '_');
                             return name;
                         });

// The axis unknown: each placement's step estimated from its own views, then the placements
// joined by shape.
TEST(Placements, RoundsWithUnknownAxisAlignTheGreyPart) {
    const test_support::TurntableScan& scan = test_support::two_placement_scan(PlacementPart::GreyMechanical);
    const Alignment alignment = align_placements(scan.views, scan.names, two_placements(scan, false, true));
    const WholeModel model = judge(scan, alignment, "grey-mechanical round");
    EXPECT_EQ(model.wrong, 0);
    EXPECT_EQ(model.aligned, static_cast<int>(scan.views.size()));
    EXPECT_LT(model.worst_deg, 0.05);
    EXPECT_LT(model.worst_mm, 0.05);
}

// Built to fool it: a plain block looks the same upside down (a half turn fits as well), so
// its placements cannot be told apart and must be refused, never merged by a guess.
TEST(Placements, SymmetricBlockFlippedIsRefused) {
    const test_support::TurntableScan& scan = test_support::two_placement_scan(PlacementPart::Block);
    const Alignment alignment = align_placements(scan.views, scan.names, two_placements(scan, true, false));
    const WholeModel model = judge(scan, alignment, "block");
    EXPECT_EQ(model.wrong, 0);
    ASSERT_EQ(alignment.placements.size(), 2u);
    EXPECT_FALSE(alignment.placements[1].aligned);
    EXPECT_FALSE(alignment.placements[1].problem.empty());
    EXPECT_EQ(model.aligned, static_cast<int>(kViewsPerPlacement));  // the first placement stands alone
}

// Built to fool it: the grey part turned upside down shows, besides the bottom, only its
// upright sides to both placements, which leave the height free (and its near-twin, the part
// not flipped, fits tightly too). Right or refused.
TEST(Placements, UpsideDownGreyPartIsRightOrRefused) {
    const test_support::TurntableScan& scan = test_support::two_placement_scan(PlacementPart::GreyMechanicalUpsideDown);
    const Alignment alignment = align_placements(scan.views, scan.names, two_placements(scan, true, false));
    const WholeModel model = judge(scan, alignment, "grey-mechanical upside down");
    EXPECT_EQ(model.wrong, 0);
    ASSERT_EQ(alignment.placements.size(), 2u);
    if (!alignment.placements[1].aligned) {
        EXPECT_FALSE(alignment.placements[1].problem.empty());
    } else {
        EXPECT_LT(model.worst_deg, 0.1);
        EXPECT_LT(model.worst_mm, 0.1);
    }
}

// Built to fool it: the second placement is another part (the stepped block flipped) given as
// if it were the grey mechanical part turned over. Must be refused.
TEST(Placements, APlacementOfAnotherPartIsRefused) {
    const test_support::TurntableScan& grey = test_support::two_placement_scan(PlacementPart::GreyMechanical);
    const test_support::TurntableScan& other = test_support::two_placement_scan(PlacementPart::SteppedBlock);
    std::vector<ScanView> views;
    std::vector<std::string> names;
    for (size_t v = 0; v < kViewsPerPlacement; ++v) {
        views.push_back(grey.views[v]);
        names.push_back("grey-" + grey.names[v]);
    }
    for (size_t v = kViewsPerPlacement; v < 2 * kViewsPerPlacement; ++v) {
        views.push_back(other.views[v]);
        names.push_back("other-" + other.names[v]);
    }
    const Alignment alignment = align_placements(views, names, two_placements(grey, true, false));
    ASSERT_EQ(alignment.placements.size(), 2u);
    std::printf("another part: %s\n", alignment.placements[1].problem.c_str());
    EXPECT_TRUE(alignment.placements[0].aligned);
    EXPECT_FALSE(alignment.placements[1].aligned);
    EXPECT_FALSE(alignment.placements[1].problem.empty());
    for (size_t v = kViewsPerPlacement; v < views.size(); ++v) EXPECT_FALSE(alignment.views[v].aligned) << names[v];
}

}  // namespace
