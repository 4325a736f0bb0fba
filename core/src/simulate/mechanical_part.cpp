// The built-in mechanical part for multi-view scans: a block with a chamfered edge, a
// vertical through hole and a boss, finely tessellated and speckle-painted so its white
// frames carry features to register on (as real parts are sprayed before scanning).
#include "picoscan/simulate.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <vector>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxEdgeMm = 0.6;  // fine enough for the paint to show at camera resolution

class MeshBuilder {
public:
    explicit MeshBuilder(Mesh& mesh) : mesh_(mesh) {}

    // A planar (or nearly) quad a-b-c-d, counter-clockwise seen from outside, split into a
    // grid of cells no longer than kMaxEdgeMm.
    void quad(const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c, const cv::Vec3d& d) {
        const int nu = cells(std::max(cv::norm(b - a), cv::norm(c - d)));
        const int nv = cells(std::max(cv::norm(d - a), cv::norm(c - b)));
        const int first = static_cast<int>(mesh_.vertices.size());
        for (int j = 0; j <= nv; ++j)
            for (int i = 0; i <= nu; ++i) {
                const double u = static_cast<double>(i) / nu, v = static_cast<double>(j) / nv;
                const cv::Vec3d p = (1 - v) * ((1 - u) * a + u * b) + v * ((1 - u) * d + u * c);
                mesh_.vertices.emplace_back(p);
            }
        for (int j = 0; j < nv; ++j)
            for (int i = 0; i < nu; ++i) {
                const int v00 = first + j * (nu + 1) + i, v10 = v00 + 1, v01 = v00 + nu + 1, v11 = v01 + 1;
                mesh_.faces.emplace_back(v00, v10, v11);
                mesh_.faces.emplace_back(v00, v11, v01);
            }
    }

private:
    static int cells(double length) { return std::max(1, static_cast<int>(std::ceil(length / kMaxEdgeMm))); }
    Mesh& mesh_;
};

// Where the ray from `centre` at `angle` leaves the convex polygon (counter-clockwise).
cv::Vec2d ray_exit(const std::vector<cv::Vec2d>& polygon, const cv::Vec2d& centre, double angle) {
    const cv::Vec2d direction(std::cos(angle), std::sin(angle));
    double nearest = 1e30;
    for (size_t k = 0; k < polygon.size(); ++k) {
        const cv::Vec2d a = polygon[k], b = polygon[(k + 1) % polygon.size()];
        const cv::Vec2d edge = b - a, to_a = a - centre;
        const double denominator = direction[0] * edge[1] - direction[1] * edge[0];
        if (std::abs(denominator) < 1e-12) continue;
        const double t = (to_a[0] * edge[1] - to_a[1] * edge[0]) / denominator;
        const double s = (to_a[0] * direction[1] - to_a[1] * direction[0]) / denominator;
        if (t > 0 && s >= -1e-9 && s <= 1 + 1e-9) nearest = std::min(nearest, t);
    }
    return centre + nearest * direction;
}

// Dark speckles of random size and darkness at random places on the surface.
void paint_speckles(Mesh& mesh, uint64_t seed) {
    cv::RNG rng(seed);
    std::vector<double> cumulative_area;
    double area = 0;
    for (const cv::Vec3i& f : mesh.faces) {
        const cv::Vec3d a(mesh.vertices[f[0]]), b(mesh.vertices[f[1]]), c(mesh.vertices[f[2]]);
        area += 0.5 * cv::norm((b - a).cross(c - a));
        cumulative_area.push_back(area);
    }
    struct Speckle { cv::Vec3d centre; double radius_mm, darkness; };
    const int count = static_cast<int>(area / 4.0);  // one per 4 mm^2: they overlap into irregular shapes
    const double cell = 4.0;
    std::unordered_map<long long, std::vector<Speckle>> grid;
    auto key = [&](long long x, long long y, long long z) { return (x * 73856093LL) ^ (y * 19349663LL) ^ (z * 83492791LL); };
    for (int s = 0; s < count; ++s) {
        const double pick = rng.uniform(0.0, area);
        const size_t face = static_cast<size_t>(std::lower_bound(cumulative_area.begin(), cumulative_area.end(), pick) -
                                                cumulative_area.begin());
        const cv::Vec3i& f = mesh.faces[std::min(face, mesh.faces.size() - 1)];
        double u = rng.uniform(0.0, 1.0), v = rng.uniform(0.0, 1.0);
        if (u + v > 1) { u = 1 - u; v = 1 - v; }
        const cv::Vec3d centre = (1 - u - v) * cv::Vec3d(mesh.vertices[f[0]]) + u * cv::Vec3d(mesh.vertices[f[1]]) +
                                 v * cv::Vec3d(mesh.vertices[f[2]]);
        const Speckle speckle{centre, rng.uniform(0.3, 1.3), rng.uniform(0.35, 0.75)};
        grid[key(static_cast<long long>(std::floor(centre[0] / cell)), static_cast<long long>(std::floor(centre[1] / cell)),
                 static_cast<long long>(std::floor(centre[2] / cell)))]
            .push_back(speckle);
    }
    mesh.colours.resize(mesh.vertices.size());
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        const cv::Vec3d p(mesh.vertices[i]);
        const long long cx = static_cast<long long>(std::floor(p[0] / cell)), cy = static_cast<long long>(std::floor(p[1] / cell)),
                        cz = static_cast<long long>(std::floor(p[2] / cell));
        double dark = 0;
        for (long long dx = -1; dx <= 1; ++dx)
            for (long long dy = -1; dy <= 1; ++dy)
                for (long long dz = -1; dz <= 1; ++dz) {
                    const auto found = grid.find(key(cx + dx, cy + dy, cz + dz));
                    if (found == grid.end()) continue;
                    for (const Speckle& s : found->second) {
                        // A disc with a soft 0.25 mm edge, like a droplet of paint.
                        const double edge = (s.radius_mm - cv::norm(p - s.centre)) / 0.25;
                        dark = std::max(dark, s.darkness * std::clamp(edge, 0.0, 1.0));
                    }
                }
        const uchar level = cv::saturate_cast<uchar>(255.0 * (1.0 - dark));
        mesh.colours[i] = cv::Vec3b(level, level, level);
    }
}

}  // namespace

Mesh mechanical_part(const MechanicalPartShape& shape) {
    Mesh mesh;
    MeshBuilder build(mesh);
    const double hx = shape.length_mm / 2, hy = shape.width_mm / 2, h = shape.height_mm, c = shape.chamfer_mm;
    const std::vector<cv::Vec2d> outline = {{-hx, -hy}, {hx, -hy}, {hx, hy - c}, {hx - c, hy}, {-hx, hy}};
    const cv::Vec2d hole = shape.hole_centre_mm;
    const double r = shape.hole_diameter_mm / 2;

    // Angles around the hole centre: uniform, plus every outline corner so the walls stay flat.
    std::vector<double> angles;
    const int segments = 360;
    for (int k = 0; k < segments; ++k) angles.push_back(2 * kPi * k / segments);
    for (const cv::Vec2d& corner : outline) {
        double angle = std::atan2(corner[1] - hole[1], corner[0] - hole[0]);
        if (angle < 0) angle += 2 * kPi;
        angles.push_back(angle);
    }
    std::sort(angles.begin(), angles.end());
    angles.erase(std::unique(angles.begin(), angles.end(), [](double a, double b) { return b - a < 1e-6; }), angles.end());

    auto at = [](const cv::Vec2d& xy, double z) { return cv::Vec3d(xy[0], xy[1], z); };
    for (size_t k = 0; k < angles.size(); ++k) {
        const double a0 = angles[k], a1 = angles[(k + 1) % angles.size()];
        const cv::Vec2d i0 = hole + r * cv::Vec2d(std::cos(a0), std::sin(a0));
        const cv::Vec2d i1 = hole + r * cv::Vec2d(std::cos(a1), std::sin(a1));
        const cv::Vec2d o0 = ray_exit(outline, hole, a0), o1 = ray_exit(outline, hole, a1);
        build.quad(at(i0, h), at(o0, h), at(o1, h), at(i1, h));   // top, facing +z
        build.quad(at(i1, 0), at(o1, 0), at(o0, 0), at(i0, 0));   // bottom, facing -z
        build.quad(at(o0, 0), at(o1, 0), at(o1, h), at(o0, h));   // outer wall
        build.quad(at(i1, 0), at(i0, 0), at(i0, h), at(i1, h));   // hole wall, facing the axis
    }
    // The boss: a capped cylinder standing on the top face (its foot sunk 1 mm into the block).
    const cv::Vec2d boss = shape.boss_centre_mm;
    const double rb = shape.boss_diameter_mm / 2, z0 = h - 1, z1 = h + shape.boss_height_mm;
    const int boss_segments = 180;
    for (int k = 0; k < boss_segments; ++k) {
        const double a0 = 2 * kPi * k / boss_segments, a1 = 2 * kPi * (k + 1) / boss_segments;
        const cv::Vec2d b0 = boss + rb * cv::Vec2d(std::cos(a0), std::sin(a0));
        const cv::Vec2d b1 = boss + rb * cv::Vec2d(std::cos(a1), std::sin(a1));
        build.quad(at(b0, z0), at(b1, z0), at(b1, z1), at(b0, z1));
        build.quad(at(boss, z1), at(b0, z1), at(b1, z1), at(boss, z1));  // top cap: a quad folded into a fan slice
        build.quad(at(boss, z0), at(b1, z0), at(b0, z0), at(boss, z0));
    }
    paint_speckles(mesh, shape.paint_seed);
    return mesh;
}

std::vector<cv::Matx44d> turntable_part_poses(const TurntablePlan& plan) {
    cv::RNG rng(plan.seed);
    auto rotation_about = [](const cv::Vec3d& axis, double angle_rad) {
        cv::Matx33d r;
        cv::Rodrigues(cv::normalize(axis) * angle_rad, r);
        return r;
    };
    // The placement turns the part about its middle, which stays at part_centre_mm.
    const double flip_deg = plan.placement == PartPlacement::UpsideDown ? 180 : plan.placement == PartPlacement::OnItsSide ? 90 : 0;
    const cv::Matx33d placed = rotation_about({1, 0, 0}, flip_deg * kPi / 180);
    auto pose_at = [&](double elevation_deg, double turn_deg) {
        const double e = elevation_deg * kPi / 180;
        // Part axes in the camera frame: x stays, z (up) leans towards the camera.
        const cv::Vec3d x(1, 0, 0), z(0, -std::cos(e), -std::sin(e)), y = z.cross(x);
        const cv::Matx33d tilt(x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]);
        cv::Matx33d rotation = tilt * rotation_about({0, 0, 1}, (turn_deg + plan.placement_turn_deg) * kPi / 180) * placed;
        cv::Vec3d translation = plan.part_centre_mm - rotation * cv::Vec3d(0, 0, plan.part_middle_height_mm);
        if (plan.max_disturbance_deg > 0 || plan.max_disturbance_mm > 0) {
            const cv::Vec3d axis(rng.gaussian(1), rng.gaussian(1), rng.gaussian(1));
            const cv::Matx33d knock = rotation_about(axis, rng.uniform(0.0, plan.max_disturbance_deg) * kPi / 180);
            const cv::Vec3d direction = cv::normalize(cv::Vec3d(rng.gaussian(1), rng.gaussian(1), rng.gaussian(1)));
            const cv::Vec3d shift = direction * rng.uniform(0.0, plan.max_disturbance_mm);
            // Turned about the part's middle, then shifted.
            rotation = knock * rotation;
            translation = plan.part_centre_mm - rotation * cv::Vec3d(0, 0, plan.part_middle_height_mm) + shift;
        }
        cv::Matx44d pose = cv::Matx44d::eye();
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) pose(r, c) = rotation(r, c);
            pose(r, 3) = translation[r];
        }
        return pose;
    };
    std::vector<cv::Matx44d> poses;
    for (int k = 0; k < plan.turntable_views; ++k) poses.push_back(pose_at(plan.elevation_deg, 360.0 * k / plan.turntable_views));
    if (plan.top_view) poses.push_back(pose_at(plan.top_elevation_deg, 360.0 / plan.turntable_views / 2));
    return poses;
}

}  // namespace picoscan
