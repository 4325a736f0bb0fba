// Bounding volume hierarchy over triangles for the simulator's ray casting: a binned-SAH
// binary tree collapsed into a four-wide one. Boxes are stored in float (half the memory, so more of the tree stays in cache) and
// padded so float rounding can never cull a real hit; the triangle test itself runs in
// double so hit points are exact to well below a micrometre.
#pragma once

#include <opencv2/core.hpp>
#include <cstdint>
#include <vector>

namespace picoscan::detail {

struct BvhTriangle {
    cv::Vec3d a, b, c;
    cv::Vec3f albedo{0.8f, 0.8f, 0.8f};  // at a, b, c; interpolated across the face
};

class TriangleBvh {
public:
    // Binned surface-area-heuristic build. Degenerate (zero-area) triangles are dropped.
    explicit TriangleBvh(const std::vector<BvhTriangle>& triangles = {});

    bool empty() const { return triangles_.empty(); }
    size_t triangle_count() const { return triangles_.size(); }
    size_t node_count() const { return nodes_.size(); }

    // Nearest hit with t in (t_min, t_max); `direction` need not be unit (t is in its units).
    // On a hit, t_max becomes the hit distance and `triangle` its index.
    bool nearest(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double& t_max,
                 int& triangle) const;
    // Whether anything lies on the ray with t in (t_min, t_max).
    bool occluded(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max) const;

    // Unit geometric normal (right-hand rule over a, b, c) of a triangle, and its albedo at a
    // point on it.
    cv::Vec3d normal(int triangle) const;
    double albedo_at(int triangle, const cv::Vec3d& point) const;

private:
    // Four-wide node: the boxes of up to four children side by side (one SIMD test for all
    // four). Rows 0-2 hold the low x, y, z of the children, rows 3-5 the high x, y, z.
    struct alignas(64) Node {
        float bounds[6][4];
        int32_t child[4];  // inner child: node index; leaf child: first triangle
        int32_t count[4];  // leaf child: triangle count; 0 for an inner child, -1 for an empty slot
    };
    struct Triangle {
        double v0[3], e1[3], e2[3];
    };
    struct RayData;

    template <bool AnyHit>
    bool traverse(const RayData& ray, double t_min, double& t_max, int& triangle) const;

    std::vector<Node> nodes_;
    std::vector<Triangle> triangles_;  // in leaf order
    std::vector<cv::Vec3f> albedo_;  // per triangle, at its corners
};

}  // namespace picoscan::detail
