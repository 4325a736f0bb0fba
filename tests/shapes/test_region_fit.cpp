// Fitting where the user points: picked regions of synthetic scans (20 um noise) must get the
// right kind (a flat chamfer is a plane, not a huge cylinder), the right size, the constraints
// asked for, and nominal sizes only when the points allow them.
#include "picoscan/error.h"
#include "picoscan/pipeline.h"
#include "picoscan/region_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Scan {
    PointCloud cloud;
    std::mt19937 random{11};
    std::normal_distribution<double> noise;
    explicit Scan(double sigma_mm) : noise(0.0, sigma_mm) {}
    void add(const cv::Vec3d& point, const cv::Vec3d& normal) {
        const cv::Vec3d unit = cv::normalize(normal);
        cloud.points.emplace_back(point + noise(random) * unit);
        cloud.normals.emplace_back(unit);
    }
};

std::vector<int> all_of(const PointCloud& cloud) {
    std::vector<int> indices(cloud.points.size());
    for (size_t i = 0; i < indices.size(); ++i) indices[i] = int(i);
    return indices;
}

// Part of a hole's wall (radius r, axis along `axis` through `centre`), the arc seen from one side.
void add_hole_wall(Scan& scan, const cv::Vec3d& centre, const cv::Vec3d& axis, double radius, double from_deg, double to_deg) {
    const cv::Vec3d u = cv::normalize(axis.cross(cv::Vec3d(0.3, 1, 0.2))), v = axis.cross(u);
    for (int i = 0; i <= 60; ++i)
        for (int j = 0; j <= 40; ++j) {
            const double angle = (from_deg + (to_deg - from_deg) * i / 60.0) * kPi / 180;
            const cv::Vec3d radial = std::cos(angle) * u + std::sin(angle) * v;
            scan.add(centre + radius * radial + (j * 0.2 - 4) * axis, -radial);  // a hole: normals inwards
        }
}

}  // namespace

TEST(RegionFit, FlatChamferIsAPlaneAndItsAngleIsRight) {
    for (double sigma : {0.005, 0.02, 0.04}) {
        Scan scan(sigma);
        const cv::Vec3d normal = cv::normalize(cv::Vec3d(1, 1, 0));  // a 45 degree chamfer
        const cv::Vec3d along = cv::normalize(cv::Vec3d(1, -1, 0));
        for (int i = 0; i <= 50; ++i)
            for (int j = 0; j <= 100; ++j) scan.add(cv::Vec3d(21, 14, 0) + (i * 0.2 - 5) * along + cv::Vec3d(0, 0, j * 0.2), normal);
        const RegionFit fit = fit_region(scan.cloud, all_of(scan.cloud));
        SCOPED_TRACE(fit.report);
        ASSERT_EQ(fit.shape.kind, ShapeKind::Plane);
        EXPECT_LT(std::acos(std::min(1.0, fit.shape.direction.dot(normal))) * 180 / kPi, 0.1);
        EXPECT_NEAR(fit.shape.rms_mm, sigma, 0.2 * sigma);
        EXPECT_GT(fit.cylinder_rms_mm, 0);  // the cylinder was tried, and not taken
    }
}

TEST(RegionFit, HoleWallIsACylinderOfTheRightDiameter) {
    for (double sigma : {0.01, 0.02, 0.04}) {
        for (double arc : {60.0, 120.0, 360.0}) {
            Scan scan(sigma);
            const cv::Vec3d axis = cv::normalize(cv::Vec3d(0.1, -0.2, 1));
            add_hole_wall(scan, cv::Vec3d(-11, 0, 12), axis, 5.0, 10, 10 + arc);
            const RegionFit fit = fit_region(scan.cloud, all_of(scan.cloud));
            SCOPED_TRACE(fit.report);
            ASSERT_EQ(fit.shape.kind, ShapeKind::Cylinder);
            // A 60 degree arc fixes the radius less well: within 3 standard errors at 40 um noise.
            EXPECT_NEAR(2 * fit.shape.radius_mm, 10.0, arc < 100 ? 0.06 : 0.02);
            EXPECT_LT(std::acos(std::min(1.0, std::abs(fit.shape.direction.dot(axis)))) * 180 / kPi, 0.5);
        }
    }
}

TEST(RegionFit, SphereAndConeAreTold) {
    Scan ball(0.02);
    for (int i = 0; i <= 40; ++i)
        for (int j = 0; j <= 40; ++j) {
            const double theta = (20 + 50.0 * i / 40) * kPi / 180, phi = (90.0 * j / 40) * kPi / 180;
            const cv::Vec3d n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
            ball.add(cv::Vec3d(3, 4, 400) + 12.5 * n, n);
        }
    const RegionFit sphere = fit_region(ball.cloud, all_of(ball.cloud));
    SCOPED_TRACE(sphere.report);
    ASSERT_EQ(sphere.shape.kind, ShapeKind::Sphere);
    EXPECT_NEAR(sphere.shape.radius_mm, 12.5, 0.02);

    Scan countersink(0.02);
    const double half_angle = 45 * kPi / 180;
    for (int i = 0; i <= 40; ++i)
        for (int j = 0; j <= 90; ++j) {
            const double along = 4 + 6.0 * i / 40, phi = 2 * kPi * j / 90;
            const cv::Vec3d radial(std::cos(phi), std::sin(phi), 0);
            const cv::Vec3d normal = std::cos(half_angle) * radial - std::sin(half_angle) * cv::Vec3d(0, 0, 1);
            countersink.add(cv::Vec3d(0, 0, along) + along * std::tan(half_angle) * radial, normal);
        }
    const RegionFit cone = fit_region(countersink.cloud, all_of(countersink.cloud));
    SCOPED_TRACE(cone.report);
    ASSERT_EQ(cone.shape.kind, ShapeKind::Cone);
    EXPECT_NEAR(cone.shape.half_angle_deg, 45, 0.1);
}

TEST(RegionFit, ConstraintsHoldAndSizesSnapOnlyWhenTheyFit) {
    Scan scan(0.02);
    const cv::Vec3d axis = cv::normalize(cv::Vec3d(0.02, 0, 1));  // 1.15 degrees off the reference z
    add_hole_wall(scan, cv::Vec3d(0, 0, 0), axis, 4.99, 0, 200);
    RegionFitOptions options;
    options.constraint = FitConstraint::Parallel;
    options.reference_direction = cv::Vec3d(0, 0, 1);
    const RegionFit parallel = fit_region(scan.cloud, all_of(scan.cloud), options);
    EXPECT_EQ(parallel.shape.kind, ShapeKind::Cylinder) << parallel.report;
    EXPECT_NEAR(std::abs(parallel.shape.direction[2]), 1.0, 1e-12);

    options.constraint = FitConstraint::Coaxial;
    options.reference_point = cv::Vec3d(0.5, 0, 0);
    const RegionFit coaxial = fit_region(scan.cloud, all_of(scan.cloud), options);
    EXPECT_LT(cv::norm((coaxial.shape.point - cv::Vec3d(0.5, 0, 0)).cross(cv::Vec3d(0, 0, 1))), 1e-9);

    options.constraint = FitConstraint::Perpendicular;
    options.reference_direction = cv::Vec3d(1, 0, 0);
    const RegionFit square = fit_region(scan.cloud, all_of(scan.cloud), options);
    EXPECT_LT(std::abs(square.shape.direction[0]), 1e-9);

    // Free fit: diameter 9.98. A 0.5 mm nominal step snaps it to 10.0 when the tolerance allows
    // 20 um and the points stay within the noise; a 10 um tolerance does not snap it.
    RegionFitOptions snap;
    snap.snap_step_mm = 0.5;
    snap.snap_tolerance_mm = 0.05;
    const RegionFit snapped = fit_region(scan.cloud, all_of(scan.cloud), snap);
    EXPECT_NEAR(2 * snapped.fitted_radius_mm, 9.98, 0.01);
    EXPECT_TRUE(snapped.snapped) << snapped.report;
    EXPECT_DOUBLE_EQ(snapped.shape.radius_mm, 5.0);
    snap.snap_tolerance_mm = 0.01;
    const RegionFit strict = fit_region(scan.cloud, all_of(scan.cloud), snap);
    EXPECT_FALSE(strict.snapped) << strict.report;
    EXPECT_NEAR(strict.shape.radius_mm, 4.99, 0.005);
    // A whole 9.8 mm hole forced to 10 mm would leave 0.1 mm residuals (5 x the noise): refused.
    Scan whole(0.02);
    add_hole_wall(whole, cv::Vec3d(0, 0, 0), axis, 4.9, 0, 360);
    snap.snap_step_mm = 1.0;
    snap.snap_tolerance_mm = 0.3;
    const RegionFit forced = fit_region(whole.cloud, all_of(whole.cloud), snap);
    EXPECT_FALSE(forced.snapped) << forced.report;
    EXPECT_NE(forced.report.find("would exceed"), std::string::npos) << forced.report;
    EXPECT_NEAR(forced.shape.radius_mm, 4.9, 0.005);

    RegionFitOptions plane_coaxial;
    plane_coaxial.automatic = false;
    plane_coaxial.kind = ShapeKind::Plane;
    plane_coaxial.constraint = FitConstraint::Coaxial;
    EXPECT_THROW(fit_region(scan.cloud, all_of(scan.cloud), plane_coaxial), Error);
}

TEST(RegionFit, TwoSurfacesAtOnceAreRefusedWhenTheNoiseIsKnown) {
    Scan scan(0.02);
    for (int i = 0; i <= 40; ++i)
        for (int j = 0; j <= 40; ++j) {
            scan.add(cv::Vec3d(i * 0.2, j * 0.2, 0), cv::Vec3d(0, 0, 1));
            scan.add(cv::Vec3d(i * 0.2, 0, j * 0.2), cv::Vec3d(0, -1, 0));
        }
    RegionFitOptions options;
    options.noise_mm = 0.02;
    EXPECT_THROW(fit_region(scan.cloud, all_of(scan.cloud), options), Error);
    EXPECT_THROW(fit_region(scan.cloud, {0, 1, 2}), Error);
    EXPECT_THROW(fit_region(scan.cloud, std::vector<int>(20, 999999)), Error);
}

// A 10 x 10 mm floor (z = 0, 2601 points on a 0.2 mm grid) meeting a wall (y = 0) at a 90° edge.
Scan floor_and_wall() {
    Scan scan(0.01);
    for (int i = 0; i <= 50; ++i)
        for (int j = 0; j <= 50; ++j) {
            scan.add(cv::Vec3d(i * 0.2, j * 0.2, 0), cv::Vec3d(0, 0, 1));
            if (j > 0) scan.add(cv::Vec3d(i * 0.2, 0, j * 0.2), cv::Vec3d(0, -1, 0));
        }
    return scan;
}

TEST(RegionFit, GrowingFromASeedStopsAtTheEdge) {
    Scan scan = floor_and_wall();
    RegionSelection selection;
    selection.radius_mm = 100;
    selection.grow = true;
    selection.max_gap_mm = 0.5;
    const std::vector<int> floor = select_region(scan.cloud, cv::Vec3d(5, 5, 0.1), selection);
    EXPECT_EQ(floor.size(), 51u * 51u);
    selection.grow = false;
    selection.radius_mm = 1.0;
    const std::vector<int> ball = select_region(scan.cloud, cv::Vec3d(5, 5, 0.1), selection);
    EXPECT_GT(ball.size(), 60u);
    EXPECT_LT(ball.size(), 90u);
    EXPECT_THROW(select_region(PointCloud{}, cv::Vec3d(0, 0, 0)), Error);
}

// A gap too fine for the points' distance from the origin is refused naming max_gap_mm: the
// flood's cube numbers (coordinate / gap, 1e10 here) did not fit an int, undefined behaviour.
TEST(RegionFit, AGapTooFineForThePointsIsRefused) {
    const Scan scan = floor_and_wall();
    RegionSelection selection;
    selection.radius_mm = 100;
    selection.grow = true;
    selection.max_gap_mm = 1e-9;
    try {
        select_region(scan.cloud, cv::Vec3d(5, 5, 0.1), selection);
        ADD_FAILURE() << "a gap of 1e-9 mm was taken";
    } catch (const Error& error) {
        EXPECT_EQ(error.subject(), "max_gap_mm") << error.what();
    }
    selection.max_gap_mm = 0.5;
    EXPECT_EQ(select_region(scan.cloud, cv::Vec3d(5, 5, 0.1), selection).size(), 51u * 51u);
}

TEST(RegionFit, BoxAndLassoSelectExactlyThePointsInsideAndTheRecipeFitsThem) {
    Scan scan = floor_and_wall();
    // A box 2 x 1 x 0.5 mm (half sizes) turned 90 degrees about z around (5, 5, 0): x spans 1 mm
    // across the floor's y and 2 mm along its x: 11 x 21 grid points.
    RegionSelection selection;
    selection.box_half_size_mm = {1.0, 2.0, 0.5};
    selection.box_axes = cv::Matx33d(0, 1, 0, -1, 0, 0, 0, 0, 1);
    const std::vector<int> box = select_region(scan.cloud, cv::Vec3d(5, 5, 0.1), selection);
    EXPECT_EQ(box.size(), 11u * 21u);
    selection.box_half_size_mm = {1.0, 0.0, 0.5};
    EXPECT_THROW(select_region(scan.cloud, cv::Vec3d(5, 5, 0), selection), Error);
    selection.box_half_size_mm = {1.0, 1.0, 1.0};
    selection.box_axes = cv::Matx33d(1, 0, 0, 0, 2, 0, 0, 0, 1);
    EXPECT_THROW(select_region(scan.cloud, cv::Vec3d(5, 5, 0), selection), Error);

    // A lasso seen by an eye 5 mm above the floor looking down (screen = 50 px x (x, y) / (5 - z):
    // 10 px per mm on the floor): a triangle over the floor takes the floor's points under it;
    // the wall (y = 0) projects onto the screen's y = 0, outside the triangle.
    const cv::Matx44d top_view(50, 0, 0, 0, 0, 50, 0, 0, 0, 0, 0, 0, 0, 0, -1, 5);
    const std::vector<cv::Vec2d> triangle = {{11, 11}, {90, 11}, {11, 90}};  // off the grid's 2 px steps
    const std::vector<int> lasso = select_in_polygon(scan.cloud, top_view, triangle);
    size_t expected = 0;
    for (const cv::Vec3f& p : scan.cloud.points) {
        const double x = 10 * p[0], y = 10 * p[1];
        if (std::abs(p[2]) < 0.1 && x > 11 && y > 11 && x + y < 101) ++expected;
    }
    EXPECT_EQ(lasso.size(), expected);
    EXPECT_GT(lasso.size(), 500u);
    for (int i : lasso) EXPECT_LT(std::abs(scan.cloud.points[i][2]), 0.1f);  // floor points only
    EXPECT_THROW(select_in_polygon(scan.cloud, top_view, {{0, 0}, {1, 1}}), Error);

    // The recipe: the lasso's points are the floor, a plane with its normal up; the default
    // grown face from a point on the wall is the wall, a plane with its normal along -y.
    const PickedFit floor = fit_in_lasso(scan.cloud, top_view, triangle);
    EXPECT_EQ(floor.fit.shape.kind, ShapeKind::Plane);
    EXPECT_GT(std::abs(floor.fit.shape.direction[2]), 0.9999);
    PickedFitOptions options;
    options.selection.max_gap_mm = 0.5;
    const PickedFit wall = fit_at_point(scan.cloud, cv::Vec3d(5, 0, 5), options);
    EXPECT_EQ(wall.region.size(), 51u * 50u);
    EXPECT_EQ(wall.fit.shape.kind, ShapeKind::Plane);
    EXPECT_GT(-wall.fit.shape.direction[1], 0.9999);
    int reports = 0;
    EXPECT_THROW(fit_at_point(scan.cloud, cv::Vec3d(5, 0, 5), options,
                              [&](double, const std::string&) { return ++reports < 3; }),
                 Error);
    EXPECT_EQ(reports, 3);
    options.fit.snap_step_mm = -1;
    EXPECT_THROW(validate(options), Error);
    options.fit.snap_step_mm = 0;
    options.selection.radius_mm = 0;
    EXPECT_THROW(fit_at_point(scan.cloud, cv::Vec3d(5, 0, 5), options), Error);
}

TEST(RegionFit, PlaneSphereAndConeConstraintsHoldAndSpheresSnap) {
    // A plane tilted 0.5 degrees from z: parallel to z it becomes exactly z (RMS shows the tilt),
    // perpendicular to x its normal has no x part.
    Scan floor(0.01);
    const cv::Vec3d tilted = cv::normalize(cv::Vec3d(std::tan(0.5 * kPi / 180), 0, 1));
    const auto [u, v] = std::make_pair(cv::normalize(cv::Vec3d(1, 0, 0) - tilted[0] * tilted), cv::Vec3d(0, 1, 0));
    for (int i = 0; i <= 50; ++i)
        for (int j = 0; j <= 50; ++j) floor.add((i * 0.2 - 5) * u + (j * 0.2 - 5) * v, tilted);
    RegionFitOptions options;
    options.automatic = false;
    options.kind = ShapeKind::Plane;
    options.constraint = FitConstraint::Parallel;
    options.reference_direction = cv::Vec3d(0, 0, 2);  // any length
    const RegionFit parallel = fit_region(floor.cloud, all_of(floor.cloud), options);
    EXPECT_NEAR(parallel.shape.direction[2], 1.0, 1e-12);
    // 5 mm either side of the middle, 0.5 degrees: a ramp of RMS 5 x tan(0.5°) / sqrt(3) = 25 um.
    EXPECT_NEAR(parallel.shape.rms_mm, std::hypot(5 * std::tan(0.5 * kPi / 180) / std::sqrt(3.0), 0.01), 0.003);
    options.constraint = FitConstraint::Perpendicular;
    options.reference_direction = cv::Vec3d(1, 0, 0);
    const RegionFit square = fit_region(floor.cloud, all_of(floor.cloud), options);
    EXPECT_LT(std::abs(square.shape.direction[0]), 1e-12);
    EXPECT_GT(std::abs(square.shape.direction[2]), 0.9999);

    // A sphere cap of radius 12.52 centred 0.3 mm off the z axis: coaxial with z, its centre is on
    // the axis; free, it snaps to 25.0 mm on a 0.5 mm step (within 0.05 mm) and not on 0.3 mm.
    Scan ball(0.01);
    const cv::Vec3d centre(0.3, 0, 50);
    for (int i = 0; i <= 40; ++i)
        for (int j = 0; j <= 40; ++j) {
            const double theta = (10 + 60.0 * i / 40) * kPi / 180, phi = (120.0 * j / 40) * kPi / 180;
            const cv::Vec3d n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
            ball.add(centre + 12.52 * n, n);
        }
    RegionFitOptions on_axis;
    on_axis.automatic = false;
    on_axis.kind = ShapeKind::Sphere;
    on_axis.constraint = FitConstraint::Coaxial;
    on_axis.reference_point = cv::Vec3d(0, 0, 7);
    on_axis.reference_direction = cv::Vec3d(0, 0, 1);
    const RegionFit coaxial = fit_region(ball.cloud, all_of(ball.cloud), on_axis);
    EXPECT_LT(std::hypot(coaxial.shape.point[0], coaxial.shape.point[1]), 1e-9) << coaxial.report;
    EXPECT_GT(coaxial.shape.rms_mm, 0.05);  // 0.3 mm off the true centre shows
    RegionFitOptions snap;
    snap.snap_step_mm = 0.5;
    snap.snap_tolerance_mm = 0.05;
    const RegionFit snapped = fit_region(ball.cloud, all_of(ball.cloud), snap);
    ASSERT_EQ(snapped.shape.kind, ShapeKind::Sphere) << snapped.report;
    EXPECT_NEAR(snapped.fitted_radius_mm, 12.52, 0.005);
    EXPECT_TRUE(snapped.snapped) << snapped.report;
    EXPECT_DOUBLE_EQ(snapped.shape.radius_mm, 12.5);
    EXPECT_LT(cv::norm(snapped.shape.point - centre), 0.05);
    snap.snap_step_mm = 0.3;  // nearest multiple 24.9 mm: 0.14 mm away
    const RegionFit not_snapped = fit_region(ball.cloud, all_of(ball.cloud), snap);
    EXPECT_FALSE(not_snapped.snapped) << not_snapped.report;
    EXPECT_NE(not_snapped.report.find("not snapped"), std::string::npos) << not_snapped.report;

    // A 45 degree countersink whose axis is tilted 1 degree from z: parallel to z holds the axis
    // exactly, coaxial with an axis 0.2 mm away puts it there; a cone cannot be perpendicular.
    Scan countersink(0.01);
    const double half_angle = 45 * kPi / 180;
    const cv::Vec3d axis = cv::normalize(cv::Vec3d(std::tan(kPi / 180), 0, 1));
    const cv::Vec3d across = cv::normalize(cv::Vec3d(0, 1, 0).cross(axis)), side = axis.cross(across);
    for (int i = 0; i <= 40; ++i)
        for (int j = 0; j <= 90; ++j) {
            const double along = 4 + 6.0 * i / 40, phi = 2 * kPi * j / 90;
            const cv::Vec3d radial = std::cos(phi) * across + std::sin(phi) * side;
            countersink.add(along * axis + along * std::tan(half_angle) * radial,
                            std::cos(half_angle) * radial - std::sin(half_angle) * axis);
        }
    RegionFitOptions cone;
    cone.automatic = false;
    cone.kind = ShapeKind::Cone;
    cone.constraint = FitConstraint::Parallel;
    cone.reference_direction = cv::Vec3d(0, 0, 1);
    const RegionFit cone_parallel = fit_region(countersink.cloud, all_of(countersink.cloud), cone);
    EXPECT_NEAR(std::abs(cone_parallel.shape.direction[2]), 1.0, 1e-12) << cone_parallel.report;
    cone.constraint = FitConstraint::Coaxial;
    cone.reference_point = cv::Vec3d(0.2, 0, 0);
    cone.reference_direction = axis;
    const RegionFit cone_coaxial = fit_region(countersink.cloud, all_of(countersink.cloud), cone);
    EXPECT_LT(cv::norm((cone_coaxial.shape.point - cv::Vec3d(0.2, 0, 0)).cross(axis)), 1e-9) << cone_coaxial.report;
    EXPECT_NEAR(std::abs(cone_coaxial.shape.direction.dot(axis)), 1.0, 1e-12);
    EXPECT_NEAR(cone_coaxial.shape.half_angle_deg, 45, 0.5);
    cone.constraint = FitConstraint::Perpendicular;
    EXPECT_THROW(fit_region(countersink.cloud, all_of(countersink.cloud), cone), Error);
}
