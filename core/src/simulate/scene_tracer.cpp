#include "simulate/scene_tracer.h"

#include "picoscan/error.h"

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
    std::vector<BvhTriangle> triangles;
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        const TriangleMesh& mesh = scene.meshes[m];
        const std::string where = "meshes[" + std::to_string(m) + "]";
        check_albedo(mesh.albedo, where);
        const int vertex_count = static_cast<int>(mesh.mesh.vertices.size());
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
            }
            tri.albedo = static_cast<float>(mesh.albedo);
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
    auto take = [&](double shape_albedo) {
        if (closest.found && closest.t < closest.t_max) {
            closest.t_max = closest.t;  // later shapes must be nearer still
            albedo = shape_albedo;
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
    if (AnyHit) return bvh_.occluded(origin, direction, t_min, t_max);

    double t_mesh = closest.found ? closest.t : t_max;
    int triangle = -1;
    if (bvh_.nearest(origin, direction, t_min, t_mesh, triangle)) {
        hit->t = t_mesh;
        hit->normal = bvh_.normal(triangle);
        hit->albedo = bvh_.albedo(triangle);
        return true;
    }
    if (!closest.found) return false;
    hit->t = closest.t;
    hit->normal = closest.normal;
    hit->albedo = albedo;
    return true;
}

bool SceneTracer::nearest(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max,
                          SurfaceHit& hit) const {
    return trace<false>(origin, direction, t_min, t_max, &hit);
}

bool SceneTracer::occluded(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max) const {
    return trace<true>(origin, direction, t_min, t_max, nullptr);
}

}  // namespace picoscan::detail
