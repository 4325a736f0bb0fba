#include "support/turntable_scan.h"

#include "picoscan/io.h"
#include "picoscan/pipeline.h"

#include <opencv2/core.hpp>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <cstdio>

namespace picoscan::test_support {

namespace {

// One view as the turntable recipe (pipeline.h) makes it.
ScanView scan_view(const Mesh& part, const cv::Matx44d& part_to_camera, uint64_t noise_seed) {
    const Calibration rig = seed_rig_calibration();
    const TurntableScanOptions recipe;
    Scene scene;
    scene.meshes.push_back({transformed(part, part_to_camera), recipe.part_albedo});
    SimulateOptions simulate;
    simulate.patterns = recipe.patterns;
    simulate.camera = recipe.camera;
    simulate.camera.seed = noise_seed;  // independent camera noise in every view
    ReconstructOptions reconstruct;
    reconstruct.decode = recipe.decode;
    reconstruct.clean = true;
    return reconstruct_view(simulate_captures(scene, rig, simulate), rig, "seed rig", reconstruct).view;
}

TurntableScan make_scan(const std::string& name, double disturbance_deg, double disturbance_mm) {
    TurntableScan scan;
    scan.part = mechanical_part();
    TurntablePlan plan;
    plan.max_disturbance_deg = disturbance_deg;
    plan.max_disturbance_mm = disturbance_mm;
    scan.part_to_camera = turntable_part_poses(plan);
    const std::filesystem::path cache = std::filesystem::path(PICOSCAN_TEST_CACHE_DIR) / name;
    std::filesystem::create_directories(cache);
    for (size_t i = 0; i < scan.part_to_camera.size(); ++i) {
        const std::string file = "view_" + std::to_string(i) + ".ply";
        const std::filesystem::path path = cache / file;
        if (!std::filesystem::exists(path)) {
            std::printf("scanning %s (cached in %s)\n", file.c_str(), cache.string().c_str());
            write_view_ply(scan_view(scan.part, scan.part_to_camera[i], i + 1), path.string());
        }
        scan.views.push_back(read_view_ply(path.string()));
        scan.names.push_back(file);
        scan.true_view_to_model.push_back(scan.part_to_camera[0] * scan.part_to_camera[i].inv());
    }
    return scan;
}

}  // namespace

cv::Vec3d TurntableScan::centroid(size_t view) const {
    const std::vector<cv::Vec3f> points = to_point_cloud(views[view]).points;
    cv::Vec3d sum(0, 0, 0);
    for (const cv::Vec3f& p : points) sum += cv::Vec3d(p);
    return points.empty() ? sum : sum * (1.0 / static_cast<double>(points.size()));
}

// The cache key names everything that shapes the scan; change it when any of that changes.
const TurntableScan& disturbed_turntable_scan() {
    static const TurntableScan scan = make_scan("turntable-v3-disturbed", 10, 20);
    return scan;
}

const TurntableScan& turntable_scan() {
    static const TurntableScan scan = make_scan("turntable-v3-exact", 0, 0);
    return scan;
}

namespace {

long long cell_key(long long x, long long y, long long z) { return (x * 73856093LL) ^ (y * 19349663LL) ^ (z * 83492791LL); }

// Closest point on triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
cv::Vec3d closest_on_triangle(const cv::Vec3d& p, const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c) {
    const cv::Vec3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) return a;
    const cv::Vec3d bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
    const cv::Vec3d cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    const double denominator = 1.0 / (va + vb + vc);
    return a + ab * (vb * denominator) + ac * (vc * denominator);
}

}  // namespace

MeshDistance::MeshDistance(const Mesh& mesh, double reach_mm) : mesh_(mesh), reach_mm_(reach_mm) {
    // Each triangle goes in every cell its box (grown by the reach) touches.
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        cv::Vec3d lo(1e30, 1e30, 1e30), hi(-1e30, -1e30, -1e30);
        for (int k = 0; k < 3; ++k)
            for (int d = 0; d < 3; ++d) {
                lo[d] = std::min(lo[d], static_cast<double>(mesh.vertices[mesh.faces[f][k]][d]));
                hi[d] = std::max(hi[d], static_cast<double>(mesh.vertices[mesh.faces[f][k]][d]));
            }
        long long l[3], h[3];
        for (int d = 0; d < 3; ++d) {
            l[d] = static_cast<long long>(std::floor((lo[d] - reach_mm) / reach_mm));
            h[d] = static_cast<long long>(std::floor((hi[d] + reach_mm) / reach_mm));
        }
        for (long long x = l[0]; x <= h[0]; ++x)
            for (long long y = l[1]; y <= h[1]; ++y)
                for (long long z = l[2]; z <= h[2]; ++z) cells_[cell_key(x, y, z)].push_back(static_cast<int>(f));
    }
}

double MeshDistance::operator()(const cv::Vec3d& point) const {
    const auto found = cells_.find(cell_key(static_cast<long long>(std::floor(point[0] / reach_mm_)),
                                            static_cast<long long>(std::floor(point[1] / reach_mm_)),
                                            static_cast<long long>(std::floor(point[2] / reach_mm_))));
    double best = reach_mm_;
    if (found == cells_.end()) return best;
    for (int f : found->second) {
        const cv::Vec3i& face = mesh_.faces[static_cast<size_t>(f)];
        const cv::Vec3d q = closest_on_triangle(point, cv::Vec3d(mesh_.vertices[face[0]]), cv::Vec3d(mesh_.vertices[face[1]]),
                                                cv::Vec3d(mesh_.vertices[face[2]]));
        best = std::min(best, cv::norm(point - q));
    }
    return best;
}

}  // namespace picoscan::test_support
