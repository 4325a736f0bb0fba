// The seed-like virtual rig and the built-in demo part.
#include "picoscan/simulate.h"

#include "simulate/lens_model.h"

#include <cmath>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;
double radians(double degrees) { return degrees * kPi / 180.0; }

cv::Matx33d rotation_x(double a) {
    const double c = std::cos(a), s = std::sin(a);
    return {1, 0, 0, 0, c, -s, 0, s, c};
}
cv::Matx33d rotation_y(double a) {
    const double c = std::cos(a), s = std::sin(a);
    return {c, 0, s, 0, 1, 0, -s, 0, c};
}

// Sets R, T so that the projector, at `centre` (camera frame, y = 0), sends the ray of
// `pixel` through `working_point` (y = 0): a yaw, then a pitch, no roll.
void aim_projector(Calibration& c, const cv::Vec3d& centre, const cv::Vec3d& working_point, const cv::Vec2d& pixel) {
    const detail::LensModel projector(c.projector_matrix, c.projector_distortion, c.projector_size, "projector");
    cv::Vec3d p;  // the ray to the working point in the projector frame
    projector.pixel_ray(pixel, p);
    const cv::Vec3d w = cv::normalize(working_point - centre);  // the same ray in the camera frame (w[1] = 0)
    // R = Rx(pitch) * Ry(yaw): Ry must bring w's x component to p's, Rx then tilts y/z into place.
    const double yaw = std::asin(p[0]) - std::atan2(w[0], w[2]);
    const double pitch = std::atan2(-p[1], p[2]);
    c.R = rotation_x(pitch) * rotation_y(yaw);
    c.T = -(c.R * centre);
}

}  // namespace

Calibration seed_rig_calibration() {
    Calibration c;
    // Camera: 1600x1200, ~35 degrees across, a ~256 mm wide field at 400 mm.
    c.camera_size = cv::Size(1600, 1200);
    c.camera_matrix = cv::Matx33d(2500, 0, 803.2, 0, 2500, 597.6, 0, 0, 1);
    c.camera_distortion = (cv::Mat_<double>(1, 5) << -0.08, 0.12, 0.0005, -0.0003, 0.0);

    // Projector: 854x480 DLP with the usual offset optics (principal point near the bottom
    // edge, so the image is thrown above the optical axis) and non-square effective pixels,
    // as DLP diamond-pixel arrays have. fy is short enough for the 16:9 image to hold the
    // camera's whole 4:3 field from 340 to 460 mm; fx, along the baseline where depth is
    // measured, is longer for precision (depth noise ~ 1/fx) while the field, shifted
    // sideways with depth by the baseline, still fits across.
    c.projector_size = cv::Size(854, 480);
    c.projector_matrix = cv::Matx33d(1100, 0, 427.0, 0, 890, 400.0, 0, 0, 1);
    c.projector_distortion = (cv::Mat_<double>(1, 5) << 0.03, -0.02, 0.0, 0.0, 0.0);

    // Projector 150 mm to the right of the camera, turned (yaw, then pitch, no roll) so the
    // working point (0, 0, 400) lands at the projector pixel that centres the camera's field
    // over 340..460 mm in the projector image (margins of ~4 px above and below, ~33 px
    // left and right at the extremes of that range).
    aim_projector(c, cv::Vec3d(150, 0, 0), cv::Vec3d(0, 0, 400), cv::Vec2d(391.56, 250.19));
    return c;
}

SeedStereoRig seed_stereo_rig(double baseline_mm) {
    const cv::Vec3d working_point(0, 0, 400);
    SeedStereoRig rig;
    rig.left = seed_rig_calibration();
    // The projector midway, its image centred on the working point.
    aim_projector(rig.left, cv::Vec3d(baseline_mm / 2, 0, 0), working_point,
                  cv::Vec2d(rig.left.projector_size.width / 2.0, rig.left.projector_size.height / 2.0));
    // The second camera at (baseline, 0, 0), turned about y to look at the working point.
    const cv::Vec3d centre(baseline_mm, 0, 0);
    const cv::Vec3d z = cv::normalize(working_point - centre), y(0, 1, 0);
    const cv::Vec3d x = y.cross(z);
    const cv::Matx33d rotation(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);  // X_2 = rotation (X_1 - centre)
    rig.right = rig.left;
    rig.right.R = rig.left.R * rotation.t();
    rig.right.T = rig.left.T + rig.left.R * centre;
    rig.stereo = stereo_from_projector_calibrations(rig.left, rig.right);
    return rig;
}

Scene transformed(const Scene& scene, const cv::Matx44d& transform) {
    const cv::Matx33d rotation = transform.get_minor<3, 3>(0, 0);
    const cv::Vec3d translation(transform(0, 3), transform(1, 3), transform(2, 3));
    auto point = [&](const cv::Vec3d& p) { return rotation * p + translation; };
    Scene moved = scene;
    for (Sphere& sphere : moved.spheres) sphere.centre = point(sphere.centre);
    for (Plane& plane : moved.planes) {
        plane.point = point(plane.point);
        plane.normal = rotation * plane.normal;
    }
    for (Box& box : moved.boxes) {
        box.centre = point(box.centre);
        box.rotation = rotation * box.rotation;
    }
    for (Cylinder& cylinder : moved.cylinders) {
        cylinder.base_centre = point(cylinder.base_centre);
        cylinder.axis = rotation * cylinder.axis;
    }
    for (TriangleMesh& mesh : moved.meshes) mesh.mesh = transformed(mesh.mesh, transform);
    for (CalibrationBoard& board : moved.boards) {
        board.rotation = rotation * board.rotation;
        board.translation = point(board.translation);
    }
    return moved;
}

std::pair<CaptureSet, CaptureSet> simulate_stereo_capture(const PatternSequence& sequence, const SeedStereoRig& rig,
                                                          const Scene& scene, const SimulationOptions& options,
                                                          const ProgressCallback& progress) {
    cv::Matx44d left_to_right = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int col = 0; col < 3; ++col) left_to_right(r, col) = rig.stereo.R(r, col);
        left_to_right(r, 3) = rig.stereo.T[r];
    }
    SimulationOptions right_options = options;
    right_options.seed = options.seed + 1;
    return {simulate_capture(sequence, rig.left, scene, options, progress),
            simulate_capture(sequence, rig.right, transformed(scene, left_to_right), right_options, progress)};
}

namespace {

// A rectangular block (half sizes hx, hy, hz about the origin) with a round through-hole
// along z at (hole_x, 0). Outward-facing counter-clockwise triangles, local coordinates.
Mesh block_with_hole(double hx, double hy, double hz, double hole_x, double hole_radius, int segments) {
    Mesh mesh;
    auto vertex = [&](double x, double y, double z) {
        mesh.vertices.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
        return static_cast<int>(mesh.vertices.size()) - 1;
    };
    // Orders a triangle so its right-hand normal points along `outward`.
    auto triangle = [&](int a, int b, int c, const cv::Vec3d& outward) {
        const cv::Vec3d pa(mesh.vertices[a]), pb(mesh.vertices[b]), pc(mesh.vertices[c]);
        if ((pb - pa).cross(pc - pa).dot(outward) < 0) std::swap(b, c);
        mesh.faces.emplace_back(a, b, c);
    };
    auto quad = [&](int a, int b, int c, int d, const cv::Vec3d& outward) {
        triangle(a, b, c, outward);
        triangle(a, c, d, outward);
    };

    // Top (z = -hz) and bottom (z = +hz) faces: a square of side 2*hy around the hole,
    // triangulated as a ring from the hole's rim out to the square (star-shaped from the
    // hole centre, so every ray from it meets the square once), plus a rectangle either side.
    const double square_lo = hole_x - hy, square_hi = hole_x + hy;
    std::vector<int> rim[2];
    for (int side = 0; side < 2; ++side) {
        const double z = side == 0 ? -hz : hz;
        const cv::Vec3d outward(0, 0, side == 0 ? -1 : 1);
        std::vector<int> square;
        for (int k = 0; k < segments; ++k) {
            const double angle = 2.0 * kPi * k / segments;
            const double c = std::cos(angle), s = std::sin(angle);
            rim[side].push_back(vertex(hole_x + hole_radius * c, hole_radius * s, z));
            const double reach = hy / std::max(std::abs(c), std::abs(s));
            square.push_back(vertex(hole_x + reach * c, reach * s, z));
        }
        for (int k = 0; k < segments; ++k) {
            const int next = (k + 1) % segments;
            quad(rim[side][k], rim[side][next], square[next], square[k], outward);
        }
        quad(vertex(-hx, -hy, z), vertex(square_lo, -hy, z), vertex(square_lo, hy, z), vertex(-hx, hy, z), outward);
        quad(vertex(square_hi, -hy, z), vertex(hx, -hy, z), vertex(hx, hy, z), vertex(square_hi, hy, z), outward);
    }
    // Hole wall: the solid's outward normal points into the hole, towards its axis.
    for (int k = 0; k < segments; ++k) {
        const int next = (k + 1) % segments;
        const double angle = 2.0 * kPi * (k + 0.5) / segments;
        quad(rim[0][k], rim[0][next], rim[1][next], rim[1][k], cv::Vec3d(-std::cos(angle), -std::sin(angle), 0));
    }
    // Four sides.
    for (int sign = -1; sign <= 1; sign += 2) {
        const double x = sign * hx, y = sign * hy;
        quad(vertex(x, -hy, -hz), vertex(x, hy, -hz), vertex(x, hy, hz), vertex(x, -hy, hz), cv::Vec3d(sign, 0, 0));
        quad(vertex(-hx, y, -hz), vertex(hx, y, -hz), vertex(hx, y, hz), vertex(-hx, y, hz), cv::Vec3d(0, sign, 0));
    }
    return mesh;
}

}  // namespace

Scene demo_scene() {
    Scene scene;
    Plane background;
    background.point = cv::Vec3d(0, 0, 460);
    background.normal = cv::Vec3d(0, 0, -1);
    background.albedo = 0.5;
    scene.planes.push_back(background);

    // The bracket: an 80 x 50 x 25 mm block with a 14 mm through-hole, turned so its
    // top, right side and upper side all face camera and projector.
    const cv::Vec3d block_centre(-15, 5, 410);
    const cv::Matx33d block_rotation = rotation_y(radians(25)) * rotation_x(radians(35));
    const double hx = 40, hy = 25, hz = 12.5;
    Mesh block = block_with_hole(hx, hy, hz, 14.0, 7.0, 64);
    for (cv::Vec3f& v : block.vertices) v = cv::Vec3f(block_rotation * cv::Vec3d(v) + block_centre);
    scene.meshes.push_back(TriangleMesh{block, 0.75});

    // A boss standing on the block's camera-facing face (local -z).
    Cylinder boss;
    boss.base_centre = block_rotation * cv::Vec3d(-20, 0, -hz) + block_centre;
    boss.axis = block_rotation * cv::Vec3d(0, 0, -1);
    boss.radius_mm = 9;
    boss.height_mm = 12;
    boss.albedo = 0.8;
    scene.cylinders.push_back(boss);

    Sphere ball;
    ball.centre = cv::Vec3d(65, -40, 420);
    ball.radius_mm = 15;
    ball.albedo = 0.85;
    scene.spheres.push_back(ball);
    return scene;
}

}  // namespace picoscan
