// Signed distances of points to a triangle mesh: CGAL's AABB tree finds the closest point, the
// angle-weighted pseudo-normal there gives the side (Baerentzen & Aanaes, "Signed distance
// computation using the angle weighted pseudonormal", IEEE TVCG 11(3), 2005). The only CGAL
// translation unit of this stage.
#include "picoscan/deviation.h"
#include "picoscan/error.h"

#include "common/parallel.h"
#include "common/progress_reporter.h"

#include <opencv2/calib3d.hpp>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <unordered_map>

namespace picoscan {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

cv::Vec3d to_vec(const Kernel::Point_3& p) { return {p.x(), p.y(), p.z()}; }

// The reference with vertices welded (a tessellated B-rep repeats the vertices of shared edges
// in every face) and the pseudo-normals of its faces, edges and vertices.
struct Reference {
    std::vector<cv::Vec3d> vertices;
    std::vector<std::array<int, 3>> faces;       // non-degenerate faces only, welded indices
    std::vector<Triangle> triangles;             // one per face
    std::vector<cv::Vec3d> face_normals;         // unit
    std::vector<std::array<cv::Vec3d, 3>> edge_normals;  // per face: edge (v0 v1), (v1 v2), (v2 v0)
    std::vector<cv::Vec3d> vertex_normals;       // angle-weighted
};

struct PositionHash {
    size_t operator()(const cv::Vec3f& p) const {
        uint32_t bits[3];
        std::memcpy(bits, p.val, sizeof bits);
        return (size_t(bits[0]) * 73856093u) ^ (size_t(bits[1]) * 19349663u) ^ (size_t(bits[2]) * 83492791u);
    }
};

Reference build_reference(const Mesh& mesh) {
    if (mesh.faces.empty()) throw Error("reference", "has no triangles");
    Reference ref;
    std::unordered_map<cv::Vec3f, int, PositionHash> index_of;
    std::vector<int> welded(mesh.vertices.size());
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        const cv::Vec3f& p = mesh.vertices[i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
            throw Error("reference", "vertex " + std::to_string(i) + " is not finite");
        const auto inserted = index_of.emplace(p, int(ref.vertices.size()));
        if (inserted.second) ref.vertices.emplace_back(p[0], p[1], p[2]);
        welded[i] = inserted.first->second;
    }
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        std::array<int, 3> face;
        for (int k = 0; k < 3; ++k) {
            const int v = mesh.faces[f][k];
            if (v < 0 || size_t(v) >= mesh.vertices.size())
                throw Error("reference", "triangle " + std::to_string(f) + " uses vertex " + std::to_string(v) +
                                             " of " + std::to_string(mesh.vertices.size()));
            face[k] = welded[v];
        }
        const cv::Vec3d normal =
            (ref.vertices[face[1]] - ref.vertices[face[0]]).cross(ref.vertices[face[2]] - ref.vertices[face[0]]);
        const double area2 = cv::norm(normal);
        if (!(area2 > 0)) continue;  // degenerate: no side, and its edges belong to its neighbours
        ref.faces.push_back(face);
        ref.face_normals.push_back(normal / area2);
    }
    if (ref.faces.empty()) throw Error("reference", "every triangle is degenerate (zero area)");

    ref.vertex_normals.assign(ref.vertices.size(), cv::Vec3d(0, 0, 0));
    std::unordered_map<uint64_t, cv::Vec3d> edge_sums;
    const auto edge_key = [](int a, int b) { return (uint64_t(std::min(a, b)) << 32) | uint64_t(std::max(a, b)); };
    for (size_t f = 0; f < ref.faces.size(); ++f) {
        const auto& face = ref.faces[f];
        for (int k = 0; k < 3; ++k) {
            const cv::Vec3d& p = ref.vertices[face[k]];
            const cv::Vec3d a = ref.vertices[face[(k + 1) % 3]] - p, b = ref.vertices[face[(k + 2) % 3]] - p;
            const double angle = std::acos(std::clamp(a.dot(b) / (cv::norm(a) * cv::norm(b)), -1.0, 1.0));
            ref.vertex_normals[face[k]] += angle * ref.face_normals[f];
            edge_sums[edge_key(face[k], face[(k + 1) % 3])] += ref.face_normals[f];
        }
    }
    ref.edge_normals.resize(ref.faces.size());
    ref.triangles.reserve(ref.faces.size());
    for (size_t f = 0; f < ref.faces.size(); ++f) {
        const auto& face = ref.faces[f];
        for (int k = 0; k < 3; ++k) ref.edge_normals[f][k] = edge_sums[edge_key(face[k], face[(k + 1) % 3])];
        const auto point = [&](int k) {
            const cv::Vec3d& v = ref.vertices[face[k]];
            return Kernel::Point_3(v[0], v[1], v[2]);
        };
        ref.triangles.emplace_back(point(0), point(1), point(2));
    }
    return ref;
}

// The pseudo-normal at `closest` on face f: the face's normal inside it, the edge's on an edge,
// the vertex's at a corner (barycentric coordinates near zero say where the point is).
cv::Vec3d pseudo_normal(const Reference& ref, size_t f, const cv::Vec3d& closest) {
    const auto& face = ref.faces[f];
    const cv::Vec3d a = ref.vertices[face[0]], b = ref.vertices[face[1]], c = ref.vertices[face[2]];
    const cv::Vec3d n = (b - a).cross(c - a);
    const double area2 = n.dot(n);
    const double w0 = (c - b).cross(closest - b).dot(n) / area2;  // weight of a
    const double w1 = (a - c).cross(closest - c).dot(n) / area2;  // weight of b
    const double w2 = 1 - w0 - w1;                                // weight of c
    constexpr double eps = 1e-7;
    const bool on0 = w0 < eps, on1 = w1 < eps, on2 = w2 < eps;
    if (on1 && on2) return ref.vertex_normals[face[0]];
    if (on0 && on2) return ref.vertex_normals[face[1]];
    if (on0 && on1) return ref.vertex_normals[face[2]];
    if (on2) return ref.edge_normals[f][0];  // edge a-b
    if (on0) return ref.edge_normals[f][1];  // edge b-c
    if (on1) return ref.edge_normals[f][2];  // edge c-a
    return ref.face_normals[f];
}

// Spreads the lowest 21 bits of v to every third bit.
uint64_t spread_bits(uint64_t v) {
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
}

// Indices of the finite points sorted along a Z-order curve over their bounding box.
std::vector<size_t> morton_order(const std::vector<cv::Vec3f>& points) {
    cv::Vec3f low(HUGE_VALF, HUGE_VALF, HUGE_VALF), high(-HUGE_VALF, -HUGE_VALF, -HUGE_VALF);
    std::vector<size_t> finite;
    finite.reserve(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
        const cv::Vec3f& p = points[i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
        finite.push_back(i);
        for (int k = 0; k < 3; ++k) low[k] = std::min(low[k], p[k]), high[k] = std::max(high[k], p[k]);
    }
    std::vector<std::pair<uint64_t, size_t>> keyed(finite.size());
    const double cells = double(1 << 21) - 1;
    for (size_t n = 0; n < finite.size(); ++n) {
        const cv::Vec3f& p = points[finite[n]];
        uint64_t key = 0;
        for (int k = 0; k < 3; ++k) {
            const double t = high[k] > low[k] ? (p[k] - low[k]) / (high[k] - low[k]) : 0.0;
            key |= spread_bits(uint64_t(t * cells)) << k;
        }
        keyed[n] = {key, finite[n]};
    }
    std::sort(keyed.begin(), keyed.end());
    std::vector<size_t> order(keyed.size());
    for (size_t n = 0; n < keyed.size(); ++n) order[n] = keyed[n].second;
    return order;
}

}  // namespace

DeviationMap measure_deviation(const std::vector<cv::Vec3f>& points, const Mesh& reference,
                               const DeviationOptions& options, const ProgressCallback& progress) {
    if (!(options.tolerance_mm > 0)) throw Error("tolerance_mm", "must be positive");
    if (options.histogram_bins < 2 || options.histogram_bins > 10000)
        throw Error("histogram_bins", "must be between 2 and 10000");
    if (!(options.max_distance_mm >= 0)) throw Error("max_distance_mm", "must be 0 (no limit) or positive");
    if (!(options.range_mm >= 0)) throw Error("range_mm", "must be 0 (automatic) or positive");
    if (points.empty()) throw Error("points", "none to measure");

    // The preparation reports too, so that a cancel is heard before the queries start.
    const auto prepared = [&](double fraction) {
        if (progress && !progress(fraction, "deviation: preparing")) throw Error("cancelled", "deviation measurement was stopped");
    };
    const Reference ref = build_reference(reference);
    prepared(0.3);
    Tree tree(ref.triangles.begin(), ref.triangles.end());
    tree.accelerate_distance_queries();  // built here: the queries below only read the tree
    prepared(0.6);

    DeviationMap map;
    map.distances_mm.assign(points.size(), std::numeric_limits<float>::quiet_NaN());
    // Points in Morton (Z-curve) order: each query starts from the previous point's answer, a
    // near one, which lets the tree discard most boxes at once.
    const std::vector<size_t> order = morton_order(points);
    prepared(1.0);
    constexpr int block = 8192;
    const int blocks = int((order.size() + block - 1) / block);
    detail::ProgressReporter reporter(progress, "deviation", blocks);
    const double max_distance = options.max_distance_mm > 0 ? options.max_distance_mm : HUGE_VAL;
    detail::parallel_rows(blocks, [&](int first, int last) {
        bool have_hint = false;
        Tree::Point_and_primitive_id hint;
        for (int b = first; b < last && !reporter.cancelled(); ++b) {
            const size_t end = std::min(order.size(), size_t(b + 1) * block);
            for (size_t k = size_t(b) * block; k < end; ++k) {
                const size_t i = order[k];
                const cv::Vec3f& p = points[i];
                const Kernel::Point_3 query(p[0], p[1], p[2]);
                hint = have_hint ? tree.closest_point_and_primitive(query, hint) : tree.closest_point_and_primitive(query);
                have_hint = true;
                const cv::Vec3d closest = to_vec(hint.first), offset = cv::Vec3d(p[0], p[1], p[2]) - closest;
                const double distance = cv::norm(offset);
                if (distance > max_distance) continue;
                const size_t face = size_t(hint.second - ref.triangles.begin());
                const double side = offset.dot(pseudo_normal(ref, face, closest));
                map.distances_mm[i] = float(side < 0 ? -distance : distance);
            }
            reporter.advance();
        }
    });
    if (reporter.cancelled()) throw Error("cancelled", "deviation measurement was stopped");
    summarise_deviation(map, options);
    return map;
}

BestFit best_fit_to_reference(const std::vector<cv::Vec3f>& points, const Mesh& reference,
                              const BestFitOptions& options, const ProgressCallback& progress) {
    if (!(options.keep_fraction > 0 && options.keep_fraction <= 1)) throw Error("keep_fraction", "must be in (0, 1]");
    if (options.max_iterations < 1) throw Error("max_iterations", "must be at least 1");
    if (!(options.max_distance_mm >= 0)) throw Error("max_distance_mm", "must be 0 (no limit) or positive");
    // An even subset, in Morton order so that each query can start from its neighbour's answer.
    const std::vector<size_t> order = morton_order(points);
    const size_t stride = std::max<size_t>(1, order.size() / size_t(std::max(1, options.max_points)));
    std::vector<cv::Vec3d> sample;
    for (size_t k = 0; k < order.size(); k += stride) sample.emplace_back(points[order[k]]);
    if (sample.size() < 6) throw Error("points", "fewer than 6 points to fit");
    const Reference ref = build_reference(reference);
    Tree tree(ref.triangles.begin(), ref.triangles.end());
    tree.accelerate_distance_queries();

    BestFit fit;
    struct Pair {
        cv::Vec3d point, normal;
        double residual, distance;
    };
    std::vector<Pair> pairs(sample.size());
    detail::ProgressReporter reporter(progress, "best fit", options.max_iterations);
    const double max_distance = options.max_distance_mm > 0 ? options.max_distance_mm : HUGE_VAL;
    for (fit.iterations = 1; fit.iterations <= options.max_iterations; ++fit.iterations) {
        const cv::Matx33d rotation = fit.transform.get_minor<3, 3>(0, 0);
        const cv::Vec3d translation(fit.transform(0, 3), fit.transform(1, 3), fit.transform(2, 3));
        detail::parallel_rows(int(sample.size()), [&](int first, int last) {
            Tree::Point_and_primitive_id found;
            for (int i = first; i < last; ++i) {
                const cv::Vec3d p = rotation * sample[size_t(i)] + translation;
                const Kernel::Point_3 query(p[0], p[1], p[2]);
                found = i > first ? tree.closest_point_and_primitive(query, found) : tree.closest_point_and_primitive(query);
                const cv::Vec3d q = to_vec(found.first);
                const cv::Vec3d n = ref.face_normals[size_t(found.second - ref.triangles.begin())];
                pairs[size_t(i)] = {p, n, (p - q).dot(n), cv::norm(p - q)};
            }
        });
        // Trimmed: the nearest keep_fraction of the pairs within max_distance.
        std::vector<const Pair*> kept;
        for (const Pair& pair : pairs)
            if (pair.distance <= max_distance) kept.push_back(&pair);
        const size_t keep = size_t(std::ceil(options.keep_fraction * double(kept.size())));
        std::nth_element(kept.begin(), kept.begin() + long(std::min(keep, kept.size()) - (keep > 0)), kept.end(),
                         [](const Pair* a, const Pair* b) { return a->distance < b->distance; });
        kept.resize(std::min(keep, kept.size()));
        if (kept.size() < 6) throw Error("points", "fewer than 6 points lie within max_distance_mm of the reference");
        // Point-to-plane step, linearised in the small rotation w: r + (w x p + t) . n = 0.
        cv::Matx66d normal = cv::Matx66d::zeros();
        cv::Vec6d right(0, 0, 0, 0, 0, 0);
        double sum_squares = 0;
        for (const Pair* pair : kept) {
            const cv::Vec3d c = pair->point.cross(pair->normal);
            const cv::Vec6d row(c[0], c[1], c[2], pair->normal[0], pair->normal[1], pair->normal[2]);
            normal += row * row.t();
            right -= row * pair->residual;
            sum_squares += pair->residual * pair->residual;
        }
        fit.rms_mm = std::sqrt(sum_squares / double(kept.size()));
        fit.pairs = kept.size();
        cv::Vec6d eigenvalues;
        cv::eigen(cv::Mat(normal), eigenvalues);
        if (!(eigenvalues[5] > 1e-9 * eigenvalues[0]))
            throw Error("points", "they do not fix all six degrees of freedom against the reference (one plane, "
                                  "a sphere or a cylinder alone can slide); include more of the part");
        cv::Vec6d step;
        cv::solve(normal, right, step, cv::DECOMP_CHOLESKY);
        const cv::Vec3d w(step[0], step[1], step[2]), t(step[3], step[4], step[5]);
        cv::Matx33d turn;
        cv::Rodrigues(w, turn);
        cv::Matx44d update = cv::Matx44d::eye();
        for (int r = 0; r < 3; ++r) {
            for (int k = 0; k < 3; ++k) update(r, k) = turn(r, k);
            update(r, 3) = t[r];
        }
        fit.transform = update * fit.transform;
        if (!reporter.advance()) throw Error("cancelled", "best fit was stopped");
        if (cv::norm(w) * 180 / CV_PI < options.converged_deg && cv::norm(t) < options.converged_mm) {
            fit.converged = true;
            break;
        }
    }
    fit.iterations = std::min(fit.iterations, options.max_iterations);
    return fit;
}

}  // namespace picoscan
