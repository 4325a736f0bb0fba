// The open surface of oriented points, contoured on a sparse voxel band around them.
//
// The signed distance at a grid corner is the weighted mean of the distances to the tangent
// planes of the nearby points (Hoppe et al. 1992, "Surface reconstruction from unorganized
// points", with the Gaussian-weighted mean of implicit MLS surfaces, Kolluri 2008), taken
// only over points whose normal agrees with the nearest point's: the two sides of a thin wall
// are not averaged into one sheet. It is evaluated only on the cubes around the points and
// contoured by marching tetrahedra: each cube is split into the six tetrahedra of Kuhn's
// triangulation (the chains from corner (0,0,0) to (1,1,1) along the axes in each order),
// which neighbouring cubes share face by face, so that every crossing point is one vertex of
// the mesh and the result is a manifold whose only borders lie at the band's edge. Triangles
// farther than kKeptReach voxels from every point are cut: nothing is invented.
#include "common/text_format.h"
#include "picoscan/error.h"
#include "picoscan/mesh.h"
#include "register/point_grid.h"

#include <opencv2/core.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <unordered_map>

namespace picoscan {

namespace {

// Corners within this many voxels of at least kLeastNeighbours agreeing points get a distance.
constexpr double kNeighbourReach = 2.0;
constexpr int kLeastNeighbours = 3;
// The Gaussian weight's width, in voxels.
constexpr double kWeightWidth = 1.0;
// Points whose normal is within 60 degrees of the nearest point's belong to the same sheet.
constexpr double kSameSheet = 0.5;
// Triangles with a corner farther than this many voxels from every point are cut.
constexpr double kKeptReach = 1.5;
// Pieces of fewer faces than this are crumbs of noise (a few stray points), not surface.
constexpr size_t kLeastPieceFaces = 12;
// Edges shorter than this many voxels (crossings bunched near one grid corner) are collapsed.
constexpr double kShortEdge = 0.3;
// Corners and cubes handled between two progress reports.
constexpr size_t kBlock = 1 << 15;

// Grid indices packed in 20 bits per axis; an edge key adds 3 bits for its direction.
constexpr int kAxisBits = 20;
constexpr int64_t kAxisLimit = int64_t(1) << kAxisBits;

using Key = uint64_t;

Key corner_key(int64_t x, int64_t y, int64_t z) {
    return (Key(x) << (2 * kAxisBits)) | (Key(y) << kAxisBits) | Key(z);
}

cv::Vec<int64_t, 3> corner_of(Key key) {
    const Key mask = Key(kAxisLimit - 1);
    return {int64_t((key >> (2 * kAxisBits)) & mask), int64_t((key >> kAxisBits) & mask), int64_t(key & mask)};
}

// Offsets of a cube's corners: bit 0 x, bit 1 y, bit 2 z.
cv::Vec<int64_t, 3> offset(int bits) { return {bits & 1, (bits >> 1) & 1, (bits >> 2) & 1}; }

// The six tetrahedra of a cube, as corner numbers (offset bits), each a chain from 0 to 7
// stepping along x, y and z in one of the six orders; every edge of them joins a corner to
// one with more bits set.
constexpr std::array<std::array<int, 4>, 6> kTetrahedra{{
    {{0, 1, 3, 7}}, {{0, 1, 5, 7}}, {{0, 2, 3, 7}}, {{0, 2, 6, 7}}, {{0, 4, 5, 7}}, {{0, 4, 6, 7}},
}};

class BandSurface {
public:
    BandSurface(const PointCloud& cloud, double voxel_mm, const ProgressCallback& progress)
        : voxel_(voxel_mm), progress_(progress) {
        for (size_t i = 0; i < cloud.points.size(); ++i) {
            const cv::Vec3d p(cloud.points[i]), n(cloud.normals[i]);
            const double length = cv::norm(n);
            if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]) && std::isfinite(length) && length > 0))
                continue;
            points_.push_back(p);
            normals_.push_back(n / length);
        }
        if (points_.empty()) throw Error("point cloud", "has no point with a valid normal: nothing to mesh");
        cv::Vec3d low = points_[0], high = points_[0];
        for (const cv::Vec3d& p : points_)
            for (int k = 0; k < 3; ++k) {
                low[k] = std::min(low[k], p[k]);
                high[k] = std::max(high[k], p[k]);
            }
        origin_ = low - cv::Vec3d::all(3 * voxel_);
        for (int k = 0; k < 3; ++k)
            if ((high[k] - origin_[k]) / voxel_ + 3 >= double(kAxisLimit))
                throw Error("voxel", "of " + format("%.3g", voxel_) + " mm is too fine for a cloud " +
                                         format("%.3g", high[k] - low[k]) + " mm across");
    }

    Mesh run() {
        find_band();
        evaluate_corners();
        contour();
        cut_far_faces();
        keep_manifold_fans();
        drop_crumbs();
        collapse_short_edges();
        return compact();
    }

private:
    void report(double fraction, const char* stage) const {
        if (progress_ && !progress_(fraction, stage)) throw Error("cancelled", "meshing cancelled");
    }

    cv::Vec<int64_t, 3> cell_of(const cv::Vec3d& p) const {
        return {int64_t(std::floor((p[0] - origin_[0]) / voxel_)), int64_t(std::floor((p[1] - origin_[1]) / voxel_)),
                int64_t(std::floor((p[2] - origin_[2]) / voxel_))};
    }

    cv::Vec3d position(const cv::Vec<int64_t, 3>& corner) const {
        return origin_ + voxel_ * cv::Vec3d(double(corner[0]), double(corner[1]), double(corner[2]));
    }

    // The cubes holding a point and their neighbours, and the corners of those cubes.
    void find_band() {
        report(0.0, "band surface: finding the band");
        cubes_.reserve(points_.size() * 27);
        for (const cv::Vec3d& p : points_) {
            const cv::Vec<int64_t, 3> c = cell_of(p);
            for (int64_t dz = -1; dz <= 1; ++dz)
                for (int64_t dy = -1; dy <= 1; ++dy)
                    for (int64_t dx = -1; dx <= 1; ++dx) cubes_.push_back(corner_key(c[0] + dx, c[1] + dy, c[2] + dz));
        }
        std::sort(cubes_.begin(), cubes_.end());
        cubes_.erase(std::unique(cubes_.begin(), cubes_.end()), cubes_.end());
        corners_.reserve(cubes_.size() * 2);
        for (Key cube : cubes_) {
            const cv::Vec<int64_t, 3> c = corner_of(cube);
            for (int bits = 0; bits < 8; ++bits) {
                const cv::Vec<int64_t, 3> o = offset(bits);
                corners_.push_back(corner_key(c[0] + o[0], c[1] + o[1], c[2] + o[2]));
            }
        }
        std::sort(corners_.begin(), corners_.end());
        corners_.erase(std::unique(corners_.begin(), corners_.end()), corners_.end());
    }

    // The signed distance at every corner of the band (NaN where too few points are near).
    void evaluate_corners() {
        const double reach = kNeighbourReach * voxel_;
        const double width = kWeightWidth * voxel_;
        const detail::PointGrid grid(points_, reach);
        values_.assign(corners_.size(), std::numeric_limits<float>::quiet_NaN());
        std::vector<int> near;
        for (size_t i = 0; i < corners_.size(); ++i) {
            if (i % kBlock == 0) report(0.05 + 0.6 * double(i) / double(corners_.size()), "band surface: signed distances");
            const cv::Vec3d x = position(corner_of(corners_[i]));
            grid.within(x, reach, near);
            if (near.size() < size_t(kLeastNeighbours)) continue;
            int nearest = near[0];
            double nearest_distance = std::numeric_limits<double>::max();
            for (int k : near) {
                const double d = cv::norm(x - points_[size_t(k)], cv::NORM_L2SQR);
                if (d < nearest_distance) {
                    nearest_distance = d;
                    nearest = k;
                }
            }
            const cv::Vec3d& sheet = normals_[size_t(nearest)];
            double weighted = 0, weights = 0;
            int agreeing = 0;
            for (int k : near) {
                const cv::Vec3d& n = normals_[size_t(k)];
                if (n.dot(sheet) < kSameSheet) continue;
                const cv::Vec3d d = x - points_[size_t(k)];
                const double w = std::exp(-d.dot(d) / (width * width));
                weighted += w * n.dot(d);
                weights += w;
                ++agreeing;
            }
            if (agreeing >= kLeastNeighbours && weights > 0) values_[i] = float(weighted / weights);
        }
    }

    size_t corner_index(Key key) const {
        return size_t(std::lower_bound(corners_.begin(), corners_.end(), key) - corners_.begin());
    }

    // The mesh vertex where the edge from corner `low` to corner `low + o(direction)` crosses zero.
    int crossing(Key low, int direction, size_t low_index, size_t high_index) {
        const Key edge = (low << 3) | Key(direction);
        const auto [found, inserted] = crossings_.try_emplace(edge, int(mesh_.vertices.size()));
        if (inserted) {
            const double a = values_[low_index], b = values_[high_index];
            // Kept off the corners themselves, so that no triangle collapses to a point.
            const double t = std::clamp(a / (a - b), 1e-3, 1 - 1e-3);
            const cv::Vec<int64_t, 3> c = corner_of(low);
            const cv::Vec3d from = position(c), to = position(c + offset(direction));
            mesh_.vertices.emplace_back(from + t * (to - from));
        }
        return found->second;
    }

    // The zero set of the linear function on each tetrahedron: a triangle, or a quad as two,
    // facing the positive side (outside, where the normals point).
    void contour() {
        for (size_t i = 0; i < cubes_.size(); ++i) {
            if (i % kBlock == 0) report(0.65 + 0.25 * double(i) / double(cubes_.size()), "band surface: contouring");
            const cv::Vec<int64_t, 3> c = corner_of(cubes_[i]);
            std::array<Key, 8> keys;
            std::array<size_t, 8> index;
            std::array<float, 8> value;
            for (int bits = 0; bits < 8; ++bits) {
                const cv::Vec<int64_t, 3> o = offset(bits);
                keys[bits] = corner_key(c[0] + o[0], c[1] + o[1], c[2] + o[2]);
                index[bits] = corner_index(keys[bits]);
                value[bits] = values_[index[bits]];
            }
            for (const auto& tetrahedron : kTetrahedra) {
                bool known = true;
                int inside = 0;
                for (int corner : tetrahedron) {
                    known = known && std::isfinite(value[corner]);
                    inside += value[corner] < 0 ? 1 : 0;
                }
                if (!known || inside == 0 || inside == 4) continue;
                std::array<int, 4> below{}, above{};
                int below_count = 0, above_count = 0;
                for (int corner : tetrahedron) {
                    if (value[corner] < 0)
                        below[below_count++] = corner;
                    else
                        above[above_count++] = corner;
                }
                auto vertex = [&](int a, int b) {
                    const int low = std::min(a, b), high = std::max(a, b);  // every edge goes to more bits
                    return crossing(keys[low], high - low, index[low], index[high]);
                };
                cv::Vec3d outwards(0, 0, 0);
                for (int k = 0; k < above_count; ++k) outwards += position(corner_of(keys[above[k]])) / double(above_count);
                for (int k = 0; k < below_count; ++k) outwards -= position(corner_of(keys[below[k]])) / double(below_count);
                if (below_count == 1 || above_count == 1) {
                    const int apex = below_count == 1 ? below[0] : above[0];
                    const std::array<int, 4>& others = below_count == 1 ? above : below;
                    add_triangle({vertex(apex, others[0]), vertex(apex, others[1]), vertex(apex, others[2])}, outwards);
                } else {
                    // Two below (a, b), two above (c, d): the quad ac, ad, bd, bc.
                    const int ac = vertex(below[0], above[0]), ad = vertex(below[0], above[1]);
                    const int bd = vertex(below[1], above[1]), bc = vertex(below[1], above[0]);
                    add_triangle({ac, ad, bd}, outwards);
                    add_triangle({ac, bd, bc}, outwards);
                }
            }
        }
    }

    void add_triangle(cv::Vec3i face, const cv::Vec3d& outwards) {
        const cv::Vec3d a(mesh_.vertices[size_t(face[0])]), b(mesh_.vertices[size_t(face[1])]),
            c(mesh_.vertices[size_t(face[2])]);
        if ((b - a).cross(c - a).dot(outwards) < 0) std::swap(face[1], face[2]);
        mesh_.faces.push_back(face);
    }

    // Faces with a corner beyond kKeptReach voxels of every point: the tangent planes carried
    // past the edge of the data, not measured surface.
    void cut_far_faces() {
        report(0.9, "band surface: cutting unmeasured faces");
        const double reach = kKeptReach * voxel_;
        const detail::PointGrid grid(points_, reach);
        std::vector<uint8_t> near(mesh_.vertices.size());
        for (size_t v = 0; v < mesh_.vertices.size(); ++v) near[v] = grid.nearest(cv::Vec3d(mesh_.vertices[v]), reach) >= 0;
        std::vector<cv::Vec3i> kept;
        kept.reserve(mesh_.faces.size());
        for (const cv::Vec3i& f : mesh_.faces)
            if (near[size_t(f[0])] && near[size_t(f[1])] && near[size_t(f[2])]) kept.push_back(f);
        mesh_.faces.swap(kept);
    }

    // Where the band's edge or the cut leaves several fans of faces around one vertex (they
    // touch only there), all but the largest fan go: the result is a manifold.
    void keep_manifold_fans() {
        report(0.95, "band surface: checking the fans");
        for (int round = 0; round < 4; ++round) {
            std::vector<std::vector<int>> faces_of(mesh_.vertices.size());
            for (size_t f = 0; f < mesh_.faces.size(); ++f)
                for (int k = 0; k < 3; ++k) faces_of[size_t(mesh_.faces[f][k])].push_back(int(f));
            std::vector<uint8_t> dropped(mesh_.faces.size(), 0);
            bool any = false;
            for (size_t v = 0; v < faces_of.size(); ++v) {
                const std::vector<int>& around = faces_of[v];
                if (around.size() < 2) continue;
                // Fans: faces around v joined through a shared edge (a shared second vertex).
                std::vector<int> fan(around.size(), -1);
                int fans = 0;
                for (size_t start = 0; start < around.size(); ++start) {
                    if (fan[start] >= 0) continue;
                    std::vector<size_t> stack{start};
                    fan[start] = fans;
                    while (!stack.empty()) {
                        const size_t a = stack.back();
                        stack.pop_back();
                        for (size_t b = 0; b < around.size(); ++b)
                            if (fan[b] < 0 && shares_edge_at(around[a], around[b], int(v))) {
                                fan[b] = fans;
                                stack.push_back(b);
                            }
                    }
                    ++fans;
                }
                if (fans < 2) continue;
                std::vector<int> size(size_t(fans), 0);
                for (int f : fan) ++size[size_t(f)];
                const int largest = int(std::max_element(size.begin(), size.end()) - size.begin());
                for (size_t k = 0; k < around.size(); ++k)
                    if (fan[k] != largest) dropped[size_t(around[k])] = 1;
                any = true;
            }
            if (!any) return;
            std::vector<cv::Vec3i> kept;
            for (size_t f = 0; f < mesh_.faces.size(); ++f)
                if (!dropped[f]) kept.push_back(mesh_.faces[f]);
            mesh_.faces.swap(kept);
        }
    }

    // Pieces (faces joined through vertices) of fewer than kLeastPieceFaces faces go.
    void drop_crumbs() {
        std::vector<int> parent(mesh_.vertices.size());
        for (size_t v = 0; v < parent.size(); ++v) parent[v] = int(v);
        auto root = [&](int v) {
            while (parent[size_t(v)] != v) v = parent[size_t(v)] = parent[size_t(parent[size_t(v)])];
            return v;
        };
        for (const cv::Vec3i& f : mesh_.faces) {
            parent[size_t(root(f[1]))] = root(f[0]);
            parent[size_t(root(f[2]))] = root(f[0]);
        }
        std::vector<size_t> faces_in(parent.size(), 0);
        for (const cv::Vec3i& f : mesh_.faces) ++faces_in[size_t(root(f[0]))];
        std::vector<cv::Vec3i> kept;
        kept.reserve(mesh_.faces.size());
        for (const cv::Vec3i& f : mesh_.faces)
            if (faces_in[size_t(root(f[0]))] >= kLeastPieceFaces) kept.push_back(f);
        mesh_.faces.swap(kept);
    }

    // Marching tetrahedra leave the crossing points bunched around grid corners near the zero
    // set (slivers): each edge shorter than kShortEdge voxels is collapsed to its middle, in order
    // of length, when that keeps the mesh a manifold (the two ends share no neighbour but the
    // corners opposite the edge, neither end on a border) and turns no face by more than 60
    // degrees.
    void collapse_short_edges() {
        report(0.97, "band surface: collapsing short edges");
        const double shortest = kShortEdge * voxel_;
        std::vector<std::vector<int>> faces_of(mesh_.vertices.size());
        for (size_t f = 0; f < mesh_.faces.size(); ++f)
            for (int k = 0; k < 3; ++k) faces_of[size_t(mesh_.faces[f][k])].push_back(int(f));
        std::vector<uint8_t> border(mesh_.vertices.size(), 0);
        for (size_t v = 0; v < faces_of.size(); ++v) border[v] = on_border(int(v), faces_of[v]);
        std::vector<std::pair<float, std::pair<int, int>>> edges;
        for (const cv::Vec3i& f : mesh_.faces)
            for (int k = 0; k < 3; ++k) {
                const int a = f[k], b = f[(k + 1) % 3];
                const float length = float(cv::norm(mesh_.vertices[size_t(a)] - mesh_.vertices[size_t(b)]));
                if (a < b && length < shortest) edges.push_back({length, {a, b}});
            }
        std::sort(edges.begin(), edges.end());
        std::vector<uint8_t> removed(mesh_.faces.size(), 0);
        std::vector<int> merged_into(mesh_.vertices.size(), -1);
        for (const auto& [length, edge] : edges) {
            const int a = edge.first, b = edge.second;
            if (merged_into[size_t(a)] >= 0 || merged_into[size_t(b)] >= 0 || border[size_t(a)] || border[size_t(b)]) continue;
            std::vector<int> around_a, around_b, shared_faces;
            for (int f : faces_of[size_t(a)]) {
                bool has_b = false;
                for (int k = 0; k < 3; ++k) {
                    has_b = has_b || mesh_.faces[size_t(f)][k] == b;
                    if (mesh_.faces[size_t(f)][k] != a) around_a.push_back(mesh_.faces[size_t(f)][k]);
                }
                if (has_b) shared_faces.push_back(f);
            }
            if (shared_faces.size() != 2) continue;  // the edge is gone or on a border
            for (int f : faces_of[size_t(b)])
                for (int k = 0; k < 3; ++k)
                    if (mesh_.faces[size_t(f)][k] != b) around_b.push_back(mesh_.faces[size_t(f)][k]);
            std::sort(around_a.begin(), around_a.end());
            around_a.erase(std::unique(around_a.begin(), around_a.end()), around_a.end());
            std::sort(around_b.begin(), around_b.end());
            around_b.erase(std::unique(around_b.begin(), around_b.end()), around_b.end());
            std::vector<int> common;
            std::set_intersection(around_a.begin(), around_a.end(), around_b.begin(), around_b.end(), std::back_inserter(common));
            if (common.size() != 2) continue;  // the link condition: only the two opposite corners
            const cv::Vec3f middle = 0.5f * (mesh_.vertices[size_t(a)] + mesh_.vertices[size_t(b)]);
            bool turns = false;
            for (int end : {a, b})
                for (int f : faces_of[size_t(end)]) {
                    if (f == shared_faces[0] || f == shared_faces[1]) continue;
                    cv::Vec3i face = mesh_.faces[size_t(f)];
                    std::array<cv::Vec3d, 3> before, after;
                    for (int k = 0; k < 3; ++k) {
                        before[k] = cv::Vec3d(mesh_.vertices[size_t(face[k])]);
                        after[k] = face[k] == end ? cv::Vec3d(middle) : before[k];
                    }
                    const cv::Vec3d n0 = (before[1] - before[0]).cross(before[2] - before[0]);
                    const cv::Vec3d n1 = (after[1] - after[0]).cross(after[2] - after[0]);
                    turns = turns || n0.dot(n1) <= 0.5 * cv::norm(n0) * cv::norm(n1);
                }
            if (turns) continue;
            mesh_.vertices[size_t(a)] = middle;
            merged_into[size_t(b)] = a;
            for (int f : shared_faces) removed[size_t(f)] = 1;
            for (int f : faces_of[size_t(b)]) {
                if (removed[size_t(f)]) continue;
                for (int k = 0; k < 3; ++k)
                    if (mesh_.faces[size_t(f)][k] == b) mesh_.faces[size_t(f)][k] = a;
                faces_of[size_t(a)].push_back(f);
            }
            faces_of[size_t(b)].clear();
            std::vector<int>& list = faces_of[size_t(a)];
            list.erase(std::remove_if(list.begin(), list.end(), [&](int f) { return removed[size_t(f)] != 0; }), list.end());
            for (int c : common) {
                std::vector<int>& around = faces_of[size_t(c)];
                around.erase(std::remove_if(around.begin(), around.end(), [&](int f) { return removed[size_t(f)] != 0; }),
                             around.end());
            }
        }
        std::vector<cv::Vec3i> kept;
        kept.reserve(mesh_.faces.size());
        for (size_t f = 0; f < mesh_.faces.size(); ++f)
            if (!removed[f]) kept.push_back(mesh_.faces[f]);
        mesh_.faces.swap(kept);
    }

    // Whether one of the edges from v is used by one face only.
    bool on_border(int v, const std::vector<int>& around) const {
        std::vector<int> others;
        for (int f : around)
            for (int k = 0; k < 3; ++k)
                if (mesh_.faces[size_t(f)][k] != v) others.push_back(mesh_.faces[size_t(f)][k]);
        std::sort(others.begin(), others.end());
        for (size_t i = 0; i < others.size();) {
            size_t j = i;
            while (j < others.size() && others[j] == others[i]) ++j;
            if (j - i != 2) return true;
            i = j;
        }
        return false;
    }

    bool shares_edge_at(int f, int g, int v) const {
        const cv::Vec3i& a = mesh_.faces[size_t(f)];
        const cv::Vec3i& b = mesh_.faces[size_t(g)];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                if (a[i] != v && a[i] == b[j]) return true;
        return false;
    }

    // Only the vertices the faces use.
    Mesh compact() const {
        Mesh out;
        std::vector<int> index(mesh_.vertices.size(), -1);
        out.faces.reserve(mesh_.faces.size());
        for (const cv::Vec3i& f : mesh_.faces) {
            cv::Vec3i g;
            for (int k = 0; k < 3; ++k) {
                int& v = index[size_t(f[k])];
                if (v < 0) {
                    v = int(out.vertices.size());
                    out.vertices.push_back(mesh_.vertices[size_t(f[k])]);
                }
                g[k] = v;
            }
            out.faces.push_back(g);
        }
        return out;
    }

    double voxel_;
    const ProgressCallback& progress_;
    std::vector<cv::Vec3d> points_, normals_;
    cv::Vec3d origin_;
    std::vector<Key> cubes_, corners_;  // sorted
    std::vector<float> values_;         // per corner
    std::unordered_map<Key, int> crossings_;
    Mesh mesh_;
};

}  // namespace

Mesh band_surface(const PointCloud& cloud, double voxel_mm, const ProgressCallback& progress) {
    if (!(voxel_mm > 0) || !std::isfinite(voxel_mm))
        throw Error("voxel", "must be a positive size in mm, got " + std::to_string(voxel_mm));
    if (cloud.normals.size() != cloud.points.size())
        throw Error("point cloud", "has no normals: the band surface needs the side each point was seen from");
    return BandSurface(cloud, voxel_mm, progress).run();
}

}  // namespace picoscan
