// Fitting where the user points on a scan-like part: the face at the picked point is grown as a
// fitted shape, not by normals alone. The part's normals are smoothed over 1 mm as a scanner's
// are, so they turn gradually over every edge (the old growing by normal steps ran from the
// short boss's side onto its top and the block). Short and small features must come out right at
// several noise levels; picks on an edge or a patch too small to fit are refused with a reason.
#include "picoscan/error.h"
#include "picoscan/pipeline.h"
#include "picoscan/region_fit.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>
#include <random>
#include <tuple>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kStep = 0.2;  // sample spacing, mm

struct Part {
    PointCloud cloud;
    std::vector<int> surface;  // which surface each point was sampled on
};

enum Surface { kBlockTop, kRightFace, kChamfer, kBackFace, kNarrowChamfer, kBossSide, kBossTop, kHoleWall, kPinSide, kPinTop };

// The demo part's top half (block top z = 24, boss of 14 mm to z = 32 at (12, -2), a 10 mm hole
// at (-11, 0) seen on a 140 degree arc, the 8 mm chamfer at the (+x, +y) corner), a narrow
// 1.5 x 1.5 mm chamfer along the back top edge and a 1.2 mm pin 1 mm tall at (-20, -12).
Part sampled_part(double sigma_mm, unsigned seed) {
    Part part;
    std::vector<cv::Vec3d> points, normals;
    const auto add = [&](Surface surface, const cv::Vec3d& p, const cv::Vec3d& n) {
        points.push_back(p);
        normals.push_back(cv::normalize(n));
        part.surface.push_back(surface);
    };
    const cv::Vec2d hole(-11, 0), boss(12, -2), pin(-20, -12);
    for (double x = -25; x <= 25 + 1e-9; x += kStep)
        for (double y = -18; y <= 16.5 + 1e-9; y += kStep) {
            if (x + y > 35 || cv::norm(cv::Vec2d(x, y) - hole) < 5 || cv::norm(cv::Vec2d(x, y) - boss) < 7 ||
                cv::norm(cv::Vec2d(x, y) - pin) < 0.6)
                continue;
            add(kBlockTop, {x, y, 24}, {0, 0, 1});
        }
    for (double y = -18; y <= 10 + 1e-9; y += kStep)
        for (double z = 14; z < 24 - 1e-9; z += kStep) add(kRightFace, {25, y, z}, {1, 0, 0});
    for (double t = 0; t <= 8 * std::sqrt(2.0) + 1e-9; t += kStep)  // from (25, 10) to (17, 18)
        for (double z = 14; z < 24 - 1e-9; z += kStep) add(kChamfer, {25 - t / std::sqrt(2.0), 10 + t / std::sqrt(2.0), z}, {1, 1, 0});
    for (double x = -25; x <= 10 + 1e-9; x += kStep) {
        for (double z = 14; z < 22.5 - 1e-9; z += kStep) add(kBackFace, {x, 18, z}, {0, 1, 0});
        for (double t = kStep / 2; t < 1.5 * std::sqrt(2.0); t += kStep)  // the narrow chamfer, (18, 22.5) to (16.5, 24)
            add(kNarrowChamfer, {x, 18 - t / std::sqrt(2.0), 22.5 + t / std::sqrt(2.0)}, {0, 1, 1});
    }
    const auto ring = [&](Surface surface, const cv::Vec2d& centre, double radius, double from_deg, double to_deg, double z0,
                          double z1, double outwards) {
        const int steps = int(radius * (to_deg - from_deg) * kPi / 180 / kStep);
        for (int k = 0; k <= steps; ++k) {
            const double a = (from_deg + (to_deg - from_deg) * k / steps) * kPi / 180;
            const cv::Vec3d radial(std::cos(a), std::sin(a), 0);
            for (double z = z0; z < z1 - 1e-9; z += kStep)
                add(surface, cv::Vec3d(centre[0], centre[1], z) + radius * radial, outwards * radial);
        }
    };
    const auto disc = [&](Surface surface, const cv::Vec2d& centre, double radius, double z) {
        for (double x = -radius; x <= radius; x += kStep)
            for (double y = -radius; y <= radius; y += kStep)
                if (std::hypot(x, y) < radius) add(surface, {centre[0] + x, centre[1] + y, z}, {0, 0, 1});
    };
    ring(kBossSide, boss, 7, 0, 360, 24 + kStep, 32, 1);
    disc(kBossTop, boss, 7, 32);
    ring(kHoleWall, hole, 5, -70, 70, 14, 24, -1);  // its +x half, seen from above at an angle
    ring(kPinSide, pin, 0.6, 0, 360, 24 + kStep, 25, 1);
    disc(kPinTop, pin, 0.6, 25);

    // A scanner's normals: averaged over 1 mm, so they turn smoothly over every edge.
    std::map<std::tuple<int, int, int>, std::vector<int>> cells;
    const auto cell = [](const cv::Vec3d& p) { return std::make_tuple(int(std::floor(p[0])), int(std::floor(p[1])), int(std::floor(p[2]))); };
    for (size_t i = 0; i < points.size(); ++i) cells[cell(points[i])].push_back(int(i));
    std::mt19937 random(seed);
    std::normal_distribution<double> noise(0.0, sigma_mm);
    for (size_t i = 0; i < points.size(); ++i) {
        cv::Vec3d smoothed(0, 0, 0);
        const auto [cx, cy, cz] = cell(points[i]);
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                    const auto found = cells.find({cx + dx, cy + dy, cz + dz});
                    if (found == cells.end()) continue;
                    for (int j : found->second)
                        if (cv::norm(points[size_t(j)] - points[i]) <= 1.0) smoothed += normals[size_t(j)];
                }
        part.cloud.points.emplace_back(points[i] + noise(random) * normals[i]);
        part.cloud.normals.emplace_back(cv::normalize(smoothed));
    }
    return part;
}

double angle_deg(const cv::Vec3d& a, const cv::Vec3d& b) {
    return std::acos(std::min(1.0, std::abs(cv::normalize(a).dot(cv::normalize(b))))) * 180 / kPi;
}

// How many of the region's points lie on `surface`, and how many the part has there.
std::pair<size_t, size_t> on_surface(const Part& part, const std::vector<int>& region, Surface surface) {
    size_t in_region = 0, total = 0;
    for (int i : region) in_region += part.surface[size_t(i)] == surface;
    for (int s : part.surface) total += s == surface;
    return {in_region, total};
}

}  // namespace

TEST(PickedFace, ShortBossHoleChamfersAndSmallPlanesAreFoundAtEveryNoiseLevel) {
    for (double sigma : {0.005, 0.02, 0.04}) {
        SCOPED_TRACE("noise " + std::to_string(sigma) + " mm");
        const Part part = sampled_part(sigma, 3);
        struct Pick {
            const char* name;
            cv::Vec3d seed;
            Surface surface;
            ShapeKind kind;
        };
        const Pick picks[] = {{"boss side", {19, -2, 28}, kBossSide, ShapeKind::Cylinder},
                              {"boss side near its top edge", {12, 5, 31.3}, kBossSide, ShapeKind::Cylinder},
                              {"boss top", {12, -2, 32}, kBossTop, ShapeKind::Plane},
                              {"hole wall", {-6, 0, 19}, kHoleWall, ShapeKind::Cylinder},
                              {"chamfer", {21, 14, 18}, kChamfer, ShapeKind::Plane},
                              {"narrow chamfer", {0, 17.25, 23.25}, kNarrowChamfer, ShapeKind::Plane},
                              {"block top", {-5, 10, 24}, kBlockTop, ShapeKind::Plane}};
        for (const Pick& pick : picks) {
            SCOPED_TRACE(pick.name);
            const PickedFit picked = fit_at_point(part.cloud, pick.seed);
            SCOPED_TRACE(picked.fit.report);
            ASSERT_EQ(picked.fit.shape.kind, pick.kind);
            const auto [in_region, total] = on_surface(part, picked.region, pick.surface);
            // Nearly all of the face (its points within 1 mm of an edge may go), nothing of another.
            EXPECT_GE(in_region, picked.region.size() - picked.region.size() / 100) << "points of other faces";
            if (pick.surface != kBlockTop) {
                EXPECT_GT(double(in_region), 0.7 * double(total)) << in_region << " of " << total;
            }
            EXPECT_LT(picked.fit.shape.rms_mm, 1.3 * sigma + 0.002);
            const DetectedShape& shape = picked.fit.shape;
            switch (pick.surface) {
                case kBossSide:
                    EXPECT_NEAR(2 * shape.radius_mm, 14.0, 0.01 + sigma / 2);
                    EXPECT_LT(angle_deg(shape.direction, {0, 0, 1}), 0.3);
                    EXPECT_LT(cv::norm((shape.point - cv::Vec3d(12, -2, 0)).cross(shape.direction)), 0.01 + sigma / 2);
                    break;
                case kHoleWall:
                    EXPECT_NEAR(2 * shape.radius_mm, 10.0, 0.01 + sigma);
                    EXPECT_LT(angle_deg(shape.direction, {0, 0, 1}), 0.5);
                    break;
                case kBossTop: EXPECT_NEAR(shape.point[2], 32.0, 0.01); [[fallthrough]];
                case kBlockTop: EXPECT_LT(angle_deg(shape.direction, {0, 0, 1}), 0.1); break;
                case kChamfer: EXPECT_LT(angle_deg(shape.direction, {1, 1, 0}), 0.1); break;
                case kNarrowChamfer: EXPECT_LT(angle_deg(shape.direction, {0, 1, 1}), 1.0); break;
                default: break;
            }
        }
    }
}

TEST(PickedFace, PicksOnAnEdgeOrATooSmallPatchAreRefusedWithAReason) {
    const Part part = sampled_part(0.02, 5);
    // On the edge between the block's top and its right face, and on the boss's top rim.
    for (const cv::Vec3d& seed : {cv::Vec3d(25, 0, 24), cv::Vec3d(19, -2, 32)}) {
        try {
            const PickedFit picked = fit_at_point(part.cloud, seed);
            ADD_FAILURE() << "an edge pick was fitted: " << picked.fit.report;
        } catch (const Error& error) {
            EXPECT_EQ(error.subject(), "seed") << error.what();
            EXPECT_NE(std::string(error.what()).find("edge"), std::string::npos) << error.what();
        }
    }
    // The pin's top (a 1.2 mm disc, about 28 points) is too small a face to fit anything on.
    try {
        const PickedFit picked = fit_at_point(part.cloud, {-20, -12, 25});
        ADD_FAILURE() << "the pin's top was fitted: " << picked.fit.report;
    } catch (const Error& error) {
        EXPECT_TRUE(error.subject() == "seed" || error.subject() == "region") << error.what();
        EXPECT_NE(std::string(error.what()).find("pick"), std::string::npos) << error.what();
    }
    // A cylinder asked for on the flat chamfer: its radius is not determined by the points.
    PickedFitOptions cylinder;
    cylinder.fit.automatic = false;
    cylinder.fit.kind = ShapeKind::Cylinder;
    try {
        const PickedFit picked = fit_at_point(part.cloud, {21, 14, 18}, cylinder);
        ADD_FAILURE() << "a cylinder was fitted to the flat chamfer: " << picked.fit.report;
    } catch (const Error& error) {
        EXPECT_EQ(error.subject(), "region") << error.what();
        EXPECT_NE(std::string(error.what()).find("not determined"), std::string::npos) << error.what();
    }
}

TEST(PickedFace, NoiseIsEstimatedFromTheScanWhateverTheCurvature) {
    for (double sigma : {0.005, 0.02, 0.04}) {
        const Part part = sampled_part(sigma, 7);
        // Around the boss: its side, top and the block's top; the edges are a small share.
        EXPECT_NEAR(estimate_noise(part.cloud, {12, -2, 28}, 12), sigma, 0.2 * sigma + 0.001) << sigma;
    }
    EXPECT_THROW(estimate_noise(PointCloud{}, {0, 0, 0}, 1), Error);
}

TEST(PickedFace, ScanNoiseIsEstimatedOverTheWholeScan) {
    for (double sigma : {0.005, 0.02, 0.04}) {
        const Part part = sampled_part(sigma, 11);
        // Every face of the part, its edges and corners a small share of the neighbourhoods.
        EXPECT_NEAR(estimate_scan_noise(part.cloud), sigma, 0.2 * sigma + 0.001) << sigma;
    }
    PointCloud few;
    few.points.assign(23, cv::Vec3f(0, 0, 0));
    EXPECT_THROW(estimate_scan_noise(few), Error);
}

TEST(PickedFace, ConstraintsToFittedFeaturesAndNominalSizesHoldOnPickedFaces) {
    const Part part = sampled_part(0.02, 9);
    const PickedFit top = fit_at_point(part.cloud, {-5, 10, 24});
    ASSERT_EQ(top.fit.shape.kind, ShapeKind::Plane);
    const cv::Vec3d up = top.fit.shape.direction;
    PickedFitOptions to_top;
    to_top.fit.reference_point = top.fit.shape.point;
    to_top.fit.reference_direction = up;
    to_top.fit.constraint = FitConstraint::Parallel;
    const PickedFit boss = fit_at_point(part.cloud, {19, -2, 28}, to_top);
    ASSERT_EQ(boss.fit.shape.kind, ShapeKind::Cylinder) << boss.fit.report;
    EXPECT_NEAR(std::abs(boss.fit.shape.direction.dot(up)), 1.0, 1e-12);
    EXPECT_NEAR(2 * boss.fit.shape.radius_mm, 14.0, 0.02);
    const PickedFit boss_top = fit_at_point(part.cloud, {12, -2, 32}, to_top);
    ASSERT_EQ(boss_top.fit.shape.kind, ShapeKind::Plane) << boss_top.fit.report;
    EXPECT_NEAR(boss_top.fit.shape.direction.dot(up), 1.0, 1e-12);
    EXPECT_NEAR((boss_top.fit.shape.point - top.fit.shape.point).dot(up), 8.0, 0.01);  // the boss's height
    to_top.fit.constraint = FitConstraint::Perpendicular;
    const PickedFit chamfer = fit_at_point(part.cloud, {21, 14, 18}, to_top);
    ASSERT_EQ(chamfer.fit.shape.kind, ShapeKind::Plane) << chamfer.fit.report;
    EXPECT_LT(std::abs(chamfer.fit.shape.direction.dot(up)), 1e-12);
    EXPECT_LT(angle_deg(chamfer.fit.shape.direction, {1, 1, 0}), 0.1);
    // The hole coaxial with the boss's axis: held there, which its RMS shows (23 mm away).
    PickedFitOptions to_boss;
    to_boss.fit.constraint = FitConstraint::Coaxial;
    to_boss.fit.reference_point = boss.fit.shape.point;
    to_boss.fit.reference_direction = boss.fit.shape.direction;
    const PickedFit hole = fit_at_point(part.cloud, {-6, 0, 19}, to_boss);
    EXPECT_LT(cv::norm((hole.fit.shape.point - boss.fit.shape.point).cross(boss.fit.shape.direction)), 1e-9);
    EXPECT_GT(hole.fit.shape.rms_mm, 1.0) << hole.fit.report;
    // Coaxial with its own axis (given 10 um off): the diameter stays within 30 um of 10 mm.
    to_boss.fit.reference_point = cv::Vec3d(-11.01, 0, 0);
    to_boss.fit.reference_direction = cv::Vec3d(0, 0, 1);
    const PickedFit own = fit_at_point(part.cloud, {-6, 0, 19}, to_boss);
    EXPECT_NEAR(2 * own.fit.shape.radius_mm, 10.0, 0.03) << own.fit.report;
    // Nominal sizes: the boss snaps to 14 mm on a 1 mm step; on a 0.3 mm step (14.1 nearest) not.
    PickedFitOptions snap;
    snap.fit.snap_step_mm = 1;
    snap.fit.snap_tolerance_mm = 0.05;
    const PickedFit snapped = fit_at_point(part.cloud, {19, -2, 28}, snap);
    EXPECT_TRUE(snapped.fit.snapped) << snapped.fit.report;
    EXPECT_DOUBLE_EQ(snapped.fit.shape.radius_mm, 7.0);
    EXPECT_LT(snapped.fit.shape.rms_mm, 0.025);
    snap.fit.snap_step_mm = 0.3;
    const PickedFit off_step = fit_at_point(part.cloud, {19, -2, 28}, snap);
    EXPECT_FALSE(off_step.fit.snapped) << off_step.fit.report;
    EXPECT_NEAR(2 * off_step.fit.shape.radius_mm, 14.0, 0.02);
}

namespace {

// The demo part's simulated turntable scan (eight views round it and one from above, camera
// noise 1 DN; the views other suites cache), merged in the part's own frame by the true poses.
const PointCloud& demo_scan() {
    static const PointCloud cloud = [] {
        const test_support::TurntableScan& scan = test_support::turntable_scan();
        std::vector<ScanView> views = scan.views;
        for (size_t i = 0; i < views.size(); ++i) views[i].pose = scan.part_to_camera[i].inv();
        return merge_views(views);
    }();
    return cloud;
}

}  // namespace

// The figures the issue asks of the rebuild (20 um) hold for features fitted where the user points
// on the real simulated scan: the boss's short side and the hole's partly seen wall from a point
// anywhere on them, the chamfer, the boss's top and the block's faces; picks on an edge refused.
TEST(PickedFace, DemoPartScanBossHoleChamferAndTopsFromPickedPoints) {
    const PointCloud& cloud = demo_scan();
    const auto fitted = [&](const cv::Vec3d& seed, ShapeKind kind) {
        const PickedFit picked = fit_at_point(cloud, seed);
        std::printf("picked at (%g, %g, %g): %zu points; %s\n", seed[0], seed[1], seed[2], picked.region.size(), picked.fit.report.c_str());
        EXPECT_EQ(picked.fit.shape.kind, kind) << picked.fit.report;
        return picked;
    };
    // Truth (MechanicalPartShape): boss 14 mm at (12, -2) from z = 24 to 32, hole 10 mm at (-11, 0).
    for (const cv::Vec3d& seed : {cv::Vec3d(19, -2, 28), cv::Vec3d(5, -2, 27), cv::Vec3d(12, 5, 31)}) {
        const PickedFit boss = fitted(seed, ShapeKind::Cylinder);
        const DetectedShape& shape = boss.fit.shape;
        EXPECT_NEAR(2 * shape.radius_mm, 14.0, 0.02);
        EXPECT_LT(angle_deg(shape.direction, {0, 0, 1}), 0.05);
        EXPECT_LT(cv::norm((shape.point - cv::Vec3d(12, -2, 0)).cross(shape.direction)), 0.02);
        // The whole side and nothing of the boss's top or the block's: its points span the height.
        size_t off = 0;
        double low = 1e9, high = -1e9;
        for (int i : boss.region) {
            const cv::Vec3d p(cloud.points[size_t(i)]);
            off += std::abs(std::hypot(p[0] - 12, p[1] + 2) - 7) > 0.1;
            low = std::min(low, p[2]), high = std::max(high, p[2]);
        }
        EXPECT_LT(off, boss.region.size() / 200) << off << " of " << boss.region.size() << " points off the boss's side";
        EXPECT_LT(low, 25.0);
        EXPECT_GT(high, 31.0);
    }
    for (const cv::Vec3d& seed : {cv::Vec3d(-16, 0, 21), cv::Vec3d(-6, 0, 21), cv::Vec3d(-11, 5, 21)}) {
        const DetectedShape hole = fitted(seed, ShapeKind::Cylinder).fit.shape;
        EXPECT_NEAR(2 * hole.radius_mm, 10.0, 0.02);
        EXPECT_LT(angle_deg(hole.direction, {0, 0, 1}), 0.05);
        EXPECT_LT(cv::norm((hole.point - cv::Vec3d(-11, 0, 0)).cross(hole.direction)), 0.02);
    }
    const DetectedShape boss_top = fitted({12, -2, 32}, ShapeKind::Plane).fit.shape;
    EXPECT_NEAR(boss_top.point[2], 32.0, 0.02);
    EXPECT_LT(angle_deg(boss_top.direction, {0, 0, 1}), 0.05);
    const DetectedShape top = fitted({-18, 8, 24}, ShapeKind::Plane).fit.shape;
    EXPECT_NEAR(top.point[2], 24.0, 0.02);
    EXPECT_LT(angle_deg(top.direction, {0, 0, 1}), 0.05);
    const DetectedShape chamfer = fitted({21, 14, 12}, ShapeKind::Plane).fit.shape;
    EXPECT_LT(angle_deg(chamfer.direction, {1, 1, 0}), 0.05);
    EXPECT_NEAR((chamfer.point - cv::Vec3d(21, 14, 0)).dot(cv::normalize(cv::Vec3d(1, 1, 0))), 0.0, 0.02);
    const DetectedShape right = fitted({25, -4, 12}, ShapeKind::Plane).fit.shape;
    EXPECT_NEAR(right.point[0], 25.0, 0.02);
    // On the edge between the block's top and its right face, and on the boss's top rim.
    for (const cv::Vec3d& seed : {cv::Vec3d(25, 0, 24), cv::Vec3d(19, -2, 32)}) {
        try {
            const PickedFit picked = fit_at_point(cloud, seed);
            ADD_FAILURE() << "an edge pick was fitted: " << picked.fit.report;
        } catch (const Error& error) {
            EXPECT_EQ(error.subject(), "seed") << error.what();
        }
    }
}

// Two coplanar plates 1.1 mm apart across the camera's axis (x = y = 0), where a hashed cube key
// took the cube (1, 1, 0) for (-1, -1, 0): the face grown on one plate jumped onto the other.
TEST(PickedFace, AFaceDoesNotJumpAGapAcrossTheCameraAxis) {
    PointCloud cloud;
    std::mt19937 random(11);
    std::normal_distribution<double> noise(0.0, 0.01);
    size_t near_plate = 0;
    for (double x = -8; x <= 9 + 1e-9; x += kStep)
        for (double y = -8; y <= 9 + 1e-9; y += kStep) {
            const bool near = x < -0.05 && y < -0.05, far = x > 1.05 && y > 1.05;
            if (!near && !far) continue;
            near_plate += near;
            cloud.points.emplace_back(x, y, 0.5 + noise(random));
            cloud.normals.emplace_back(0, 0, 1);
        }
    RegionSelection selection;
    selection.radius_mm = 30;
    const GrownFace face = grow_face(cloud, {-4, -4, 0.5}, selection);
    size_t on_far_plate = 0;
    for (int i : face.region) on_far_plate += cloud.points[size_t(i)][0] > 0;
    EXPECT_EQ(on_far_plate, 0u) << face.report;
    EXPECT_GT(face.region.size(), near_plate * 9 / 10) << face.report;
}
