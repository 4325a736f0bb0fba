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

    size_t triangle_count() const { return bvh_.triangle_count(); }

private:
    template <bool AnyHit>
    bool trace(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max,
               SurfaceHit* hit) const;

    std::vector<Sphere> spheres_;
    std::vector<Plane> planes_;      // unit normals
    std::vector<Box> boxes_;
    std::vector<Cylinder> cylinders_;  // unit axes
    TriangleBvh bvh_;
};

}  // namespace picoscan::detail
