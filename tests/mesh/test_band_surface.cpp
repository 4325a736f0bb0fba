// The open band surface (fill open): one simulated view of the mechanical part against its
// true surface; inputs built to fool it (a thin wall's two sides, a gap wider than the band,
// a curved patch); cancelling.
#include "picoscan/error.h"
#include "picoscan/mesh.h"
#include "picoscan/pipeline.h"
#include "support/test_support.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

using namespace picoscan;

namespace {

struct Spread {
    double mean = 0, p95 = 0, max = 0;
};

Spread spread_of(std::vector<double> values) {
    Spread s;
    if (values.empty()) return s;
    std::sort(values.begin(), values.end());
    for (double v : values) s.mean += v;
    s.mean /= double(values.size());
    s.p95 = values[values.size() * 95 / 100];
    s.max = values.back();
    return s;
}

// Mesh vertices -> the true surface.
Spread distance_to(const Mesh& mesh, const Mesh& truth) {
    const test_support::MeshDistance distance(truth, 1.0);
    std::vector<double> d;
    for (const cv::Vec3f& v : mesh.vertices) d.push_back(distance(cv::Vec3d(v)));
    return spread_of(d);
}

// The farthest any face centre lies from the nearest input point (reach_mm when farther).
double farthest_face_from_points(const Mesh& mesh, const PointCloud& cloud, double reach_mm) {
    Mesh points;  // the points as degenerate triangles, to reuse the distance grid
    for (const cv::Vec3f& p : cloud.points) {
        points.vertices.push_back(p);
        const int v = int(points.vertices.size()) - 1;
        points.faces.emplace_back(v, v, v);
    }
    const test_support::MeshDistance distance(points, reach_mm);
    double farthest = 0;
    for (const cv::Vec3i& f : mesh.faces) {
        const cv::Vec3d centre =
            (cv::Vec3d(mesh.vertices[f[0]]) + cv::Vec3d(mesh.vertices[f[1]]) + cv::Vec3d(mesh.vertices[f[2]])) / 3.0;
        farthest = std::max(farthest, distance(centre));
    }
    return farthest;
}

void expect_manifold(const MeshCheck& check) {
    EXPECT_GT(check.faces, 0u);
    EXPECT_EQ(check.non_manifold_edges, 0u);
    EXPECT_EQ(check.non_manifold_vertices, 0u);
    EXPECT_GT(check.border_edges, 0u);  // open: the unseen side is not closed
}

// A plane patch [x0, x1] x [y0, y1] at height z, points `step` apart with Gaussian noise
// along the normal (0, 0, facing).
void add_patch(PointCloud& cloud, double x0, double x1, double y0, double y1, double z, double facing, double step,
               double noise, std::mt19937& random) {
    std::normal_distribution<double> gauss(0.0, noise);
    for (double y = y0; y <= y1; y += step)
        for (double x = x0; x <= x1; x += step) {
            cloud.points.emplace_back(float(x), float(y), float(z + gauss(random)));
            cloud.normals.emplace_back(0.f, 0.f, float(facing));
        }
}

MeshOptions open_options(double spacing_mm) {
    MeshOptions options;
    options.fill = MeshFill::Open;
    options.sample_spacing_mm = spacing_mm;
    return options;
}

}  // namespace

// One simulated view of the mechanical part (seed rig, 1600 x 1200, sigma = 1 DN): every
// vertex near the true surface, every face on measured points, a manifold open surface.
// Poisson with fill open on the same view (the path this replaced) gave mean 35.7 um, p95
// 272 um (the disabled test below; docs/multiview.md): the bounds here are tighter.
TEST(BandSurface, OneViewMatchesTheTruthAndStaysOnThePoints) {
    const test_support::TurntableScan& scan = test_support::turntable_scan();
    const ScanView& view = scan.views[0];
    const PointCloud cloud = to_point_cloud(view);
    const Mesh mesh = mesh_view(view, open_options(0.4));
    const MeshCheck check = check_mesh(mesh);
    const Spread error = distance_to(mesh, transformed(scan.part, scan.part_to_camera[0]));
    const double farthest = farthest_face_from_points(mesh, cloud, 1.2);
    std::printf("one view, fill open: %s\n", check.summary().c_str());
    std::printf("mesh -> truth over %zu vertices: mean %.1f um, p95 %.1f um, max %.1f um; farthest face from the points "
                "%.2f mm\n",
                mesh.vertices.size(), 1000 * error.mean, 1000 * error.p95, 1000 * error.max, farthest);
    expect_manifold(check);
    EXPECT_LT(check.filled_fraction, 0.01);
    EXPECT_LT(error.mean, 0.020);
    EXPECT_LT(error.p95, 0.060);
    EXPECT_LT(farthest, 1.0);
    // The whole view is meshed: the faces cover the points.
    const test_support::MeshDistance to_mesh(mesh, 0.5);
    size_t covered = 0;
    for (size_t i = 0; i < cloud.points.size(); i += 7) covered += to_mesh(cv::Vec3d(cloud.points[i])) < 0.3 ? 1 : 0;
    EXPECT_GT(double(covered) / double((cloud.points.size() + 6) / 7), 0.98);
}

// The same view by Poisson with fill poisson, its filled faces dropped: what fill open gave
// before the band surface. Slow (tens of seconds): run by hand with
// --gtest_also_run_disabled_tests to reproduce the figure quoted above.
TEST(BandSurface, DISABLED_PoissonOpenOnTheSameView) {
    const test_support::TurntableScan& scan = test_support::turntable_scan();
    MeshOptions options = open_options(0.4);
    options.fill = MeshFill::Poisson;
    const Mesh closed = mesh_view(scan.views[0], options);
    Mesh open;
    for (const cv::Vec3i& f : closed.faces)
        if (closed.measured[f[0]] + closed.measured[f[1]] + closed.measured[f[2]] >= 2) open.faces.push_back(f);
    open.vertices = closed.vertices;
    std::vector<uint8_t> used(open.vertices.size(), 0);
    for (const cv::Vec3i& f : open.faces)
        for (int k = 0; k < 3; ++k) used[f[k]] = 1;
    const Mesh truth = transformed(scan.part, scan.part_to_camera[0]);
    const Spread all = distance_to(open, truth);
    std::vector<double> d;
    const test_support::MeshDistance distance(truth, 1.0);
    for (size_t v = 0; v < open.vertices.size(); ++v)
        if (used[v]) d.push_back(distance(cv::Vec3d(open.vertices[v])));
    const Spread error = spread_of(d);
    std::printf("one view, Poisson open: %zu faces; mesh -> truth over %zu vertices: mean %.1f um, p95 %.1f um, max %.1f "
                "um (all %.1f um)\n",
                open.faces.size(), d.size(), 1000 * error.mean, 1000 * error.p95, 1000 * error.max, 1000 * all.mean);
}

// A thin wall seen from both sides (1.5 mm thick: its two faces 0.3 mm sampled, facing
// away from each other) stays two sheets: no face inside the wall. (At the wall's rim the
// points' normals, estimated from neighbours of both sides, tilt: faces there may curl up to
// 0.3 mm in.)
TEST(BandSurface, ThinWallKeepsBothSides) {
    std::mt19937 random(7);
    PointCloud cloud;
    add_patch(cloud, 0, 40, 0, 30, 0.0, +1, 0.3, 0.02, random);
    add_patch(cloud, 0, 40, 0, 30, -1.5, -1, 0.3, 0.02, random);
    const Mesh mesh = mesh_points(cloud, open_options(0.4));
    const MeshCheck check = check_mesh(mesh);
    std::printf("thin wall: %s\n", check.summary().c_str());
    expect_manifold(check);
    EXPECT_EQ(check.components, 2u);
    double top_area = 0, bottom_area = 0;
    size_t off_face = 0, inside = 0;
    for (const cv::Vec3i& f : mesh.faces) {
        const cv::Vec3d a(mesh.vertices[f[0]]), b(mesh.vertices[f[1]]), c(mesh.vertices[f[2]]);
        const cv::Vec3d n = (b - a).cross(c - a) * 0.5;
        const double z = (a[2] + b[2] + c[2]) / 3;
        const double off = std::min(std::abs(z), std::abs(z + 1.5));
        off_face += off > 0.1 ? 1 : 0;
        inside += off > 0.3 ? 1 : 0;
        (z > -0.75 ? top_area : bottom_area) += cv::norm(n);
        EXPECT_GT(n[2] * (z > -0.75 ? 1 : -1), 0) << "a face turned inwards at " << a;
    }
    std::printf("thin wall areas: %.0f and %.0f mm^2 of 1200; %zu faces more than 0.1 mm off the wall's faces\n",
                top_area, bottom_area, off_face);
    EXPECT_EQ(inside, 0u);
    EXPECT_LT(off_face, 20u);
    EXPECT_NEAR(top_area, 1200, 60);
    EXPECT_NEAR(bottom_area, 1200, 60);
}

// Two patches 3 mm apart in one plane (wider than the band): the gap stays open.
TEST(BandSurface, GapWiderThanTheBandStaysOpen) {
    std::mt19937 random(11);
    PointCloud cloud;
    add_patch(cloud, -30, -1.5, -15, 15, 0.0, +1, 0.3, 0.02, random);
    add_patch(cloud, 1.5, 30, -15, 15, 0.0, +1, 0.3, 0.02, random);
    const Mesh mesh = mesh_points(cloud, open_options(0.4));
    const MeshCheck check = check_mesh(mesh);
    std::printf("gap: %s\n", check.summary().c_str());
    expect_manifold(check);
    EXPECT_EQ(check.components, 2u);
    double innermost = 1e9;
    for (const cv::Vec3f& v : mesh.vertices) innermost = std::min(innermost, std::abs(double(v[0])));
    std::printf("innermost vertex %.2f mm from the gap's middle (its edges at 1.5 mm)\n", innermost);
    EXPECT_GT(innermost, 0.9);
}

// A noisy curved patch (the cap of a 12 mm ball seen from one side, sigma 30 um), not the
// fixture the constants were chosen on: vertices within the noise of the true sphere.
TEST(BandSurface, CurvedPatchFollowsTheSphere) {
    std::mt19937 random(3);
    std::normal_distribution<double> gauss(0.0, 0.03);
    const double radius = 12;
    PointCloud cloud;
    for (double y = -10; y <= 10; y += 0.25)
        for (double x = -10; x <= 10; x += 0.25) {
            const double r2 = x * x + y * y;
            if (r2 > 100) continue;
            const cv::Vec3d n = cv::Vec3d(x, y, std::sqrt(radius * radius - r2)) / radius;
            cloud.points.emplace_back(cv::Vec3f(n * (radius + gauss(random))));
            cloud.normals.emplace_back(cv::Vec3f(n));
        }
    const Mesh mesh = mesh_points(cloud, open_options(0.3));
    const MeshCheck check = check_mesh(mesh);
    std::vector<double> error;
    for (const cv::Vec3f& v : mesh.vertices) error.push_back(std::abs(cv::norm(cv::Vec3d(v)) - radius));
    const Spread s = spread_of(error);
    std::printf("sphere cap: %s; |r - 12| mean %.1f um, p95 %.1f um, max %.1f um\n", check.summary().c_str(),
                1000 * s.mean, 1000 * s.p95, 1000 * s.max);
    expect_manifold(check);
    EXPECT_EQ(check.components, 1u);
    EXPECT_LT(s.mean, 0.015);
    EXPECT_LT(s.max, 0.1);
}

// Cancelling in the signed distances stops the meshing: nothing more is reported.
TEST(BandSurface, CancelStopsTheMeshing) {
    std::mt19937 random(5);
    PointCloud cloud;
    add_patch(cloud, 0, 100, 0, 100, 0.0, +1, 0.4, 0.02, random);
    bool cancelled = false;
    int calls_after = 0;
    const std::string message = test_support::error_of([&] {
        mesh_points(cloud, open_options(0.4), [&](double, const std::string& stage) {
            if (cancelled) ++calls_after;
            if (stage == "band surface: signed distances") cancelled = true;
            return !cancelled;
        });
    });
    EXPECT_NE(message.find("cancelled"), std::string::npos) << message;
    EXPECT_EQ(calls_after, 0);
    EXPECT_NE(test_support::error_of([&] { band_surface(cloud, 0); }).find("voxel"), std::string::npos);
    cloud.normals.clear();
    EXPECT_NE(test_support::error_of([&] { band_surface(cloud, 0.3); }).find("normals"), std::string::npos);
}

// A cloud too wide for the voxel grid's 2^20 cells an axis is refused naming its width, also
// when the width does not fit an int (1e20 mm, reachable by calling band_surface directly: the
// message converted it to int, undefined behaviour that printed -2147483648 mm).
TEST(BandSurface, ACloudTooWideForTheVoxelIsRefusedNamingItsWidth) {
    PointCloud cloud;
    for (const float x : {0.f, 1e20f}) {
        cloud.points.emplace_back(x, 0.f, 0.f);
        cloud.normals.emplace_back(0.f, 0.f, 1.f);
    }
    const std::string message = test_support::error_of([&] { band_surface(cloud, 1.0); });
    EXPECT_NE(message.find("too fine for a cloud 1e+20 mm across"), std::string::npos) << message;
}
