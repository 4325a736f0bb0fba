#include "simulate/bvh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace picoscan::detail {

namespace {

constexpr int kBins = 16;
constexpr int kMaxLeafTriangles = 8;  // larger leaves are always split if at all possible
constexpr int kMaxDepth = 60;         // bounds the traversal stack
constexpr int kStackSize = 4 * kMaxDepth + 8;

// Build-time boxes in float: half the memory traffic of double, and the SAH needs no more.
struct Bounds {
    float lo[3] = {INFINITY, INFINITY, INFINITY};
    float hi[3] = {-INFINITY, -INFINITY, -INFINITY};

    void grow(const float* p) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], p[k]);
            hi[k] = std::max(hi[k], p[k]);
        }
    }
    void grow(const Bounds& b) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], b.lo[k]);
            hi[k] = std::max(hi[k], b.hi[k]);
        }
    }
    bool valid() const { return lo[0] <= hi[0]; }
    float half_area() const {
        if (!valid()) return 0.0f;
        const float ex = hi[0] - lo[0], ey = hi[1] - lo[1], ez = hi[2] - lo[2];
        return ex * ey + ey * ez + ez * ex;
    }
};

struct BuildRef {
    Bounds bounds;  // rounded outwards from the double vertices
    float centroid[3];
    int index;
};

cv::Vec3d cross(const double* a, const double* b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

}  // namespace

struct TriangleBvh::RayData {
    float origin[3];
    float inverse[3];
    int near_row[3];  // Node::bounds row of the box face a ray meets first along each axis
    int far_row[3];
    double origin_d[3];
    double direction_d[3];
};

namespace {

// Float box bounds padded outwards: the slab test runs on a float copy of the ray, whose
// rounding (~1e-5 mm at 400 mm) must never make it miss a box that holds a real hit.
float pad_low(double v) { return std::nextafter(static_cast<float>(v - (1e-3 + 1e-6 * std::abs(v))), -INFINITY); }
float pad_high(double v) { return std::nextafter(static_cast<float>(v + (1e-3 + 1e-6 * std::abs(v))), INFINITY); }

}  // namespace

namespace {

struct BinaryNode {
    Bounds bounds;
    int first = 0;  // leaf: first reference; inner: left child (right child is first + 1)
    int count = 0;  // leaf: reference count; 0 for an inner node
};

// Binned surface-area-heuristic binary tree over `refs` (reordered into leaf order).
std::vector<BinaryNode> build_binary(std::vector<BuildRef>& refs) {
    std::vector<BinaryNode> nodes;
    nodes.reserve(2 * refs.size());
    struct Task {
        int node;
        int begin;
        int end;
        int depth;
    };
    std::vector<Task> tasks;
    nodes.emplace_back();
    tasks.push_back({0, 0, static_cast<int>(refs.size()), 0});
    while (!tasks.empty()) {
        const Task task = tasks.back();
        tasks.pop_back();
        Bounds bounds, centroid_bounds;
        for (int i = task.begin; i < task.end; ++i) {
            bounds.grow(refs[i].bounds);
            centroid_bounds.grow(refs[i].centroid);
        }
        nodes[task.node].bounds = bounds;
        const int count = task.end - task.begin;
        auto make_leaf = [&] {
            nodes[task.node].first = task.begin;
            nodes[task.node].count = count;
        };
        if (count <= 2 || task.depth >= kMaxDepth) {
            make_leaf();
            continue;
        }

        // Best split over all three axes, binned in one pass over the references.
        double best_cost = std::numeric_limits<double>::infinity();
        int best_axis = -1, best_bin = -1;
        float bin_scale[3];
        for (int axis = 0; axis < 3; ++axis) {
            const float extent = centroid_bounds.hi[axis] - centroid_bounds.lo[axis];
            bin_scale[axis] = extent > 0.0f ? kBins / extent : 0.0f;
        }
        auto bin_of = [&](const BuildRef& r, int axis) {
            return std::min(kBins - 1, static_cast<int>((r.centroid[axis] - centroid_bounds.lo[axis]) * bin_scale[axis]));
        };
        std::array<Bounds, kBins> bin_bounds[3];
        std::array<int, kBins> bin_count[3] = {};
        for (int i = task.begin; i < task.end; ++i) {
            for (int axis = 0; axis < 3; ++axis) {
                const int b = bin_of(refs[i], axis);
                bin_bounds[axis][b].grow(refs[i].bounds);
                ++bin_count[axis][b];
            }
        }
        for (int axis = 0; axis < 3; ++axis) {
            if (bin_scale[axis] == 0.0f) continue;
            std::array<double, kBins> right_cost{};
            Bounds right;
            int right_count = 0;
            for (int b = kBins - 1; b > 0; --b) {
                right.grow(bin_bounds[axis][b]);
                right_count += bin_count[axis][b];
                right_cost[b] = static_cast<double>(right.half_area()) * right_count;
            }
            Bounds left;
            int left_count = 0;
            for (int b = 0; b < kBins - 1; ++b) {
                left.grow(bin_bounds[axis][b]);
                left_count += bin_count[axis][b];
                if (left_count == 0 || left_count == count) continue;
                const double cost = static_cast<double>(left.half_area()) * left_count + right_cost[b + 1];
                if (cost < best_cost) {
                    best_cost = cost;
                    best_axis = axis;
                    best_bin = b;
                }
            }
        }

        // Cost in units of one triangle test; a box step costs about as much.
        int middle = -1;
        const double leaf_cost = count;
        const double split_cost = 1.0 + best_cost / std::max(static_cast<double>(bounds.half_area()), 1e-30);
        if (best_axis >= 0 && (split_cost < leaf_cost || count > kMaxLeafTriangles)) {
            auto it = std::partition(refs.begin() + task.begin, refs.begin() + task.end,
                                     [&](const BuildRef& r) { return bin_of(r, best_axis) <= best_bin; });
            middle = static_cast<int>(it - refs.begin());
        } else if (best_axis < 0 && count > kMaxLeafTriangles) {
            // All centroids coincide: split by index so leaves stay small.
            middle = task.begin + count / 2;
        }
        if (middle <= task.begin || middle >= task.end) {
            make_leaf();
            continue;
        }
        const int left = static_cast<int>(nodes.size());
        nodes.emplace_back();
        nodes.emplace_back();
        nodes[task.node].first = left;
        nodes[task.node].count = 0;
        tasks.push_back({left, task.begin, middle, task.depth + 1});
        tasks.push_back({left + 1, middle, task.end, task.depth + 1});
    }
    return nodes;
}

}  // namespace

TriangleBvh::TriangleBvh(const std::vector<BvhTriangle>& input) {
    std::vector<BuildRef> refs;
    refs.reserve(input.size());
    for (size_t i = 0; i < input.size(); ++i) {
        const BvhTriangle& tri = input[i];
        const cv::Vec3d n = (tri.b - tri.a).cross(tri.c - tri.a);
        if (!(cv::norm(n) > 0.0) || !std::isfinite(n[0] + n[1] + n[2])) continue;  // degenerate or non-finite
        BuildRef ref;
        for (int k = 0; k < 3; ++k) {
            const double lo = std::min({tri.a[k], tri.b[k], tri.c[k]});
            const double hi = std::max({tri.a[k], tri.b[k], tri.c[k]});
            ref.bounds.lo[k] = std::nextafter(static_cast<float>(lo), -INFINITY);
            ref.bounds.hi[k] = std::nextafter(static_cast<float>(hi), INFINITY);
            ref.centroid[k] = static_cast<float>((tri.a[k] + tri.b[k] + tri.c[k]) / 3.0);
        }
        ref.index = static_cast<int>(i);
        refs.push_back(ref);
    }
    if (refs.empty()) return;
    const std::vector<BinaryNode> binary = build_binary(refs);

    // Collapse the binary tree: each four-wide node takes the children of a binary node and
    // keeps opening its largest inner child until it has four (or only leaves are left).
    nodes_.reserve(binary.size() / 2 + 1);
    auto fill = [&](auto&& self, int node_index, std::vector<int> children) -> void {
        while (children.size() < 4) {
            int widest = -1;
            double widest_area = -1;
            for (size_t i = 0; i < children.size(); ++i) {
                const BinaryNode& b = binary[children[i]];
                if (b.count == 0 && b.bounds.half_area() > widest_area) {
                    widest_area = b.bounds.half_area();
                    widest = static_cast<int>(i);
                }
            }
            if (widest < 0) break;
            const int left = binary[children[widest]].first;
            children[widest] = left;
            children.push_back(left + 1);
        }
        for (int slot = 0; slot < 4; ++slot) {
            Node& node = nodes_[node_index];
            if (slot >= static_cast<int>(children.size())) {
                for (int k = 0; k < 3; ++k) {
                    node.bounds[k][slot] = INFINITY;  // an empty slot no ray can enter
                    node.bounds[3 + k][slot] = -INFINITY;
                }
                node.child[slot] = 0;
                node.count[slot] = -1;
                continue;
            }
            const BinaryNode& b = binary[children[slot]];
            for (int k = 0; k < 3; ++k) {
                node.bounds[k][slot] = pad_low(b.bounds.lo[k]);
                node.bounds[3 + k][slot] = pad_high(b.bounds.hi[k]);
            }
            if (b.count > 0) {
                node.child[slot] = b.first;
                node.count[slot] = b.count;
            } else {
                const int child_index = static_cast<int>(nodes_.size());
                nodes_.emplace_back();
                nodes_[node_index].child[slot] = child_index;  // `node` may have moved
                nodes_[node_index].count[slot] = 0;
                self(self, child_index, {b.first, b.first + 1});
            }
        }
    };
    nodes_.emplace_back();
    if (binary[0].count > 0) fill(fill, 0, {0});  // a single leaf: one slot
    else fill(fill, 0, {binary[0].first, binary[0].first + 1});

    triangles_.resize(refs.size());
    albedo_.resize(refs.size());
    for (size_t i = 0; i < refs.size(); ++i) {
        const BvhTriangle& tri = input[refs[i].index];
        Triangle& t = triangles_[i];
        for (int k = 0; k < 3; ++k) {
            t.v0[k] = tri.a[k];
            t.e1[k] = tri.b[k] - tri.a[k];
            t.e2[k] = tri.c[k] - tri.a[k];
        }
        albedo_[i] = tri.albedo;
    }
}

cv::Vec3d TriangleBvh::normal(int triangle) const {
    const Triangle& t = triangles_[triangle];
    return cv::normalize(cross(t.e1, t.e2));
}

double TriangleBvh::albedo_at(int triangle, const cv::Vec3d& point) const {
    const cv::Vec3f& corner = albedo_[triangle];
    if (corner[0] == corner[1] && corner[1] == corner[2]) return corner[0];
    // Barycentric coordinates of the point from the normal equations of the two edges.
    const Triangle& t = triangles_[triangle];
    const cv::Vec3d e1(t.e1[0], t.e1[1], t.e1[2]), e2(t.e2[0], t.e2[1], t.e2[2]);
    const cv::Vec3d d = point - cv::Vec3d(t.v0[0], t.v0[1], t.v0[2]);
    const double a11 = e1.dot(e1), a12 = e1.dot(e2), a22 = e2.dot(e2);
    const double b1 = d.dot(e1), b2 = d.dot(e2);
    const double det = a11 * a22 - a12 * a12;
    const double u = std::clamp((a22 * b1 - a12 * b2) / det, 0.0, 1.0);
    const double v = std::clamp((a11 * b2 - a12 * b1) / det, 0.0, 1.0 - u);
    return (1.0 - u - v) * corner[0] + u * corner[1] + v * corner[2];
}

template <bool AnyHit>
bool TriangleBvh::traverse(const RayData& ray, double t_min, double& t_max, int& triangle) const {
    const Node* nodes = nodes_.data();
    const Triangle* tris = triangles_.data();
    const float t_min_f = static_cast<float>(t_min) * (1.0f - 1e-6f) - 1e-6f;
    // Float upper bound for box culling, loosened so a float-rounded box distance never
    // rejects a hit the double-precision triangle test would accept.
    auto loose = [](double t) { return static_cast<float>(std::min(t, 1e30)) * (1.0f + 2e-6f) + 1e-6f; };
    float t_max_f = loose(t_max);

    struct Entry {
        int32_t child;
        int32_t count;
        float entry;
    };
    Entry stack[kStackSize];
    int depth = 0;
    stack[depth++] = {0, 0, t_min_f};
    bool found = false;
    const double* o = ray.origin_d;
    const double* d = ray.direction_d;
#if defined(__SSE2__)
    const __m128 origin_x = _mm_set1_ps(ray.origin[0]), origin_y = _mm_set1_ps(ray.origin[1]),
                 origin_z = _mm_set1_ps(ray.origin[2]);
    const __m128 inverse_x = _mm_set1_ps(ray.inverse[0]), inverse_y = _mm_set1_ps(ray.inverse[1]),
                 inverse_z = _mm_set1_ps(ray.inverse[2]);
#endif

    while (depth > 0) {
        const Entry e = stack[--depth];
        if (e.entry > t_max_f) continue;  // a nearer hit was found meanwhile
        if (e.count > 0) {
            // Leaf: Möller–Trumbore, two-sided, in double.
            for (int i = e.child, end = e.child + e.count; i < end; ++i) {
                const Triangle& tri = tris[i];
                const double p0 = d[1] * tri.e2[2] - d[2] * tri.e2[1];
                const double p1 = d[2] * tri.e2[0] - d[0] * tri.e2[2];
                const double p2 = d[0] * tri.e2[1] - d[1] * tri.e2[0];
                const double det = tri.e1[0] * p0 + tri.e1[1] * p1 + tri.e1[2] * p2;
                if (det == 0.0) continue;
                const double inv_det = 1.0 / det;
                const double s0 = o[0] - tri.v0[0], s1 = o[1] - tri.v0[1], s2 = o[2] - tri.v0[2];
                const double u = (s0 * p0 + s1 * p1 + s2 * p2) * inv_det;
                if (u < 0.0 || u > 1.0) continue;
                const double q0 = s1 * tri.e1[2] - s2 * tri.e1[1];
                const double q1 = s2 * tri.e1[0] - s0 * tri.e1[2];
                const double q2 = s0 * tri.e1[1] - s1 * tri.e1[0];
                const double v = (d[0] * q0 + d[1] * q1 + d[2] * q2) * inv_det;
                if (v < 0.0 || u + v > 1.0) continue;
                const double t = (tri.e2[0] * q0 + tri.e2[1] * q1 + tri.e2[2] * q2) * inv_det;
                if (t > t_min && t < t_max) {
                    if (AnyHit) return true;
                    t_max = t;
                    triangle = i;
                    found = true;
                }
            }
            if (found) t_max_f = loose(t_max);
            continue;
        }

        // Inner node: slab test of all four child boxes at once.
        const Node& node = nodes[e.child];
        float entry[4];
        int hit_mask;
#if defined(__SSE2__)
        {
            const __m128 near_x = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.bounds[ray.near_row[0]]), origin_x), inverse_x);
            const __m128 near_y = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.bounds[ray.near_row[1]]), origin_y), inverse_y);
            const __m128 near_z = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.bounds[ray.near_row[2]]), origin_z), inverse_z);
            const __m128 far_x = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.bounds[ray.far_row[0]]), origin_x), inverse_x);
            const __m128 far_y = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.bounds[ray.far_row[1]]), origin_y), inverse_y);
            const __m128 far_z = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(node.bounds[ray.far_row[2]]), origin_z), inverse_z);
            const __m128 t0 = _mm_max_ps(_mm_max_ps(near_x, near_y), _mm_max_ps(near_z, _mm_set1_ps(t_min_f)));
            const __m128 t1 = _mm_min_ps(_mm_min_ps(far_x, far_y), _mm_min_ps(far_z, _mm_set1_ps(t_max_f)));
            hit_mask = _mm_movemask_ps(_mm_cmple_ps(t0, t1));
            _mm_storeu_ps(entry, t0);
        }
#else
        hit_mask = 0;
        for (int slot = 0; slot < 4; ++slot) {
            float t0 = t_min_f, t1 = t_max_f;
            for (int k = 0; k < 3; ++k) {
                t0 = std::max(t0, (node.bounds[ray.near_row[k]][slot] - ray.origin[k]) * ray.inverse[k]);
                t1 = std::min(t1, (node.bounds[ray.far_row[k]][slot] - ray.origin[k]) * ray.inverse[k]);
            }
            entry[slot] = t0;
            if (t0 <= t1) hit_mask |= 1 << slot;
        }
#endif
        // Push the children hit, farthest first, so the nearest is visited next.
        const int first = depth;
        for (int slot = 0; slot < 4; ++slot) {
            if (!(hit_mask & (1 << slot))) continue;
            Entry child{node.child[slot], node.count[slot], entry[slot]};
            int at = depth++;
            while (at > first && stack[at - 1].entry < child.entry) {
                stack[at] = stack[at - 1];
                --at;
            }
            stack[at] = child;
        }
    }
    return found;
}

namespace {

template <class RayData>
void make_ray(RayData& ray, const cv::Vec3d& origin, const cv::Vec3d& direction) {
    for (int k = 0; k < 3; ++k) {
        ray.origin[k] = static_cast<float>(origin[k]);
        ray.origin_d[k] = origin[k];
        ray.direction_d[k] = direction[k];
        // A zero component gets a huge finite inverse so the slab test never sees 0 * inf.
        const double dk = std::abs(direction[k]) < 1e-30 ? std::copysign(1e-30, direction[k]) : direction[k];
        ray.inverse[k] = static_cast<float>(std::max(-1e30, std::min(1e30, 1.0 / dk)));
        ray.near_row[k] = ray.inverse[k] < 0 ? 3 + k : k;
        ray.far_row[k] = ray.inverse[k] < 0 ? k : 3 + k;
    }
}

}  // namespace

bool TriangleBvh::nearest(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double& t_max,
                          int& triangle) const {
    if (triangles_.empty()) return false;
    RayData ray;
    make_ray(ray, origin, direction);
    return traverse<false>(ray, t_min, t_max, triangle);
}

bool TriangleBvh::occluded(const cv::Vec3d& origin, const cv::Vec3d& direction, double t_min, double t_max) const {
    if (triangles_.empty()) return false;
    RayData ray;
    make_ray(ray, origin, direction);
    int triangle = -1;
    return traverse<true>(ray, t_min, t_max, triangle);
}

}  // namespace picoscan::detail
