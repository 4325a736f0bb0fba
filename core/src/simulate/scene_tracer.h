// Ray queries against a whole simulator scene: analytic shapes tested directly, triangle
// meshes through one BVH over all their triangles.
#pragma once

#include "picoscan/simulate.h"
#include "simulate/bvh.h"

#include <opencv2/core.hpp>
#include <vector>

namespace picoscan::detail {

struct SurfaceHit {
    double t = 0;        // distance along the (unit) ray, mm
    cv::Vec3d normal;    // unit, outward for solids, the given normal for planes
    double albedo = 0;
    int board = -1;      // index of the calibration board hit, -1 for any other surface
};

class SceneTracer {
public:
    // Validates the scene (throws Error("scene", ...) naming the bad shape and key).
    explicit SceneTracer(const Scene& scene);

    // Nearest surface with t in (t_min, t_max) along a unit direction.
    bool nearest(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max,
                 SurfaceHit& hit) const;
    // Whether any surface lies on the ray with t in (t_min, t_max).
    bool occluded(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max) const;

    // Area-average of a board's printed albedo over one pixel's footprint: the quadrilateral
    // where the rays origin + s * (ray + a * ray_dx + b * ray_dy), a, b = -1/2 or 1/2, meet
    // the board's plane (directions need not be unit). Falls back to the albedo under `ray`
    // where the footprint is degenerate (grazing or behind the origin).
    double board_albedo(int board, const cv::Vec3d& origin, const cv::Vec3d& ray, const cv::Vec3d& ray_dx,
                        const cv::Vec3d& ray_dy) const;

    size_t triangle_count() const { return bvh_.triangle_count(); }

private:
    template <bool AnyHit>
    bool trace(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max,
               SurfaceHit* hit) const;

    std::vector<Sphere> spheres_;
    std::vector<Plane> planes_;      // unit normals
    std::vector<Box> boxes_;
    std::vector<Cylinder> cylinders_;  // unit axes
    std::vector<CalibrationBoard> boards_;
    TriangleBvh bvh_;
};

}  // namespace picoscan::detail
