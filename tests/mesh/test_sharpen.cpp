// Sharp edges restored by the Poisson meshing, and rounded ones left round: points sampled
// (with noise) from a block whose two vertical edges at x = 30 are fillets of 3 mm radius and
// whose other edges are sharp, meshed by the default recipe and judged against the exact shape.
// A mesher that makes every edge sharp turns the fillets into corners; one that makes none
// leaves the sharp edges rounded by about a triangle.
#include "picoscan/deviation.h"
#include "picoscan/mesh.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

using namespace picoscan;

namespace {

constexpr double kLength = 30, kWidth = 20, kHeight = 15, kFillet = 3;

// Signed distance to the block (positive outside): its footprint a rectangle whose two corners
// at x = kLength are rounded, extruded from z = 0 to kHeight with sharp top and bottom edges.
double signed_distance(const cv::Vec3d& p) {
    double footprint;
    const double cy = p[1] < kFillet ? kFillet : kWidth - kFillet;
    if (p[0] > kLength - kFillet && (p[1] < kFillet || p[1] > kWidth - kFillet)) {
        footprint = cv::norm(cv::Vec2d(p[0] - (kLength - kFillet), p[1] - cy)) - kFillet;
    } else {
        const double dx = std::max(-p[0], p[0] - kLength), dy = std::max(-p[1], p[1] - kWidth);
        footprint = std::min(std::max(dx, dy), 0.0) + cv::norm(cv::Vec2d(std::max(dx, 0.0), std::max(dy, 0.0)));
    }
    const double dz = std::max(-p[2], p[2] - kHeight);
    return std::min(std::max(footprint, dz), 0.0) + cv::norm(cv::Vec2d(std::max(footprint, 0.0), std::max(dz, 0.0)));
}

// Points on the block's surface about `spacing` apart, with their outward normals; `noise_mm`
// along the normal.
// Samples surfaces: points on a jittered grid about `spacing` apart, `noise_mm` along the normal.
struct SurfaceSampler {
    SurfaceSampler(double spacing, double noise_mm, unsigned seed) : spacing(spacing), random(seed), noise_mm(noise_mm) {}

    void add(const cv::Vec3d& p, const cv::Vec3d& n) {
        cloud.points.emplace_back(p + noise_mm * unit_noise(random) * n);
        cloud.normals.emplace_back(n);
    }

    // Calls place(a, b) over [0, a_size] x [0, b_size].
    template <class Place>
    void grid(double a_size, double b_size, Place&& place) {
        for (double a = spacing / 2; a < a_size; a += spacing)
            for (double b = spacing / 2; b < b_size; b += spacing)
                place(std::clamp(a + jitter(random) * spacing, 0.0, a_size), std::clamp(b + jitter(random) * spacing, 0.0, b_size));
    }

    double spacing;
    std::mt19937 random;
    double noise_mm;
    std::normal_distribution<double> unit_noise;  // scaled: its deviation must be positive, and noise_mm may be 0
    std::uniform_real_distribution<double> jitter{-0.5, 0.5};
    PointCloud cloud;
};

PointCloud block_points(double spacing, double noise_mm, unsigned seed) {
    SurfaceSampler sampler(spacing, noise_mm, seed);
    auto add = [&](const cv::Vec3d& p, const cv::Vec3d& n) { sampler.add(p, n); };
    auto grid = [&](double a_size, double b_size, auto&& place) { sampler.grid(a_size, b_size, place); };
    // Top and bottom: the rounded footprint.
    auto inside_footprint = [](double x, double y) { return signed_distance(cv::Vec3d(x, y, kHeight / 2)) <= 0; };
    for (double z : {0.0, kHeight})
        grid(kLength, kWidth, [&](double x, double y) {
            if (inside_footprint(x, y)) add(cv::Vec3d(x, y, z), cv::Vec3d(0, 0, z > 0 ? 1 : -1));
        });
    // The flat sides.
    grid(kWidth, kHeight, [&](double y, double z) { add(cv::Vec3d(0, y, z), cv::Vec3d(-1, 0, 0)); });
    grid(kWidth - 2 * kFillet, kHeight, [&](double y, double z) { add(cv::Vec3d(kLength, kFillet + y, z), cv::Vec3d(1, 0, 0)); });
    for (double y : {0.0, kWidth})
        grid(kLength - kFillet, kHeight, [&](double x, double z) { add(cv::Vec3d(x, y, z), cv::Vec3d(0, y > 0 ? 1 : -1, 0)); });
    // The fillets, by arc length.
    for (double cy : {kFillet, kWidth - kFillet})
        grid(kFillet * CV_PI / 2, kHeight, [&](double s, double z) {
            const double angle = s / kFillet;  // from the x = kLength side towards the y side
            const cv::Vec3d n(std::cos(angle), cy < kWidth / 2 ? -std::sin(angle) : std::sin(angle), 0);
            add(cv::Vec3d(kLength - kFillet, cy, z) + kFillet * n, n);
        });
    return sampler.cloud;
}

// Points spread evenly over the exact surface: the same sampling without noise.
std::vector<cv::Vec3f> true_surface() { return block_points(0.25, 0, 99).points; }

}  // namespace

TEST(MeshSharpen, SharpEdgesComeBackAndFilletsStayRound) {
    const PointCloud cloud = block_points(0.25, 0.01, 1);
    const Mesh mesh = mesh_cloud(cloud);
    const MeshCheck check = check_mesh(mesh);
    std::printf("%s\n", check.summary().c_str());
    ASSERT_TRUE(check.closed_volume);
    const double true_volume = kLength * kWidth * kHeight - 2 * (kFillet * kFillet - CV_PI * kFillet * kFillet / 4) * kHeight;
    std::printf("volume %.1f mm^3, true %.1f mm^3 (%+.3f %%)\n", check.volume_mm3, true_volume,
                100 * (check.volume_mm3 / true_volume - 1));
    EXPECT_NEAR(check.volume_mm3 / true_volume - 1, 0.0, 0.002);

    // Truth -> mesh near the sharp edges (within 1 mm of one of them, away from the fillets)
    // and over everything.
    const std::vector<cv::Vec3f> truth = true_surface();
    const DeviationMap to_mesh = measure_deviation(truth, mesh);
    double worst_at_sharp_edges = 0;
    size_t at_sharp_edges = 0;
    for (size_t i = 0; i < truth.size(); ++i) {
        const cv::Vec3d p(truth[i]);
        const bool near_x0 = p[0] < 1, near_y = p[1] < 1 || p[1] > kWidth - 1, near_z = p[2] < 1 || p[2] > kHeight - 1;
        const bool sharp = (near_x0 && (near_y || near_z)) || (near_y && near_z && p[0] < kLength - kFillet - 1) ||
                           (near_z && p[0] > kLength - 1 && p[1] > kFillet && p[1] < kWidth - kFillet);
        if (!sharp) continue;
        ++at_sharp_edges;
        worst_at_sharp_edges = std::max(worst_at_sharp_edges, double(std::abs(to_mesh.distances_mm[i])));
    }
    // Mesh -> truth, and the fillets: the mesh's vertices on them (away from the top and
    // bottom) lie on the 3 mm arc, and none comes near the corner a sharpened fillet would have.
    double worst_vertex = 0, worst_on_fillet = 0, nearest_to_false_corner = 1e9;
    cv::Vec2d radius_sum(0, 0);
    size_t on_fillet = 0;
    for (const cv::Vec3f& v : mesh.vertices) {
        const cv::Vec3d p(v);
        worst_vertex = std::max(worst_vertex, std::abs(signed_distance(p)));
        if (p[2] < 2 || p[2] > kHeight - 2) continue;
        for (double corner_y : {0.0, kWidth}) {
            nearest_to_false_corner = std::min(nearest_to_false_corner, cv::norm(cv::Vec2d(p[0] - kLength, p[1] - corner_y)));
            const double cy = corner_y > 0 ? kWidth - kFillet : kFillet;
            const cv::Vec2d from_centre(p[0] - (kLength - kFillet), p[1] - cy);
            if (from_centre[0] > 0.3 && std::abs(p[1] - cy) > 0.3 && (p[1] - cy) * (corner_y - cy) > 0) {
                ++on_fillet;
                worst_on_fillet = std::max(worst_on_fillet, std::abs(cv::norm(from_centre) - kFillet));
                radius_sum += cv::Vec2d(cv::norm(from_centre), 1);
            }
        }
    }
    const double mean_radius = radius_sum[0] / radius_sum[1];
    std::printf("truth -> mesh: mean %.1f um, p95 %.1f um, max %.1f um; at the sharp edges (%zu samples) max %.1f um\n",
                1000 * to_mesh.statistics.mean_abs_mm, 1000 * to_mesh.statistics.p95_abs_mm,
                1000 * to_mesh.statistics.max_abs_mm, at_sharp_edges, 1000 * worst_at_sharp_edges);
    std::printf("mesh vertices -> truth: max %.1f um; fillets: %zu vertices, mean radius %.4f mm (true %.1f), worst %.1f um "
                "off the arc; nearest vertex to the corner a sharpened fillet would make: %.3f mm\n",
                1000 * worst_vertex, on_fillet, mean_radius, kFillet, 1000 * worst_on_fillet, nearest_to_false_corner);
    // Measured (see docs/multiview.md): sharpened, truth -> mesh mean 1.1 um, 140 and 190 um at
    // the sharp edges in two runs, fillet radius 2.9941 mm, 54-55 um off the arc at worst, 1.241 mm
    // from the false corner (the true arc: 1.243 mm); without sharpening mean 10.8 um, 402 um at
    // the sharp edges (and the volume more than 0.2 % off).
    EXPECT_LT(to_mesh.statistics.mean_abs_mm, 0.004);
    EXPECT_LT(worst_at_sharp_edges, 0.250);
    EXPECT_LT(worst_vertex, 0.300);
    ASSERT_GT(on_fillet, 100u);
    EXPECT_NEAR(mean_radius, kFillet, 0.02);
    EXPECT_LT(worst_on_fillet, 0.080);
    EXPECT_GT(nearest_to_false_corner, 1.2);  // a sharpened fillet puts vertices at the corner
}

namespace {

// A 20 x 20 x 14 mm block with a vertical through hole of radius 5 at its middle, scanned as a
// part standing on the turntable and then on its side is: every outer face, the hole's wall all
// round near its top (z 10-14) and its y < 0 half all the way down, but not its y > 0 half
// below z = 10 (no view looks that far in on that side). `flat_y` > 0: the hole is a D, its
// wall on the y > 0 side the flat y = flat_y all the way down (seen only near the top).
constexpr double kHoleBlock = 20, kHoleBlockHeight = 14, kHoleRadius = 5, kSeenFromZ = 10;

// `seen_down_deg`: the width of the side (about -y) whose wall was seen all the way down.
// `mouth_blur_mm`: the bottom face's points go on this far into the hole's mouth (a camera pixel
// at the rim sees the face and the hole's dark inside, and its point lands on the face's plane).
PointCloud holed_block_points(double flat_y, unsigned seed, double seen_down_deg = 180, double mouth_blur_mm = 0) {
    const double spacing = 0.4, noise_mm = 0.01;
    std::mt19937 random(seed);
    std::normal_distribution<double> noise(0, noise_mm);
    std::uniform_real_distribution<double> jitter(-0.5, 0.5);
    PointCloud cloud;
    auto add = [&](const cv::Vec3d& p, const cv::Vec3d& n) {
        cloud.points.emplace_back(p + noise(random) * n);
        cloud.normals.emplace_back(n);
    };
    auto in_hole = [&](double x, double y) { return std::hypot(x, y) < kHoleRadius && (flat_y <= 0 || y < flat_y); };
    const double h = kHoleBlock / 2;
    for (double a = -h + spacing / 2; a < h; a += spacing)
        for (double b = spacing / 2; b < kHoleBlockHeight; b += spacing) {
            const double u = a + jitter(random) * spacing, w = std::clamp(b + jitter(random) * spacing, 0.0, kHoleBlockHeight);
            add(cv::Vec3d(-h, u, w), cv::Vec3d(-1, 0, 0));
            add(cv::Vec3d(h, u, w), cv::Vec3d(1, 0, 0));
            add(cv::Vec3d(u, -h, w), cv::Vec3d(0, -1, 0));
            add(cv::Vec3d(u, h, w), cv::Vec3d(0, 1, 0));
        }
    for (double a = -h + spacing / 2; a < h; a += spacing)
        for (double b = -h + spacing / 2; b < h; b += spacing) {
            const double x = a + jitter(random) * spacing, y = b + jitter(random) * spacing;
            // A negative blur: the bottom face's points stop that far short of the hole.
            if (std::hypot(x, y) >= kHoleRadius - mouth_blur_mm || (mouth_blur_mm >= 0 && !in_hole(x, y)))
                add(cv::Vec3d(x, y, 0), cv::Vec3d(0, 0, -1));
            if (in_hole(x, y)) continue;
            add(cv::Vec3d(x, y, kHoleBlockHeight), cv::Vec3d(0, 0, 1));
        }
    // The wall, by arc length around the round part and along the flat; its normals point into the hole.
    auto seen = [&](double angle, double z) {
        const double from_minus_y = std::abs(std::remainder(angle + CV_PI / 2, 2 * CV_PI)) * 180 / CV_PI;
        return z >= kSeenFromZ || from_minus_y < seen_down_deg / 2;
    };
    for (double z = spacing / 2; z < kHoleBlockHeight; z += spacing) {
        for (double s = 0; s < 2 * CV_PI * kHoleRadius; s += spacing) {
            const double angle = (s + jitter(random) * spacing) / kHoleRadius, zz = z + jitter(random) * spacing;
            const cv::Vec3d radial(std::cos(angle), std::sin(angle), 0);
            const cv::Vec3d p = kHoleRadius * radial;
            if ((flat_y > 0 && p[1] > flat_y) || !seen(angle, zz)) continue;
            add(p + cv::Vec3d(0, 0, zz), -radial);
        }
        if (flat_y > 0 && z >= kSeenFromZ) {
            const double half = std::sqrt(kHoleRadius * kHoleRadius - flat_y * flat_y);
            for (double x = -half; x < half; x += spacing) add(cv::Vec3d(x + jitter(random) * spacing, flat_y, z), cv::Vec3d(0, -1, 0));
        }
    }
    return cloud;
}

}  // namespace

// The hole's wall that no view saw (its y > 0 half below z = 10): Poisson guesses it, and the
// sharpening puts it on the cylinder fitted to the seen wall, where that wall was seen at the
// same turn about the axis (here near the top). Built to fool it: a D-shaped hole, whose flat
// side was seen only near the top, must keep its flat (not be forced round), and the unseen
// wall stays marked filled either way.
TEST(MeshSharpen, UnseenHoleWallGoesOntoTheFittedCylinderOnlyWhereTheWallIsRound) {
    for (double flat_y : {0.0, 3.0}) {
        const Mesh mesh = mesh_cloud(holed_block_points(flat_y, 5));
        const MeshCheck check = check_mesh(mesh);
        std::printf("%s hole: %s\n", flat_y > 0 ? "D-shaped" : "round", check.summary().c_str());
        ASSERT_TRUE(check.closed_volume);
        EXPECT_FALSE(check.self_intersecting);
        // The unseen wall's vertices (y > 1, 1 mm clear of the seen band and of the bottom).
        size_t unseen = 0, filled = 0, on_flat = 0, on_circle = 0;
        double worst_off_wall = 0, sum_off_wall = 0;
        for (size_t v = 0; v < mesh.vertices.size(); ++v) {
            const cv::Vec3d p(mesh.vertices[v]);
            const double r = std::hypot(p[0], p[1]);
            if (p[1] < 1 || p[2] < 1 || p[2] > kSeenFromZ - 1 || r > kHoleRadius + 2.5) continue;
            ++unseen;
            filled += mesh.measured[v] == 0;
            const bool on_flat_side = flat_y > 0 && std::abs(p[0]) < 0.8 * std::sqrt(kHoleRadius * kHoleRadius - flat_y * flat_y);
            const double off_wall = on_flat_side ? std::abs(p[1] - flat_y) : std::abs(r - kHoleRadius);
            worst_off_wall = std::max(worst_off_wall, off_wall);
            sum_off_wall += off_wall;
            on_flat += on_flat_side;
            on_circle += (on_flat_side || flat_y <= 0) && std::abs(r - kHoleRadius) < 0.02;
        }
        std::printf("%s hole: %zu unseen wall vertices, %zu marked filled; off the true wall: mean %.1f um, worst %.1f um; "
                    "on the flat side %zu; within 20 um of the circle (on the flat side, for the D): %zu\n",
                    flat_y > 0 ? "D-shaped" : "round", unseen, filled, 1000 * sum_off_wall / double(std::max<size_t>(unseen, 1)),
                    1000 * worst_off_wall, on_flat, on_circle);
        // Measured (2026-11-24, branch holewall): round, 768 unseen wall vertices, mean 1.2 um and
        // worst 2.4 um off the wall (the wall triangulated anew on the cylinder). Before, with
        // Poisson's vertices relaxed onto the cylinder: 1 158 vertices, mean 519 um, worst 2.5 mm
        // (Poisson narrowed this hole by up to half its radius; its faces folded on the wall and
        // the fold check pulled them back). The D, 330 vertices on its flat side, none on the circle.
        ASSERT_GT(unseen, 100u);
        EXPECT_EQ(filled, unseen);  // invented, and said so
        if (flat_y > 0) {
            ASSERT_GT(on_flat, 100u);
            EXPECT_LT(on_circle, on_flat / 50);  // not forced round (by chance a vertex may lie there)
        } else {
            EXPECT_GT(on_circle, unseen / 2);  // the round wall's unseen half on its cylinder
            EXPECT_LT(sum_off_wall / double(unseen), 0.020);  // measured 1.2 um (see above)
            EXPECT_LT(worst_off_wall, 0.150);                  // issue 12's mesh -> truth maximum
        }
    }
}

// Built to fool the fill: the hole's wall seen all round only near its top (z 10-14), and all the
// way down only on a 60 degree strip (a camera looking into the hole from one side). Poisson
// guesses the rest of the wall, narrowing the hole by millimetres; the fill must put that guess
// on the cylinder without folding it, and say it is filled. The wall triangulated anew on the
// cylinder (as for the test above) is refused here (its rim, unrolled, is not simple loops):
// without a fallback Poisson's guess stayed, mean 178 um and worst 749 um off the wall near the
// bottom (measured 2026-11-24); with Poisson's vertices relaxed onto the cylinder as the
// fallback, mean 1.8 um and worst 4.1 um.
TEST(MeshSharpen, UnseenHoleWallSeenDownOnlyOnAStripGoesOntoItsCylinder) {
    const Mesh mesh = mesh_cloud(holed_block_points(0.0, 7, 60));
    const MeshCheck check = check_mesh(mesh);
    std::printf("hole seen down a strip: %s\n", check.summary().c_str());
    ASSERT_TRUE(check.closed_volume);
    EXPECT_FALSE(check.self_intersecting);
    // The unseen wall's vertices: 1 mm clear of the seen band, of the strip and of the bottom.
    size_t unseen = 0, filled = 0;
    double worst = 0, sum = 0;
    cv::Vec3d worst_at;
    for (size_t v = 0; v < mesh.vertices.size(); ++v) {
        const cv::Vec3d p(mesh.vertices[v]);
        const double r = std::hypot(p[0], p[1]);
        const double from_minus_y = std::abs(std::remainder(std::atan2(p[1], p[0]) + CV_PI / 2, 2 * CV_PI)) * 180 / CV_PI;
        if (from_minus_y < 30 + 12 || p[2] < 1 || p[2] > kSeenFromZ - 1 || r > kHoleRadius + 2.5) continue;
        ++unseen;
        filled += mesh.measured[v] == 0;
        const double off = std::abs(r - kHoleRadius);
        sum += off;
        if (off > worst) worst = off, worst_at = p;
    }
    std::printf("hole seen down a strip: %zu unseen wall vertices, %zu marked filled; off the true wall: mean %.1f um, "
                "worst %.1f um at (%.2f, %.2f, %.2f)\n", unseen, filled, 1000 * sum / double(std::max<size_t>(unseen, 1)),
                1000 * worst, worst_at[0], worst_at[1], worst_at[2]);
    ASSERT_GT(unseen, 300u);
    EXPECT_EQ(filled, unseen);  // invented, and said so
    EXPECT_LT(sum / double(unseen), 0.020);
    EXPECT_LT(worst, 0.150);  // issue 12's mesh -> truth maximum
}

namespace {

// Within 1.5 mm of the hole's bottom rim, on the unseen side (1.5 mm clear of the seen half).
bool near_unseen_bottom_rim(const cv::Vec3d& p) {
    return p[1] >= 1.5 && std::hypot(std::hypot(p[0], p[1]) - kHoleRadius, p[2]) <= 1.5;
}

// Distance of a point from the part at the rim's corner (the bottom face z = 0 and the hole's
// wall): positive out of the material (into the hole or below the block), negative inside.
double off_the_bottom_rim_corner(const cv::Vec3d& p) {
    const double into_hole = kHoleRadius - std::hypot(p[0], p[1]), below = -p[2];
    return into_hole > 0 && below > 0   ? std::hypot(into_hole, below)
           : into_hole > 0 || below > 0 ? std::max(into_hole, below)
                                        : std::min(-into_hole, -below);
}

}  // namespace

// The rim where the rebuilt unseen wall meets the bottom face (the hole's mouth at z = 0 on its
// y > 0 side): its vertices lie on the bottom face's points, so they are measured and are not
// rebuilt; left as Poisson made them they round the edge off by a triangle. The rebuilt wall
// must take its rim with it: the rim vertices on the circle where the cylinder meets the bottom
// plane, as at any sharp edge. Judged by each vertex's distance from the true part near that
// circle (exact there: from the circle below the face and inside the hole, else from the
// nearer face). Bound: issue 12's mesh -> truth maximum (150 um), not yet 50 um: moving the
// rim onto the circle inside the wall's rebuild (branch rim) gave 1.1 um here but a mesh that
// crossed itself on a real scan (its moves escaped the fold and crossing checks), and made
// under those checks 172.8 um here (2026-11-24, branch rim3), worse than none; so the rim stays
// as Poisson and the sharp-edge code leave it (measured 2026-11-24: 120.2 um on main). Since a
// vertex pulled back to unfold a face goes no further than unfolds it (branch rim5): 10.8 um.
constexpr double kMouthBlurMm = 0.25;
TEST(MeshSharpen, RebuiltHoleWallsRimOnTheFaceItOpensOnIsSharp) {
    const Mesh mesh = mesh_cloud(holed_block_points(0.0, 5, 180, kMouthBlurMm));
    const MeshCheck check = check_mesh(mesh);
    std::printf("holed block, the bottom face's points %.2f mm into the hole: %s\n", kMouthBlurMm, check.summary().c_str());
    ASSERT_TRUE(check.closed_volume);
    size_t near_rim = 0;
    double worst = 0;
    cv::Vec3d worst_at;
    for (size_t v = 0; v < mesh.vertices.size(); ++v) {
        const cv::Vec3d p(mesh.vertices[v]);
        if (!near_unseen_bottom_rim(p)) continue;
        ++near_rim;
        const double off = off_the_bottom_rim_corner(p);
        if (off > worst) worst = off, worst_at = p;
    }
    std::printf("rebuilt wall's bottom rim: %zu vertices within 1.5 mm of it, worst %.1f um off the part at (%.2f, %.2f, %.2f)\n",
                near_rim, 1000 * worst, worst_at[0], worst_at[1], worst_at[2]);
    ASSERT_GT(near_rim, 50u);
    EXPECT_LT(worst, 0.050);
}

// The bottom face's points stopping short of the hole's mouth (as the real scans' do, the
// edge's blur thinning them): the rebuilt wall's vertices near the rim have none of that face's
// points near, and Poisson's rim vertices go onto the bottom face a few tenths of a millimetre
// out from the circle. The faces between the two must be split on the circle, not span the
// corner inside the material. Judged over points spread on the faces near the rim (a face
// spanning the corner has its vertices on the part and its middle inside it). Measured
// (2026-11-24): 9.1 um on branch rim, 11.4 um on main after rim3; 315.9 um before the wall's vertices with no face points
// near could have their edges split. With the points stopping 0.2-0.5 mm short it is still
// 250-976 um (not fixed: see docs/multiview.md); 0.1 mm short: 7.5 um either way.
TEST(MeshSharpen, RebuiltHoleWallsFacesDoNotSpanTheRimWhereTheFaceWasNotSeenUpToIt) {
    const double gap_mm = 0.15;
    const Mesh mesh = mesh_cloud(holed_block_points(0.0, 5, 180, -gap_mm));
    const MeshCheck check = check_mesh(mesh);
    std::printf("holed block, the bottom face's points %.2f mm short of the hole: %s\n", gap_mm, check.summary().c_str());
    ASSERT_TRUE(check.closed_volume);
    EXPECT_FALSE(check.self_intersecting);
    size_t samples = 0;
    double worst = 0;
    cv::Vec3d worst_at;
    for (const cv::Vec3i& f : mesh.faces) {
        const cv::Vec3d a(mesh.vertices[f[0]]), b(mesh.vertices[f[1]]), c(mesh.vertices[f[2]]);
        for (int i = 0; i <= 4; ++i)
            for (int j = 0; i + j <= 4; ++j) {
                const cv::Vec3d p = a + (i / 4.0) * (b - a) + (j / 4.0) * (c - a);
                if (!near_unseen_bottom_rim(p)) continue;
                ++samples;
                const double off = off_the_bottom_rim_corner(p);
                if (off > worst) worst = off, worst_at = p;
            }
    }
    std::printf("rebuilt wall's bottom rim: %zu points on the faces within 1.5 mm of it, worst %.1f um off the part at "
                "(%.2f, %.2f, %.2f)\n", samples, 1000 * worst, worst_at[0], worst_at[1], worst_at[2]);
    ASSERT_GT(samples, 500u);
    EXPECT_LT(worst, 0.050);
}

// Built to make the sharpening cross faces: a block with a fin 0.5 mm thick standing on its top
// and a groove 0.5 mm wide cut beside it, both about one sample spacing across, so that Poisson
// rounds each to a bump or a dent and the sharp edges of the two sides of one fin or groove are
// less than a move apart (the moves onto one side's edge pass through the other side's faces).
// The mesh must come out closed and not crossing itself, whatever the sharpening kept.
TEST(MeshSharpen, ThinFinAndNarrowGrooveDoNotMakeTheMeshCrossItself) {
    constexpr double kSize = 16, kHigh = 6, kThin = 0.5, kFinHigh = 2, kGrooveDeep = 2;
    constexpr double kFinY = -3, kGrooveY = 3;  // their middles; both run along x
    SurfaceSampler sampler(0.4, 0.01, 7);
    auto add = [&](const cv::Vec3d& p, const cv::Vec3d& n) { sampler.add(p, n); };
    const double h = kSize / 2, t = kThin / 2;
    // Sides and bottom of the block.
    sampler.grid(kSize, kHigh, [&](double a, double z) {
        add(cv::Vec3d(a - h, -h, z), cv::Vec3d(0, -1, 0));
        add(cv::Vec3d(a - h, h, z), cv::Vec3d(0, 1, 0));
        if (std::abs(a - h - kGrooveY) < t && z > kHigh - kGrooveDeep) return;  // the groove's ends
        add(cv::Vec3d(-h, a - h, z), cv::Vec3d(-1, 0, 0));
        add(cv::Vec3d(h, a - h, z), cv::Vec3d(1, 0, 0));
    });
    sampler.grid(kSize, kSize, [&](double a, double b) {
        const double x = a - h, y = b - h;
        add(cv::Vec3d(x, y, 0), cv::Vec3d(0, 0, -1));
        if (std::abs(y - kGrooveY) < t) add(cv::Vec3d(x, y, kHigh - kGrooveDeep), cv::Vec3d(0, 0, 1));  // the groove's floor
        else if (std::abs(y - kFinY) < t) add(cv::Vec3d(x, y, kHigh + kFinHigh), cv::Vec3d(0, 0, 1));  // the fin's top
        else add(cv::Vec3d(x, y, kHigh), cv::Vec3d(0, 0, 1));
    });
    // The groove's walls (facing each other) and the fin's (facing away), and their ends at x = +-h.
    sampler.grid(kSize, kGrooveDeep, [&](double a, double z) {
        add(cv::Vec3d(a - h, kGrooveY - t, kHigh - z), cv::Vec3d(0, 1, 0));
        add(cv::Vec3d(a - h, kGrooveY + t, kHigh - z), cv::Vec3d(0, -1, 0));
        add(cv::Vec3d(a - h, kFinY - t, kHigh + z), cv::Vec3d(0, -1, 0));
        add(cv::Vec3d(a - h, kFinY + t, kHigh + z), cv::Vec3d(0, 1, 0));
    });
    sampler.grid(kThin, kFinHigh, [&](double a, double z) {
        for (double x : {-h, h}) add(cv::Vec3d(x, kFinY - t + a, kHigh + z), cv::Vec3d(x < 0 ? -1 : 1, 0, 0));
    });
    const Mesh mesh = mesh_cloud(sampler.cloud);
    const MeshCheck check = check_mesh(mesh);
    std::printf("block with a 0.5 mm fin and a 0.5 mm groove: %s\n", check.summary().c_str());
    EXPECT_TRUE(check.watertight());
    EXPECT_FALSE(check.self_intersecting);
    // Not by giving up the block's own edges: its outer top edges stay sharp (a vertex within
    // 50 um of the edge line at x = -h, z = kHigh away from the fin, groove and corners).
    double nearest_to_edge = 1e9;
    for (const cv::Vec3f& v : mesh.vertices) {
        const cv::Vec3d p(v);
        if (std::abs(p[1]) < h - 1 && std::abs(p[1] - kFinY) > 1.5 && std::abs(p[1] - kGrooveY) > 1.5)
            nearest_to_edge = std::min(nearest_to_edge, std::hypot(p[0] + h, p[2] - kHigh));
    }
    std::printf("nearest vertex to the block's top edge at x = -%.0f: %.1f um\n", h, 1000 * nearest_to_edge);
    EXPECT_LT(nearest_to_edge, 0.050);
}

// The same points give the same mesh again in one process, with the heap in another state: the
// holed block without its bottom (a part standing on the table), capped at the table. The cut at
// the table (CGAL's corefinement) orders its work by memory address; without the cut mesh put in
// a canonical order the second meshing gave another cap (13 150 and 13 153 vertices at 0.4 mm).
// Poisson's own repeatability: MeshFill.PoissonGivesTheSameMeshAgainInOneProcess.
TEST(MeshSharpen, TableCapGivesTheSameMeshAgainInOneProcess) {
    PointCloud standing;
    const PointCloud all = holed_block_points(0.0, 5);
    for (size_t i = 0; i < all.points.size(); ++i)
        if (all.points[i][2] > 0.05) standing.points.push_back(all.points[i]), standing.normals.push_back(all.normals[i]);
    MeshOptions options;
    options.fill = MeshFill::Table;
    options.sample_spacing_mm = 0.8;  // coarser: this test is about the order, not the detail
    const Mesh first = mesh_cloud(standing, options);
    const auto stirred = test_support::stir_heap();
    const Mesh second = mesh_cloud(standing, options);
    std::printf("holed block on the table, capped twice: %zu and %zu vertices, %zu and %zu faces\n", first.vertices.size(),
                second.vertices.size(), first.faces.size(), second.faces.size());
    ASSERT_EQ(first.vertices.size(), second.vertices.size());
    EXPECT_TRUE(first.vertices == second.vertices);
    EXPECT_TRUE(first.faces == second.faces);
}

namespace {

// A 24 x 18 x 12 mm box whose corner at (24, 18, 12) is cut off by a triangular facet with legs
// of kCut along the three edges (its middle lies kCut / sqrt(3) inside the corner the three
// faces would make); the other seven corners are sharp.
constexpr double kBoxX = 24, kBoxY = 18, kBoxZ = 12, kCut = 1.5;

double box_signed_distance(const cv::Vec3d& p) {
    const cv::Vec3d d(std::max(-p[0], p[0] - kBoxX), std::max(-p[1], p[1] - kBoxY), std::max(-p[2], p[2] - kBoxZ));
    const double box = std::min(std::max({d[0], d[1], d[2]}), 0.0) +
                       cv::norm(cv::Vec3d(std::max(d[0], 0.0), std::max(d[1], 0.0), std::max(d[2], 0.0)));
    const double facet = (p[0] - kBoxX + p[1] - kBoxY + p[2] - kBoxZ + kCut) / std::sqrt(3.0);
    return std::max(box, facet);  // exact inside and on the surface, which is what is judged
}

PointCloud cut_box_points(double spacing, double noise_mm, unsigned seed) {
    SurfaceSampler sampler(spacing, noise_mm, seed);
    auto add = [&](const cv::Vec3d& p, const cv::Vec3d& n) {
        if (p[0] + p[1] + p[2] > kBoxX + kBoxY + kBoxZ - kCut) return;  // cut off
        sampler.add(p, n);
    };
    auto grid = [&](double a_size, double b_size, auto&& place) { sampler.grid(a_size, b_size, place); };
    for (double z : {0.0, kBoxZ})
        grid(kBoxX, kBoxY, [&](double x, double y) { add(cv::Vec3d(x, y, z), cv::Vec3d(0, 0, z > 0 ? 1 : -1)); });
    for (double y : {0.0, kBoxY})
        grid(kBoxX, kBoxZ, [&](double x, double z) { add(cv::Vec3d(x, y, z), cv::Vec3d(0, y > 0 ? 1 : -1, 0)); });
    for (double x : {0.0, kBoxX})
        grid(kBoxY, kBoxZ, [&](double y, double z) { add(cv::Vec3d(x, y, z), cv::Vec3d(x > 0 ? 1 : -1, 0, 0)); });
    // The facet, from its corner on the x edge across.
    const cv::Vec3d a(kBoxX - kCut, kBoxY, kBoxZ), b(kBoxX, kBoxY - kCut, kBoxZ), c(kBoxX, kBoxY, kBoxZ - kCut);
    const cv::Vec3d normal = cv::normalize(cv::Vec3d(1, 1, 1));
    const double side = cv::norm(b - a);
    grid(side, side, [&](double u, double w) {
        if (u + w > side) return;
        sampler.add(a + (b - a) * (u / side) + (c - a) * (w / side), normal);
    });
    return sampler.cloud;
}

}  // namespace

// Corners where three planes meet get a vertex on the point they meet at. Built to fool it: a
// corner cut off by a small facet (too small to be found as a plane of its own: about 60 points)
// has the three planes around it too, and they meet 0.87 mm outside the part: it must stay cut.
TEST(MeshSharpen, SharpCornersComeBackAndACutCornerStaysCut) {
    for (unsigned seed : {3u}) {  // one seed: a second adds 7 s of CPU
        const Mesh mesh = mesh_cloud(cut_box_points(0.25, 0.01, seed));
        const MeshCheck check = check_mesh(mesh);
        std::printf("seed %u: %s\n", seed, check.summary().c_str());
        ASSERT_TRUE(check.closed_volume);
        EXPECT_FALSE(check.self_intersecting);
        const double true_volume = kBoxX * kBoxY * kBoxZ - kCut * kCut * kCut / 6;
        EXPECT_NEAR(check.volume_mm3 / true_volume - 1, 0.0, 0.002);
        double worst_sharp = 0, nearest_to_cut = 1e9, worst_vertex = 0;
        for (double x : {0.0, kBoxX})
            for (double y : {0.0, kBoxY})
                for (double z : {0.0, kBoxZ}) {
                    const cv::Vec3d corner(x, y, z);
                    double nearest = 1e9;
                    for (const cv::Vec3f& v : mesh.vertices) nearest = std::min(nearest, cv::norm(cv::Vec3d(v) - corner));
                    if (x > 0 && y > 0 && z > 0) nearest_to_cut = nearest;
                    else worst_sharp = std::max(worst_sharp, nearest);
                }
        // Off the part: the vertices more than 1 mm from the cut corner's facet, and those near it
        // (the facet is too small to be found as a plane: its edges keep Poisson's rounding, and
        // the lines of the faces beside it run on a little past them).
        double worst_near_cut = 0;
        cv::Vec3d worst_at;
        for (const cv::Vec3f& v : mesh.vertices) {
            const cv::Vec3d p(v);
            const double off = std::abs(box_signed_distance(p));
            if (p[0] + p[1] + p[2] > kBoxX + kBoxY + kBoxZ - kCut - std::sqrt(3.0)) {
                worst_near_cut = std::max(worst_near_cut, off);
            } else if (off > worst_vertex) {
                worst_vertex = off;
                worst_at = p;
            }
        }
        std::printf("seed %u: worst vertex off the part at (%.3f, %.3f, %.3f)\n", seed, worst_at[0], worst_at[1], worst_at[2]);
        std::printf("seed %u: nearest vertex to each sharp corner at most %.1f um away; to the point the cut corner's "
                    "planes meet at %.3f mm (its facet: %.3f mm); vertices at most %.1f um off the part (%.1f um within "
                    "1 mm of the facet)\n",
                    seed, 1000 * worst_sharp, nearest_to_cut, kCut / std::sqrt(3.0), 1000 * worst_vertex, 1000 * worst_near_cut);
        // Measured (2026-11-24, see docs/multiview.md): corners 0.9 um, the cut corner's nearest
        // vertex 0.783 mm, 166 um off the part beside the facet. Before the corner's vertex was
        // the one the corner lies straight out from (the nearest was dragged 0.43 mm sideways),
        // a vertex beside the corner at (0, 18, 12) folded and was pulled back: 199 um off.
        // Since Poisson's refinement no longer follows memory addresses (another, repeatable
        // surface): 184.6 um at (23.815, 1.808, 11.764), one of 4 vertices beside the +x/top edge
        // whose move straight onto the x = 24 plane turned a sliver over across the edge, so the
        // fold check kept them where Poisson rounded the edge. With edge vertices moved onto
        // their plane square to the edge and slivers turned over within one plane untangled in
        // it (2026-11-24, branch edges): 0.9 um; 124.6 um with the first alone (faces with a
        // cut merged into its neighbour still folded on the y = 0 and x = 0 planes).
        EXPECT_LT(worst_sharp, 0.030);
        EXPECT_GT(nearest_to_cut, 0.7);  // a sharpened cut corner puts a vertex there
        EXPECT_LT(worst_vertex, 0.030);
        EXPECT_LT(worst_near_cut, 0.250);
    }
}

namespace {

// A 12 x 10 x 8 mm box whose points in the blur's tail beside every edge (0.5 to 0.8 mm from
// the edge's line along the face) lie 0.07 mm out from their face: a camera pixel there still
// takes in a little of the other face (the speckled two-placement scan's block edges: 0.050 to
// 0.077 mm off at 0.50 to 0.66 mm from the line). Not a fillet (that lies inside the faces).
constexpr double kTailBoxX = 12, kTailBoxY = 10, kTailBoxZ = 8, kTailOffMm = 0.07;

PointCloud blurred_tail_box_points(double spacing, double noise_mm, unsigned seed) {
    SurfaceSampler sampler(spacing, noise_mm, seed);
    const cv::Vec3d size(kTailBoxX, kTailBoxY, kTailBoxZ);
    for (int axis = 0; axis < 3; ++axis)
        for (double side : {0.0, 1.0}) {
            const int u = (axis + 1) % 3, w = (axis + 2) % 3;
            cv::Vec3d normal(0, 0, 0);
            normal[axis] = side > 0 ? 1 : -1;
            sampler.grid(size[u], size[w], [&](double a, double b) {
                const double from_edge = std::min({a, size[u] - a, b, size[w] - b});
                cv::Vec3d p(0, 0, 0);
                p[axis] = side * size[axis];
                p[u] = a;
                p[w] = b;
                if (from_edge >= 0.5 && from_edge <= 0.8) p += kTailOffMm * normal;
                sampler.add(p, normal);
            });
        }
    return sampler.cloud;
}

}  // namespace

// The edges of a box whose points beside them are blurred a little off their faces come back
// sharp: those points are the edge's blur, not a fillet (the vertices there had no model of
// their planes, so the edges stayed as Poisson rounded them).
TEST(MeshSharpen, EdgesBlurredBesideTheLineComeBackSharp) {
    const Mesh mesh = mesh_cloud(blurred_tail_box_points(0.25, 0.005, 5));
    const MeshCheck check = check_mesh(mesh);
    std::printf("%s\n", check.summary().c_str());
    ASSERT_TRUE(check.closed_volume);
    EXPECT_FALSE(check.self_intersecting);
    // The true surface within 1 mm of an edge: how far the mesh is from it.
    SurfaceSampler truth_sampler(0.1, 0, 7);
    const cv::Vec3d size(kTailBoxX, kTailBoxY, kTailBoxZ);
    for (int axis = 0; axis < 3; ++axis)
        for (double side : {0.0, 1.0}) {
            const int u = (axis + 1) % 3, w = (axis + 2) % 3;
            truth_sampler.grid(size[u], size[w], [&](double a, double b) {
                if (std::min({a, size[u] - a, b, size[w] - b}) > 1) return;
                cv::Vec3d p(0, 0, 0);
                p[axis] = side * size[axis];
                p[u] = a;
                p[w] = b;
                truth_sampler.add(p, cv::Vec3d(0, 0, 0));
            });
        }
    const DeviationMap to_mesh = measure_deviation(truth_sampler.cloud.points, mesh);
    std::printf("truth -> mesh within 1 mm of the edges (%zu samples): mean %.1f um, max %.1f um\n",
                truth_sampler.cloud.points.size(), 1000 * to_mesh.statistics.mean_abs_mm, 1000 * to_mesh.statistics.max_abs_mm);
    EXPECT_LT(to_mesh.statistics.max_abs_mm, 0.100);
}
