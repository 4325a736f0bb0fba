#include "simulate/scene_tracer.h"

#include "picoscan/error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

namespace picoscan::detail {

namespace {

bool finite(const cv::Vec3d& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

void check_albedo(double albedo, const std::string& where) {
    if (!(albedo >= 0.0 && albedo <= 1.0)) throw Error("scene", where + ": albedo must be within 0..1");
}

// Candidate hit on a shape: keeps the smallest t inside the open interval (t_min, t_max).
struct Closest {
    Closest(double lo, double hi) : t_min(lo), t_max(hi) {}
    double t_min, t_max;
    double t = std::numeric_limits<double>::infinity();
    cv::Vec3d normal;
    bool found = false;
    void offer(double candidate, const cv::Vec3d& n) {
        if (candidate > t_min && candidate < t_max && candidate < t) {
            t = candidate;
            normal = n;
            found = true;
        }
    }
};

void intersect(const Sphere& s, const cv::Vec3d& o, const cv::Vec3d& d, Closest& c) {
    const cv::Vec3d oc = o - s.centre;
    const double b = oc.dot(d);
    // r^2 - (perpendicular distance)^2 loses far less precision than b^2 - (|oc|^2 - r^2).
    const cv::Vec3d perpendicular = oc - b * d;
    const double disc = s.radius_mm * s.radius_mm - perpendicular.dot(perpendicular);
    if (disc < 0.0) return;
    const double h = std::sqrt(disc);
    // Roots -b -/+ h; take the one without cancellation and get the other from the product.
    const double q = -(b + std::copysign(h, b));
    const double cc = oc.dot(oc) - s.radius_mm * s.radius_mm;
    const double t0 = q, t1 = (q != 0.0) ? cc / q : 0.0;
    for (double t : {std::min(t0, t1), std::max(t0, t1)}) {
        const cv::Vec3d n = (oc + t * d) * (1.0 / s.radius_mm);
        c.offer(t, n);
    }
}

void intersect(const Plane& p, const cv::Vec3d& o, const cv::Vec3d& d, Closest& c) {
    const double denom = d.dot(p.normal);
    if (denom == 0.0) return;
    c.offer((p.point - o).dot(p.normal) / denom, p.normal);
}

void intersect(const Box& box, const cv::Vec3d& o, const cv::Vec3d& d, Closest& c) {
    // Slab test in the box frame: world = centre + rotation * local.
    const cv::Vec3d lo = box.rotation.t() * (o - box.centre);
    const cv::Vec3d ld = box.rotation.t() * d;
    double t_enter = -std::numeric_limits<double>::infinity(), t_exit = std::numeric_limits<double>::infinity();
    int enter_axis = -1, exit_axis = -1;
    for (int k = 0; k < 3; ++k) {
        const double h = box.half_size_mm[k];
        if (ld[k] == 0.0) {
            if (lo[k] < -h || lo[k] > h) return;
            continue;
        }
        double a = (-h - lo[k]) / ld[k], b = (h - lo[k]) / ld[k];
        if (a > b) std::swap(a, b);
        if (a > t_enter) {
            t_enter = a;
            enter_axis = k;
        }
        if (b < t_exit) {
            t_exit = b;
            exit_axis = k;
        }
    }
    if (t_enter > t_exit) return;
    auto face_normal = [&](int axis, double sign) {
        cv::Vec3d local(0, 0, 0);
        local[axis] = sign;
        return box.rotation * local;
    };
    if (enter_axis >= 0) c.offer(t_enter, face_normal(enter_axis, ld[enter_axis] > 0 ? -1.0 : 1.0));
    if (exit_axis >= 0) c.offer(t_exit, face_normal(exit_axis, ld[exit_axis] > 0 ? 1.0 : -1.0));
}

void intersect(const Cylinder& cyl, const cv::Vec3d& o, const cv::Vec3d& d, Closest& c) {
    const cv::Vec3d& a = cyl.axis;
    const cv::Vec3d w = o - cyl.base_centre;
    const double w_a = w.dot(a), d_a = d.dot(a);
    const cv::Vec3d w_p = w - w_a * a, d_p = d - d_a * a;
    const double r2 = cyl.radius_mm * cyl.radius_mm;
    // Side: |w_p + t d_p| = r with the axial coordinate inside 0..height.
    const double A = d_p.dot(d_p);
    if (A > 0.0) {
        const double B = w_p.dot(d_p);
        const cv::Vec3d closest = w_p - (B / A) * d_p;  // perpendicular offset of the ray from the axis
        const double disc = A * (r2 - closest.dot(closest));
        if (disc >= 0.0) {
            const double h = std::sqrt(disc);
            const double q = -(B + std::copysign(h, B));
            const double C = w_p.dot(w_p) - r2;
            const double roots[2] = {q / A, q != 0.0 ? C / q : 0.0};
            for (double t : roots) {
                const double s = w_a + t * d_a;
                if (s >= 0.0 && s <= cyl.height_mm) c.offer(t, (w_p + t * d_p) * (1.0 / cyl.radius_mm));
            }
        }
    }
    // Caps.
    if (d_a != 0.0) {
        const double caps[2] = {0.0, cyl.height_mm};
        for (int i = 0; i < 2; ++i) {
            const double t = (caps[i] - w_a) / d_a;
            const cv::Vec3d radial = w_p + t * d_p;
            if (radial.dot(radial) <= r2) c.offer(t, i == 0 ? -a : a);
        }
    }
}


// The board's plane along a ray, in board coordinates: false when the ray runs parallel to it.
bool board_plane_hit(const CalibrationBoard& b, const cv::Vec3d& o, const cv::Vec3d& d, double& t, cv::Vec2d& xy) {
    const cv::Vec3d lo = b.rotation.t() * (o - b.translation);
    const cv::Vec3d ld = b.rotation.t() * d;
    if (ld[2] == 0.0) return false;
    t = -lo[2] / ld[2];
    xy = cv::Vec2d(lo[0] + t * ld[0], lo[1] + t * ld[1]);
    return true;
}

void intersect(const CalibrationBoard& b, const cv::Vec3d& o, const cv::Vec3d& d, Closest& c) {
    double t;
    cv::Vec2d xy;
    if (!board_plane_hit(b, o, d, t, xy)) return;
    const double lo = -b.square_mm - b.margin_mm;
    if (xy[0] < lo || xy[0] > b.inner_corners.width * b.square_mm + b.margin_mm || xy[1] < lo ||
        xy[1] > b.inner_corners.height * b.square_mm + b.margin_mm)
        return;
    // Two-sided: the normal faces the ray's origin.
    const cv::Vec3d z(b.rotation(0, 2), b.rotation(1, 2), b.rotation(2, 2));
    c.offer(t, z.dot(d) > 0 ? -z : z);
}

// The printed pattern as a grid of cells: along each board axis, cell k spans
// [k * square, (k + 1) * square) for the squares k = -1 .. inner - 1, and the margin beyond
// is one cell on each side (k = -2 and k = inner), unbounded since it is uniform.
int board_cell(double coordinate, double square, int inner) {
    const double k = std::floor(coordinate / square);
    return static_cast<int>(std::max(-2.0, std::min(static_cast<double>(inner), k)));
}

double cell_albedo(const CalibrationBoard& b, int kx, int ky) {
    const bool margin = kx < -1 || ky < -1 || kx >= b.inner_corners.width || ky >= b.inner_corners.height;
    if (margin) return b.light_albedo;
    return (kx + ky) % 2 == 0 ? b.dark_albedo : b.light_albedo;  // cell (-1, -1) is dark
}

double printed_albedo(const CalibrationBoard& b, const cv::Vec2d& xy) {
    return cell_albedo(b, board_cell(xy[0], b.square_mm, b.inner_corners.width),
                       board_cell(xy[1], b.square_mm, b.inner_corners.height));
}

// A convex polygon small enough to clip a quadrilateral by four half-planes.
struct Polygon {
    std::array<cv::Vec2d, 8> v;
    int n = 0;
};

// Keeps the part of `in` with sign * (v[axis] - value) <= 0.
Polygon clip(const Polygon& in, int axis, double value, double sign) {
    Polygon out;
    for (int i = 0; i < in.n; ++i) {
        const cv::Vec2d& a = in.v[i];
        const cv::Vec2d& b = in.v[(i + 1) % in.n];
        const double da = sign * (a[axis] - value), db = sign * (b[axis] - value);
        if (da <= 0) out.v[out.n++] = a;
        if ((da < 0 && db > 0) || (da > 0 && db < 0)) out.v[out.n++] = a + (b - a) * (da / (da - db));
    }
    return out;
}

double area(const Polygon& p) {
    double twice = 0;
    for (int i = 0; i < p.n; ++i) {
        const cv::Vec2d& a = p.v[i];
        const cv::Vec2d& b = p.v[(i + 1) % p.n];
        twice += a[0] * b[1] - a[1] * b[0];
    }
    return 0.5 * std::abs(twice);
}

}  // namespace

SceneTracer::SceneTracer(const Scene& scene) {
    for (size_t i = 0; i < scene.spheres.size(); ++i) {
        const Sphere& s = scene.spheres[i];
        const std::string where = "spheres[" + std::to_string(i) + "]";
        if (!finite(s.centre)) throw Error("scene", where + ": centre must be finite");
        if (!(s.radius_mm > 0.0 && std::isfinite(s.radius_mm))) throw Error("scene", where + ": radius_mm must be positive");
        check_albedo(s.albedo, where);
        spheres_.push_back(s);
    }
    for (size_t i = 0; i < scene.planes.size(); ++i) {
        Plane p = scene.planes[i];
        const std::string where = "planes[" + std::to_string(i) + "]";
        if (!finite(p.point)) throw Error("scene", where + ": point must be finite");
        const double n = cv::norm(p.normal);
        if (!(n > 0.0 && std::isfinite(n))) throw Error("scene", where + ": normal must be a non-zero vector");
        p.normal *= 1.0 / n;
        check_albedo(p.albedo, where);
        planes_.push_back(p);
    }
    for (size_t i = 0; i < scene.boxes.size(); ++i) {
        const Box& b = scene.boxes[i];
        const std::string where = "boxes[" + std::to_string(i) + "]";
        if (!finite(b.centre)) throw Error("scene", where + ": centre must be finite");
        if (!(b.half_size_mm[0] > 0 && b.half_size_mm[1] > 0 && b.half_size_mm[2] > 0 && finite(b.half_size_mm)))
            throw Error("scene", where + ": half_size_mm must be positive");
        const cv::Matx33d should_be_identity = b.rotation.t() * b.rotation;
        if (!(cv::norm(should_be_identity - cv::Matx33d::eye()) < 1e-9) || cv::determinant(b.rotation) < 0)
            throw Error("scene", where + ": rotation must be a proper rotation matrix");
        check_albedo(b.albedo, where);
        boxes_.push_back(b);
    }
    for (size_t i = 0; i < scene.cylinders.size(); ++i) {
        Cylinder c = scene.cylinders[i];
        const std::string where = "cylinders[" + std::to_string(i) + "]";
        if (!finite(c.base_centre)) throw Error("scene", where + ": base_centre must be finite");
        const double n = cv::norm(c.axis);
        if (!(n > 0.0 && std::isfinite(n))) throw Error("scene", where + ": axis must be a non-zero vector");
        c.axis *= 1.0 / n;
        if (!(c.radius_mm > 0.0 && std::isfinite(c.radius_mm))) throw Error("scene", where + ": radius_mm must be positive");
        if (!(c.height_mm > 0.0 && std::isfinite(c.height_mm))) throw Error("scene", where + ": height_mm must be positive");
        check_albedo(c.albedo, where);
        cylinders_.push_back(c);
    }
    for (size_t i = 0; i < scene.boards.size(); ++i) {
        const CalibrationBoard& b = scene.boards[i];
        const std::string where = "boards[" + std::to_string(i) + "]";
        const cv::Matx33d should_be_identity = b.rotation.t() * b.rotation;
        if (!(cv::norm(should_be_identity - cv::Matx33d::eye()) < 1e-9) || cv::determinant(b.rotation) < 0)
            throw Error("scene", where + ": rotation must be a proper rotation matrix");
        if (!finite(b.translation)) throw Error("scene", where + ": translation must be finite");
        if (b.inner_corners.width < 2 || b.inner_corners.height < 2)
            throw Error("scene", where + ": inner_corners must be at least 2x2, got " +
                                     std::to_string(b.inner_corners.width) + "x" + std::to_string(b.inner_corners.height));
        if (!(b.square_mm > 0.0 && std::isfinite(b.square_mm))) throw Error("scene", where + ": square_mm must be positive");
        // A board printed to its edge (no margin) is still a board.
        if (!(b.margin_mm >= 0.0 && std::isfinite(b.margin_mm)))
            throw Error("scene", where + ": margin_mm must be finite and non-negative");
        if (!(b.dark_albedo >= 0.0 && b.dark_albedo <= 1.0)) throw Error("scene", where + ": dark_albedo must be within 0..1");
        if (!(b.light_albedo >= 0.0 && b.light_albedo <= 1.0))
            throw Error("scene", where + ": light_albedo must be within 0..1");
        boards_.push_back(b);
    }
    std::vector<BvhTriangle> triangles;
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        const TriangleMesh& mesh = scene.meshes[m];
        const std::string where = "meshes[" + std::to_string(m) + "]";
        check_albedo(mesh.albedo, where);
        const int vertex_count = static_cast<int>(mesh.mesh.vertices.size());
        const bool painted = !mesh.mesh.colours.empty();
        if (painted && mesh.mesh.colours.size() != mesh.mesh.vertices.size())
            throw Error("scene", where + ": needs one colour per vertex or none");
        for (size_t f = 0; f < mesh.mesh.faces.size(); ++f) {
            const cv::Vec3i& face = mesh.mesh.faces[f];
            BvhTriangle tri;
            cv::Vec3d* corners[3] = {&tri.a, &tri.b, &tri.c};
            for (int k = 0; k < 3; ++k) {
                if (face[k] < 0 || face[k] >= vertex_count)
                    throw Error("scene", where + ": face " + std::to_string(f) + " refers to vertex " +
                                             std::to_string(face[k]) + " of " + std::to_string(vertex_count));
                const cv::Vec3f& v = mesh.mesh.vertices[face[k]];
                *corners[k] = cv::Vec3d(v[0], v[1], v[2]);
                // A painted mesh: the vertex colour's grey level scales the albedo.
                const cv::Vec3b colour = painted ? mesh.mesh.colours[face[k]] : cv::Vec3b(255, 255, 255);
                tri.albedo[k] = static_cast<float>(mesh.albedo * (colour[0] + colour[1] + colour[2]) / (3.0 * 255.0));
            }
            triangles.push_back(tri);
        }
    }
    bvh_ = TriangleBvh(triangles);
}

template <bool AnyHit>
bool SceneTracer::trace(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max,
                        SurfaceHit* hit) const {
    Closest closest(t_min, t_max);
    double albedo = 0.0;
    int board = -1;
    auto take = [&](double shape_albedo, int board_index = -1) {
        if (closest.found && closest.t < closest.t_max) {
            closest.t_max = closest.t;  // later shapes must be nearer still
            albedo = shape_albedo;
            board = board_index;
            return true;
        }
        return false;
    };
    for (const Sphere& s : spheres_) {
        intersect(s, origin, direction, closest);
        if (take(s.albedo) && AnyHit) return true;
    }
    for (const Plane& p : planes_) {
        intersect(p, origin, direction, closest);
        if (take(p.albedo) && AnyHit) return true;
    }
    for (const Box& b : boxes_) {
        intersect(b, origin, direction, closest);
        if (take(b.albedo) && AnyHit) return true;
    }
    for (const Cylinder& c : cylinders_) {
        intersect(c, origin, direction, closest);
        if (take(c.albedo) && AnyHit) return true;
    }
    for (size_t i = 0; i < boards_.size(); ++i) {
        intersect(boards_[i], origin, direction, closest);
        if (take(0.0, static_cast<int>(i)) && AnyHit) return true;  // albedo found below, for the nearest only
    }
    if (AnyHit) return bvh_.occluded(origin, direction, t_min, t_max);

    double t_mesh = closest.found ? closest.t : t_max;
    int triangle = -1;
    if (bvh_.nearest(origin, direction, t_min, t_mesh, triangle)) {
        hit->t = t_mesh;
        hit->normal = bvh_.normal(triangle);
        hit->albedo = bvh_.albedo_at(triangle, origin + t_mesh * direction);
        hit->board = -1;
        return true;
    }
    if (!closest.found) return false;
    hit->t = closest.t;
    hit->normal = closest.normal;
    hit->albedo = albedo;
    hit->board = board;
    if (board >= 0) {
        const CalibrationBoard& b = boards_[board];
        const cv::Vec3d local = b.rotation.t() * (origin + closest.t * direction - b.translation);
        hit->albedo = printed_albedo(b, cv::Vec2d(local[0], local[1]));
    }
    return true;
}

bool SceneTracer::nearest(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max,
                          SurfaceHit& hit) const {
    return trace<false>(origin, direction, t_min, t_max, &hit);
}

double SceneTracer::board_albedo(int board, const cv::Vec3d& origin, const cv::Vec3d& ray, const cv::Vec3d& ray_dx,
                                 const cv::Vec3d& ray_dy) const {
    const CalibrationBoard& b = boards_.at(board);
    double t;
    cv::Vec2d centre;
    if (!board_plane_hit(b, origin, ray, t, centre)) return b.light_albedo;
    const double point_albedo = printed_albedo(b, centre);

    // The pixel's corners on the board, in order around it. A pinhole maps the pixel square
    // onto the plane as a quadrilateral, so its straight sides are exact.
    Polygon footprint;
    const double corner_a[4] = {-0.5, 0.5, 0.5, -0.5}, corner_b[4] = {-0.5, -0.5, 0.5, 0.5};
    for (int k = 0; k < 4; ++k) {
        cv::Vec2d xy;
        if (!board_plane_hit(b, origin, ray + corner_a[k] * ray_dx + corner_b[k] * ray_dy, t, xy) || !(t > 0))
            return point_albedo;
        footprint.v[footprint.n++] = xy;
    }
    const double total = area(footprint);
    if (!(total > 0) || !std::isfinite(total)) return point_albedo;

    const int w = b.inner_corners.width, h = b.inner_corners.height;
    const double s = b.square_mm;
    double x_min = footprint.v[0][0], x_max = x_min, y_min = footprint.v[0][1], y_max = y_min;
    for (int k = 1; k < 4; ++k) {
        x_min = std::min(x_min, footprint.v[k][0]);
        x_max = std::max(x_max, footprint.v[k][0]);
        y_min = std::min(y_min, footprint.v[k][1]);
        y_max = std::max(y_max, footprint.v[k][1]);
    }
    const int kx0 = board_cell(x_min, s, w), kx1 = board_cell(x_max, s, w);
    const int ky0 = board_cell(y_min, s, h), ky1 = board_cell(y_max, s, h);
    if (kx0 == kx1 && ky0 == ky1) return cell_albedo(b, kx0, ky0);  // most pixels: inside one square

    // Exact area of each cell under the footprint (clipping only at the cell's finite sides):
    // a box-filtered pixel, so edges and corners land where they are, to sub-pixel precision.
    double sum = 0;
    for (int kx = kx0; kx <= kx1; ++kx) {
        Polygon column = footprint;
        if (kx > -2) column = clip(column, 0, kx * s, -1.0);
        if (kx < w) column = clip(column, 0, (kx + 1) * s, 1.0);
        if (column.n < 3) continue;
        for (int ky = ky0; ky <= ky1; ++ky) {
            Polygon cell = column;
            if (ky > -2) cell = clip(cell, 1, ky * s, -1.0);
            if (ky < h) cell = clip(cell, 1, (ky + 1) * s, 1.0);
            if (cell.n >= 3) sum += area(cell) * cell_albedo(b, kx, ky);
        }
    }
    return sum / total;
}

bool SceneTracer::occluded(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max) const {
    return trace<true>(origin, direction, t_min, t_max, nullptr);
}

}  // namespace picoscan::detail

namespace picoscan {

std::vector<cv::Point3f> chessboard_corners(const CalibrationBoard& board) {
    std::vector<cv::Point3f> corners;
    corners.reserve(static_cast<size_t>(std::max(0, board.inner_corners.area())));
    for (int row = 0; row < board.inner_corners.height; ++row)
        for (int col = 0; col < board.inner_corners.width; ++col)
            corners.emplace_back(static_cast<float>(col * board.square_mm), static_cast<float>(row * board.square_mm), 0.0f);
    return corners;
}

}  // namespace picoscan
