// Multi-view registration on the simulator: the mechanical part scanned on a turntable in
// 8 views plus one from above, each view knocked by up to 10 degrees and 20 mm.
#include "picoscan/decode.h"
#include "picoscan/error.h"
#include "picoscan/register.h"
#include "picoscan/simulate.h"
#include "picoscan/triangulate.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <cstdio>

using namespace picoscan;

TEST(Register, TurntableViewsOfTheMechanicalPartAlignWithinTolerance) {
    const test_support::TurntableScan& scan = test_support::disturbed_turntable_scan();
    const Alignment alignment = align_views(scan.views, scan.names);
    for (const ViewAlignment& view : alignment.views)
        if (!view.aligned) std::printf("%s: %s\n", view.name.c_str(), view.problem.c_str());
    ASSERT_EQ(alignment.aligned_count(), static_cast<int>(scan.views.size()));
    double worst_deg = 0, worst_mm = 0;
    for (size_t i = 1; i < scan.views.size(); ++i) {
        const PoseDifference error = pose_difference(scan.true_view_to_model[i], alignment.views[i].pose, scan.centroid(i));
        std::printf("%s: rotation error %.4f deg, translation error %.4f mm, rms %.4f mm, overlap %.2f\n",
                    scan.names[i].c_str(), error.rotation_deg, error.translation_mm, alignment.views[i].rms_mm,
                    alignment.views[i].overlap);
        worst_deg = std::max(worst_deg, error.rotation_deg);
        worst_mm = std::max(worst_mm, error.translation_mm);
    }
    std::printf("worst pose error: %.4f deg, %.4f mm\n", worst_deg, worst_mm);
    EXPECT_LT(worst_deg, 0.05);
    EXPECT_LT(worst_mm, 0.05);
}

TEST(Register, PairwiseFeaturesThenIcpRecoverANeighbour) {
    const test_support::TurntableScan& scan = test_support::disturbed_turntable_scan();
    const PairRegistration pair = register_pair(scan.views[0], scan.views[1]);
    ASSERT_TRUE(pair.problem.empty()) << pair.problem;
    const cv::Matx44d truth = scan.true_view_to_model[1];  // view 1 -> view 0
    const PoseDifference error = pose_difference(truth, pair.transform, scan.centroid(1));
    std::printf("pair 0-1: %d matches, %d RANSAC inliers, overlap %.2f, rms %.4f mm, error %.4f deg %.4f mm\n",
                pair.feature_matches, pair.ransac_inliers, pair.overlap, pair.rms_mm, error.rotation_deg,
                error.translation_mm);
    EXPECT_GE(pair.ransac_inliers, 7);
    EXPECT_LT(error.rotation_deg, 0.1);
    EXPECT_LT(error.translation_mm, 0.1);
}

TEST(Register, ViewsThatDoNotOverlapAreReportedNotMerged) {
    const test_support::TurntableScan& scan = test_support::disturbed_turntable_scan();
    // Views 0 and 4 see opposite sides of the part.
    const PairRegistration pair = register_pair(scan.views[0], scan.views[4]);
    EXPECT_FALSE(pair.problem.empty());
    std::printf("opposite views: %s\n", pair.problem.c_str());

    const Alignment alignment = align_views({scan.views[0], scan.views[4]}, {"front.ply", "back.ply"});
    EXPECT_EQ(alignment.aligned_count(), 1);
    EXPECT_FALSE(alignment.views[1].aligned);
    EXPECT_NE(alignment.views[1].problem.find("could not be registered"), std::string::npos) << alignment.views[1].problem;
}

TEST(Register, ViewWithTooFewPointsIsNamed) {
    const test_support::TurntableScan& scan = test_support::disturbed_turntable_scan();
    ScanView sparse = scan.views[1];
    sparse.points.setTo(cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
    const Alignment alignment = align_views({scan.views[0], sparse}, {"a.ply", "empty.ply"});
    EXPECT_FALSE(alignment.views[1].aligned);
    EXPECT_NE(alignment.views[1].problem.find("too few points"), std::string::npos) << alignment.views[1].problem;
}

TEST(Register, TurntableAxisGuessReplacesFeatures) {
    // Undisturbed turntable: the axis is the part's z axis through its origin, seen from view 0.
    const test_support::TurntableScan& scan = test_support::turntable_scan();
    const cv::Matx44d part_to_camera = scan.part_to_camera[0];
    TurntableAxis axis;
    axis.point_mm = cv::Vec3d(part_to_camera(0, 3), part_to_camera(1, 3), part_to_camera(2, 3));
    axis.direction = cv::Vec3d(part_to_camera(0, 2), part_to_camera(1, 2), part_to_camera(2, 2));
    axis.step_deg = 45;
    // A slightly wrong axis (1 degree, 1 mm): ICP takes it the rest of the way.
    axis.point_mm += cv::Vec3d(1, 0, 0);
    axis.direction = cv::normalize(axis.direction + cv::Vec3d(0.017, 0, 0));
    std::vector<ScanView> ring(scan.views.begin(), scan.views.begin() + 8);
    std::vector<std::string> names(scan.names.begin(), scan.names.begin() + 8);
    const Alignment alignment = align_views(ring, names, {}, axis);
    ASSERT_EQ(alignment.aligned_count(), 8);
    for (size_t i = 1; i < ring.size(); ++i) {
        const PoseDifference error = pose_difference(scan.true_view_to_model[i], alignment.views[i].pose, scan.centroid(i));
        EXPECT_LT(error.rotation_deg, 0.05) << names[i];
        EXPECT_LT(error.translation_mm, 0.05) << names[i];
    }
}

TEST(Register, PoseDifferenceMeasuresAngleAndShift) {
    TurntableAxis axis{{0, 0, 0}, {0, 0, 1}, 30};
    const PoseDifference d = pose_difference(cv::Matx44d::eye(), turntable_pose(axis, 1));
    EXPECT_NEAR(d.rotation_deg, 30, 1e-9);
    EXPECT_NEAR(d.translation_mm, 0, 1e-9);
    axis.point_mm = {10, 0, 0};
    const PoseDifference shifted = pose_difference(cv::Matx44d::eye(), turntable_pose(axis, 3));  // 90 degrees
    EXPECT_NEAR(shifted.rotation_deg, 90, 1e-9);
    EXPECT_NEAR(shifted.translation_mm, 10 * std::sqrt(2.0), 1e-9);
}
