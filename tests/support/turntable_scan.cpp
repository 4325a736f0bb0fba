#include "support/turntable_scan.h"

#include "picoscan/io.h"
#include "picoscan/pipeline.h"

#include <opencv2/core.hpp>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <cstdio>

namespace picoscan::test_support {

namespace {

// One view as the turntable recipe (pipeline.h) makes it.
ScanView scan_view(const Mesh& part, const cv::Matx44d& part_to_camera, uint64_t noise_seed,
                   const Calibration& rig = seed_rig_calibration()) {
    const TurntableScanOptions recipe;
    Scene scene;
    // A painted part is white with dark speckles; a plain one is uniform grey plastic.
    scene.meshes.push_back({transformed(part, part_to_camera), part.colours.empty() ? 0.6 : recipe.part_albedo});
    SimulateOptions simulate;
    simulate.patterns = recipe.patterns;
    simulate.camera = recipe.camera;
    simulate.camera.seed = noise_seed;  // independent camera noise in every view
    ReconstructOptions reconstruct;
    reconstruct.decode = recipe.decode;
    reconstruct.clean = true;
    return reconstruct_view(simulate_captures(scene, rig, simulate), rig, "seed rig", reconstruct).view;
}

// Views are simulated once and cached as view PLYs under `name`; view i gets noise seed first_seed + i.
TurntableScan make_scan(const std::string& name, const Mesh& part, const std::vector<cv::Matx44d>& part_to_camera,
                        const Calibration& rig = seed_rig_calibration(), uint64_t first_seed = 1) {
    TurntableScan scan;
    scan.part = part;
    scan.part_to_camera = part_to_camera;
    const std::filesystem::path cache = std::filesystem::path(PICOSCAN_TEST_CACHE_DIR) / name;
    std::filesystem::create_directories(cache);
    for (size_t i = 0; i < scan.part_to_camera.size(); ++i) {
        const std::string file = "view_" + std::to_string(i) + ".ply";
        const std::filesystem::path path = cache / file;
        if (!std::filesystem::exists(path)) {
            std::printf("scanning %s (cached in %s)\n", file.c_str(), cache.string().c_str());
            write_view_ply(scan_view(scan.part, scan.part_to_camera[i], first_seed + i, rig), path.string());
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
    TurntablePlan plan;
    plan.max_disturbance_deg = 10;
    plan.max_disturbance_mm = 20;
    static const TurntableScan scan = make_scan("turntable-v3-disturbed", mechanical_part(), turntable_part_poses(plan));
    return scan;
}

const TurntableScan& turntable_scan() {
    static const TurntableScan scan = make_scan("turntable-v3-exact", mechanical_part(), turntable_part_poses(TurntablePlan{}));
    return scan;
}

namespace {

constexpr double kPi = 3.14159265358979323846;

// A straight prism over a convex outline (counter-clockwise seen from +z), from z0 to z1,
// appended to `mesh`. Faces do not share vertices, so each stays flat and sharp.
void add_prism(Mesh& mesh, const std::vector<cv::Vec2d>& outline, double z0, double z1) {
    auto triangle = [&](const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c) {
        const int first = static_cast<int>(mesh.vertices.size());
        mesh.vertices.emplace_back(a);
        mesh.vertices.emplace_back(b);
        mesh.vertices.emplace_back(c);
        mesh.faces.emplace_back(first, first + 1, first + 2);
    };
    cv::Vec2d centre(0, 0);
    for (const cv::Vec2d& p : outline) centre += p;
    centre *= 1.0 / static_cast<double>(outline.size());
    for (size_t k = 0; k < outline.size(); ++k) {
        const cv::Vec2d a = outline[k], b = outline[(k + 1) % outline.size()];
        triangle({a[0], a[1], z0}, {b[0], b[1], z0}, {b[0], b[1], z1});  // side, facing out
        triangle({a[0], a[1], z0}, {b[0], b[1], z1}, {a[0], a[1], z1});
        triangle({centre[0], centre[1], z1}, {a[0], a[1], z1}, {b[0], b[1], z1});  // top, facing +z
        triangle({centre[0], centre[1], z0}, {b[0], b[1], z0}, {a[0], a[1], z0});  // bottom, facing -z
    }
}

std::vector<cv::Vec2d> rectangle(double x0, double y0, double x1, double y1) { return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}; }

std::vector<cv::Vec2d> regular_polygon(const cv::Vec2d& centre, double radius_mm, int corners, double first_deg = 0) {
    std::vector<cv::Vec2d> outline;
    for (int k = 0; k < corners; ++k) {
        const double a = (first_deg + 360.0 * k / corners) * kPi / 180;
        outline.push_back(centre + radius_mm * cv::Vec2d(std::cos(a), std::sin(a)));
    }
    return outline;
}

Mesh plain_part_mesh(PlainPart part) {
    Mesh mesh;
    switch (part) {
    case PlainPart::GreyMechanical:
        mesh = mechanical_part();
        mesh.colours.clear();
        break;
    case PlainPart::SteppedBlock:  // an L profile: a 46 x 30 x 12 slab with a 20 mm step on one end
        add_prism(mesh, rectangle(-23, -15, 23, 15), 0, 12);
        add_prism(mesh, rectangle(3, -15, 23, 15), 12, 26);
        break;
    case PlainPart::FlattedShaft: {  // a 34 mm round with a flat 4 mm deep on one side: nearly symmetric
        const double radius = 17, flat_x = 13, start = std::acos(flat_x / radius);
        std::vector<cv::Vec2d> outline;
        const int segments = 110;
        for (int k = 0; k <= segments; ++k) {
            const double a = start + (2 * kPi - 2 * start) * k / segments;
            outline.push_back(radius * cv::Vec2d(std::cos(a), std::sin(a)));
        }
        add_prism(mesh, outline, 0, 30);
        break;
    }
    case PlainPart::HexWithPeg:  // a hexagonal prism (60 degree symmetry) with a small peg off centre
        add_prism(mesh, regular_polygon({0, 0}, 20, 6), 0, 18);
        add_prism(mesh, regular_polygon({8, 3}, 3.5, 32), 18, 24);
        break;
    case PlainPart::Block:  // a plain 40 x 28 x 18 block: symmetric by a half turn
        add_prism(mesh, rectangle(-20, -14, 20, 14), 0, 18);
        break;
    }
    return mesh;
}

}  // namespace

std::string plain_part_name(PlainPart part) {
    switch (part) {
    case PlainPart::GreyMechanical: return "grey-mechanical";
    case PlainPart::SteppedBlock: return "stepped-block";
    case PlainPart::FlattedShaft: return "flatted-shaft";
    case PlainPart::HexWithPeg: return "hex-with-peg";
    case PlainPart::Block: return "block";
    }
    return "unknown";
}

const TurntableScan& plain_turntable_scan(PlainPart part) {
    // Never destroyed: at exit, OpenCV's statics may go before this cache's cv::Mats, and
    // freeing them then crashed test_register under AddressSanitizer (SEGV in Mat::deallocate).
    static auto& scans = *new std::map<PlainPart, TurntableScan>;
    const auto found = scans.find(part);
    if (found != scans.end()) return found->second;
    TurntablePlan plan;
    plan.top_view = false;
    const Mesh mesh = plain_part_mesh(part);
    // The part's middle at the rig's working point.
    double top = 0;
    for (const cv::Vec3f& v : mesh.vertices) top = std::max(top, static_cast<double>(v[2]));
    plan.part_middle_height_mm = top / 2;
    return scans.emplace(part, make_scan("plain-v2-" + plain_part_name(part), mesh, turntable_part_poses(plan))).first->second;
}

Calibration half_resolution_seed_rig() {
    Calibration rig = seed_rig_calibration();
    rig.camera_size = cv::Size(rig.camera_size.width / 2, rig.camera_size.height / 2);
    rig.camera_matrix(0, 0) /= 2;
    rig.camera_matrix(1, 1) /= 2;
    rig.camera_matrix(0, 2) = (rig.camera_matrix(0, 2) + 0.5) / 2 - 0.5;  // pixel centres
    rig.camera_matrix(1, 2) = (rig.camera_matrix(1, 2) + 0.5) / 2 - 0.5;
    return rig;
}

std::string placement_part_name(PlacementPart part) {
    switch (part) {
    case PlacementPart::SpeckledMechanical: return "speckled-mechanical";
    case PlacementPart::GreyMechanical: return "grey-mechanical";
    case PlacementPart::SteppedBlock: return "stepped-block";
    case PlacementPart::HexWithPeg: return "hex-with-peg";
    case PlacementPart::Block: return "block";
    case PlacementPart::GreyMechanicalUpsideDown: return "grey-mechanical-upside-down";
    }
    return "unknown";
}

const TurntableScan& two_placement_scan(PlacementPart part) {
    // Never destroyed: at exit, OpenCV's statics may go before this cache's cv::Mats, and
    // freeing them then crashed test_register under AddressSanitizer (SEGV in Mat::deallocate).
    static auto& scans = *new std::map<PlacementPart, TurntableScan>;
    const auto found = scans.find(part);
    if (found != scans.end()) return found->second;
    Mesh mesh;
    std::string shape = placement_part_name(part);  // names the cache of the standing placement, shared
    PartPlacement flip = PartPlacement::OnItsSide;
    switch (part) {
    case PlacementPart::SpeckledMechanical: mesh = mechanical_part(); break;
    case PlacementPart::GreyMechanical: mesh = plain_part_mesh(PlainPart::GreyMechanical); break;
    case PlacementPart::SteppedBlock: mesh = plain_part_mesh(PlainPart::SteppedBlock); break;
    case PlacementPart::HexWithPeg: mesh = plain_part_mesh(PlainPart::HexWithPeg); break;
    case PlacementPart::Block: mesh = plain_part_mesh(PlainPart::Block); break;
    case PlacementPart::GreyMechanicalUpsideDown:
        mesh = plain_part_mesh(PlainPart::GreyMechanical);
        shape = "grey-mechanical";
        flip = PartPlacement::UpsideDown;
        break;
    }
    TurntablePlan plan;
    plan.top_view = false;
    plan.turntable_views = static_cast<int>(kViewsPerPlacement);
    double top = 0;
    for (const cv::Vec3f& v : mesh.vertices) top = std::max(top, static_cast<double>(v[2]));
    plan.part_middle_height_mm = top / 2;
    const Calibration rig = half_resolution_seed_rig();
    TurntableScan scan = make_scan("half-v1-" + shape + "-standing", mesh, turntable_part_poses(plan), rig, 1);
    plan.placement = flip;
    plan.placement_turn_deg = 20;
    const std::string flipped_name = flip == PartPlacement::OnItsSide ? "on-its-side" : "upside-down";
    const TurntableScan flipped = make_scan("half-v1-" + shape + "-" + flipped_name, mesh, turntable_part_poses(plan), rig, 101);
    for (std::string& name : scan.names) name = "standing-" + name;
    for (size_t i = 0; i < flipped.views.size(); ++i) {
        scan.views.push_back(flipped.views[i]);
        scan.names.push_back(flipped_name + "-" + flipped.names[i]);
        scan.part_to_camera.push_back(flipped.part_to_camera[i]);
        scan.true_view_to_model.push_back(scan.part_to_camera[0] * flipped.part_to_camera[i].inv());
    }
    return scans.emplace(part, std::move(scan)).first->second;
}

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

namespace {

long long cell_key(long long x, long long y, long long z) { return (x * 73856093LL) ^ (y * 19349663LL) ^ (z * 83492791LL); }

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
