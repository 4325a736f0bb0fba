// Closed triangle mesh -> planar B-rep faces: coplanar facets grown into regions (normals within
// an angle, vertices within the noise of one least-squares plane), region boundaries simplified to
// straight edges where two planar faces meet (Douglas-Peucker within the same noise).
#include "picoscan/solid.h"

#include "picoscan/error.h"
#include "solid/cylinder_faces.h"
#include "solid/simplify_surface.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numeric>
#include <set>
#include <sstream>
#include <unordered_map>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Plane {
    cv::Vec3d origin, normal;
    double distance(const cv::Vec3d& p) const { return (p - origin).dot(normal); }
};

// Least-squares plane from the moments of points taken relative to `reference`.
struct PlaneMoments {
    cv::Vec3d reference, sum{0, 0, 0};
    cv::Matx33d products = cv::Matx33d::zeros();
    size_t count = 0;
    void add(const cv::Vec3d& point) {
        const cv::Vec3d p = point - reference;
        sum += p;
        products += p * p.t();
        ++count;
    }
    Plane plane() const {
        const cv::Vec3d mean = sum / double(count);
        const cv::Matx33d covariance = products * (1.0 / double(count)) - mean * mean.t();
        cv::Mat values, vectors;
        cv::eigen(cv::Mat(covariance), values, vectors);  // descending: the last is the normal
        const cv::Vec3d normal(vectors.at<double>(2, 0), vectors.at<double>(2, 1), vectors.at<double>(2, 2));
        return {reference + mean, cv::normalize(normal)};
    }
};

uint64_t edge_key(int a, int b) { return (uint64_t(uint32_t(a)) << 32) | uint32_t(b); }

// Indices of the points of `chain` (first and last included) that a Douglas-Peucker
// simplification within `tolerance` keeps.
void douglas_peucker(const std::vector<cv::Vec3d>& positions, const std::vector<int>& chain, size_t first, size_t last,
                     double tolerance, std::vector<size_t>& kept) {
    if (last <= first + 1) return;
    const cv::Vec3d a = positions[chain[first]], b = positions[chain[last]];
    const cv::Vec3d direction = b - a;
    const double length = cv::norm(direction);
    double worst = -1;
    size_t worst_index = first;
    for (size_t i = first + 1; i < last; ++i) {
        const cv::Vec3d offset = positions[chain[i]] - a;
        const double distance = length > 0 ? cv::norm(offset.cross(direction)) / length : cv::norm(offset);
        if (distance > worst) worst = distance, worst_index = i;
    }
    if (worst <= tolerance) return;
    douglas_peucker(positions, chain, first, worst_index, tolerance, kept);
    kept.push_back(worst_index);
    douglas_peucker(positions, chain, worst_index, last, tolerance, kept);
}


// How far a merged face's boundary may stray from its plane (a vertex is moved onto it by up to
// 3 x the distance limit, or left where it was), and how short an edge may be.
struct FaceLimits {
    double off_plane_mm, min_length_mm;
};

FaceLimits face_limits(const PlanarFaceModel& model, const PlanarFaceOptions& options) {
    cv::Vec3d low = model.vertices.empty() ? cv::Vec3d(0, 0, 0) : model.vertices[0], high = low;
    for (const cv::Vec3d& p : model.vertices)
        for (int k = 0; k < 3; ++k) low[k] = std::min(low[k], p[k]), high[k] = std::max(high[k], p[k]);
    const double size = cv::norm(high - low);
    return {3 * options.distance_factor * model.noise_mm + 1e-9 * size, 1e-7 * size};
}

std::string point_text(const cv::Vec3d& p) {
    char text[96];
    std::snprintf(text, sizeof text, "(%.3f, %.3f, %.3f)", p[0], p[1], p[2]);
    return text;
}

double cross2(const cv::Vec2d& a, const cv::Vec2d& b) { return a[0] * b[1] - a[1] * b[0]; }

double point_segment_distance(const cv::Vec2d& p, const cv::Vec2d& a, const cv::Vec2d& b) {
    const cv::Vec2d ab = b - a;
    const double length2 = ab.dot(ab);
    const double t = length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
    return cv::norm(p - (a + t * ab));
}

double segment_distance(const cv::Vec2d& a, const cv::Vec2d& b, const cv::Vec2d& c, const cv::Vec2d& d) {
    const double abc = cross2(b - a, c - a), abd = cross2(b - a, d - a), cda = cross2(d - c, a - c), cdb = cross2(d - c, b - c);
    if (((abc > 0 && abd < 0) || (abc < 0 && abd > 0)) && ((cda > 0 && cdb < 0) || (cda < 0 && cdb > 0))) return 0;
    return std::min({point_segment_distance(a, c, d), point_segment_distance(b, c, d), point_segment_distance(c, a, b),
                     point_segment_distance(d, a, b)});
}

bool inside(const std::vector<cv::Vec2d>& loop, const cv::Vec2d& p) {
    bool in = false;
    for (size_t i = 0, j = loop.size() - 1; i < loop.size(); j = i++)
        if ((loop[i][1] > p[1]) != (loop[j][1] > p[1]) &&
            p[0] < loop[j][0] + (p[1] - loop[j][1]) * (loop[i][0] - loop[j][0]) / (loop[i][1] - loop[j][1]))
            in = !in;
    return in;
}

double signed_area(const std::vector<cv::Vec2d>& loop) {
    double twice = 0;
    for (size_t i = 0; i < loop.size(); ++i) twice += cross2(loop[i], loop[(i + 1) % loop.size()]);
    return twice / 2;
}

struct FaceDefect {
    std::string reason;        // empty: none
    std::vector<int> vertices; // where (model vertices); empty: the face as a whole
};

// Why a merged face would not be a valid B-rep face, and where; no reason when it would be: its wires must lie on
// its plane, have edges of some length, neither touch nor cross themselves or each other (closer
// than their edges' tolerances), the outer one counter-clockwise seen from outside, the holes
// clockwise, inside it and not inside each other.
FaceDefect merged_face_defect(const PlanarFaceModel& model, const BrepFace& face, const FaceLimits& limits) {
    const cv::Vec3d n = cv::normalize(face.normal);
    const cv::Vec3d helper = std::abs(n[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
    const cv::Vec3d x = cv::normalize(helper - helper.dot(n) * n), y = n.cross(x);
    auto flat = [&](int v) {
        const cv::Vec3d p = model.vertices[v] - face.origin;
        return cv::Vec2d(p.dot(x), p.dot(y));
    };
    struct Segment {
        cv::Vec2d a, b;
        int from, to;
        double tolerance;
    };
    std::vector<Segment> segments;
    std::vector<std::vector<cv::Vec2d>> loops;
    std::unordered_map<int, int> uses;
    for (const auto& wire : face.wires) {
        loops.emplace_back();
        for (int e : wire) {
            const BrepEdge& edge = model.edges[size_t(std::abs(e) - 1)];
            const int from = e > 0 ? edge.start : edge.end, to = e > 0 ? edge.end : edge.start;
            const cv::Vec3d& p = model.vertices[from];
            const double off = std::abs((p - face.origin).dot(n));
            if (off > limits.off_plane_mm) {
                char text[128];
                std::snprintf(text, sizeof text, " is %.4g mm from its plane (at most %.4g)", off, limits.off_plane_mm);
                return {"not planar: its boundary at " + point_text(p) + text, {from}};
            }
            if (++uses[from] > 1) return {"its boundary touches itself at " + point_text(p), {from}};
            if (cv::norm(model.vertices[to] - p) <= limits.min_length_mm)
                return {"an edge of its boundary has no length at " + point_text(p), {from, to}};
            segments.push_back({flat(from), flat(to), from, to, std::max(edge.tolerance_mm, limits.min_length_mm)});
            loops.back().push_back(segments.back().a);
        }
    }
    if (loops.empty() || !(signed_area(loops[0]) > 0)) return {"its outer boundary encloses no area or runs clockwise", {}};
    for (size_t w = 1; w < loops.size(); ++w) {
        if (!(signed_area(loops[w]) < 0)) return {"a hole's boundary runs counter-clockwise", {}};
        if (!inside(loops[0], loops[w][0])) return {"a hole lies outside its outer boundary", {}};
        for (size_t other = 1; other < loops.size(); ++other)
            if (other != w && inside(loops[other], loops[w][0])) return {"a hole lies inside another hole", {}};
    }
    // Every pair of edges that could come within their tolerances: swept along x.
    std::sort(segments.begin(), segments.end(),
              [](const Segment& s, const Segment& t) { return std::min(s.a[0], s.b[0]) < std::min(t.a[0], t.b[0]); });
    for (size_t i = 0; i < segments.size(); ++i) {
        const Segment& s = segments[i];
        const double s_right = std::max(s.a[0], s.b[0]);
        for (size_t j = i + 1; j < segments.size(); ++j) {
            const Segment& t = segments[j];
            const double tolerance = std::max(s.tolerance, t.tolerance);
            if (std::min(t.a[0], t.b[0]) > s_right + tolerance) break;
            if (std::min(t.a[1], t.b[1]) > std::max(s.a[1], s.b[1]) + tolerance ||
                std::min(s.a[1], s.b[1]) > std::max(t.a[1], t.b[1]) + tolerance)
                continue;
            double distance;
            if (s.to == t.from && s.from == t.to) {
                distance = 0;
            } else if (s.to == t.from || s.from == t.to) {
                // Neighbours meet at their shared vertex; they may not fold back onto each other
                // beyond its tolerance.
                const bool s_first = s.to == t.from;
                const cv::Vec2d &shared = s_first ? s.b : s.a, &s_far = s_first ? s.a : s.b, &t_far = s_first ? t.b : t.a;
                distance = std::numeric_limits<double>::infinity();
                if (cv::norm(s_far - shared) > tolerance) distance = point_segment_distance(s_far, t.a, t.b);
                if (cv::norm(t_far - shared) > tolerance) distance = std::min(distance, point_segment_distance(t_far, s.a, s.b));
            } else {
                distance = segment_distance(s.a, s.b, t.a, t.b);
            }
            if (distance <= tolerance)
                return {"its boundary crosses or touches itself near " + point_text(model.vertices[s.from]),
                        {s.from, s.to, t.from, t.to}};
        }
    }
    return {};
}

}  // namespace

std::string PlanarFaceModel::summary() const {
    std::ostringstream text;
    text << faces.size() << " faces from " << facet_count << " facets: " << merged_faces << " planar regions holding "
         << merged_facets << " facets, ";
    if (cylinder_faces > 0) {
        text << cylinder_faces << " cylinders replacing " << cylinder_facets << " facets";
        if (cylinder_end_facets > 0)
            text << " (continued over " << cylinder_end_facets << " facets at their ends, up to " << cylinder_end_mm
                 << " mm from them, " << cylinder_end_volume_mm3 << " mm3 between)";
        text << ", ";
    }
    if (cone_faces > 0) text << cone_faces << " cones replacing " << cone_facets << " facets, ";
    text << faces.size() - merged_faces - cylinder_faces - cone_faces << " triangles; noise " << noise_mm << " mm";
    for (const std::string& note : cylinder_notes) text << "; " << note;
    if (!refused_merges.empty())
        text << "; " << refused_merges.size() << " merge(s) undone where a face would be invalid, first: " << refused_merges.front();
    if (curved_facets_after < curved_facets_before)
        text << "; curved regions simplified from " << curved_facets_before << " to " << curved_facets_after
             << " facets within " << simplify_mm << " mm (mesh vertices at most " << simplify_deviation_mm
             << " mm from them, volume " << std::showpos << 100 * (simplified_volume_mm3 / mesh_volume_mm3 - 1)
             << std::noshowpos << " %)";
    if (!simplify_note.empty()) text << "; " << simplify_note;
    return text.str();
}

namespace {

// Planar regions found before, their vertices already moved onto them: each facet's (-1: none),
// their planes and RMS residuals.
struct GivenRegions {
    std::vector<int> of_facet;
    std::vector<Plane> planes;
    std::vector<double> rms;
};

// The faces of the solid bounded by `mesh`: its planar regions grown, or `given`.
PlanarFaceModel faces_of_mesh(const Mesh& mesh, const PlanarFaceOptions& options, const ProgressCallback& progress,
                              const GivenRegions* given = nullptr) {
    // Infinite values would pass the comparisons and let every facet fit every plane.
    if (!(options.noise_mm >= 0 && std::isfinite(options.noise_mm)))
        throw Error("noise_mm", "must be 0 (estimate) or a positive finite distance in mm");
    if (!(options.distance_factor > 0 && std::isfinite(options.distance_factor)) ||
        !(options.max_rms_factor > 0 && std::isfinite(options.max_rms_factor)))
        throw Error("distance_factor", "distance and RMS factors must be positive and finite");
    if (!(options.max_normal_deg > 0 && options.max_normal_deg < 90)) throw Error("max_normal_deg", "must be in (0, 90)");
    if (options.min_facets < 2) throw Error("min_facets", "must be at least 2");
    if (mesh.faces.empty()) throw Error("mesh", "the mesh is empty");
    auto report = [&](double fraction, const char* stage) {
        if (progress && !progress(fraction, stage)) throw Error("cancelled", "make solid was stopped");
    };

    // Join vertices at the same position (meshes whose triangles repeat their corners).
    std::vector<int> order(mesh.vertices.size()), vertex_of(mesh.vertices.size());
    std::iota(order.begin(), order.end(), 0);
    auto less = [&](int a, int b) {
        const cv::Vec3f &p = mesh.vertices[a], &q = mesh.vertices[b];
        return std::tie(p[0], p[1], p[2]) < std::tie(q[0], q[1], q[2]);
    };
    std::sort(order.begin(), order.end(), less);
    PlanarFaceModel model;
    for (size_t i = 0; i < order.size(); ++i) {
        if (i == 0 || less(order[i - 1], order[i])) model.vertices.emplace_back(mesh.vertices[order[i]]);
        vertex_of[order[i]] = int(model.vertices.size()) - 1;
    }
    const std::vector<cv::Vec3d>& positions = model.vertices;
    const int vertex_count = int(positions.size());
    // Facets with two corners at one position (collapsed by the join) bound nothing: they are left
    // out, and the facets on either side of them become neighbours.
    std::vector<cv::Vec3i> facets;
    std::vector<int> given_region;
    facets.reserve(mesh.faces.size());
    double signed_volume = 0;
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        cv::Vec3i facet;
        for (int k = 0; k < 3; ++k) {
            const int index = mesh.faces[f][k];
            if (index < 0 || index >= int(mesh.vertices.size()))
                throw Error("mesh", "facet " + std::to_string(f) + " refers to vertex " + std::to_string(index) + ", out of range");
            facet[k] = vertex_of[index];
        }
        if (facet[0] == facet[1] || facet[1] == facet[2] || facet[2] == facet[0]) continue;
        facets.push_back(facet);
        if (given) given_region.push_back(given->of_facet[f]);
        const cv::Vec3d &a = positions[facet[0]], &b = positions[facet[1]], &c = positions[facet[2]];
        signed_volume += a.dot(b.cross(c)) / 6;
    }
    const int facet_count = int(facets.size());
    if (facet_count == 0) throw Error("mesh", "every facet has two corners at one position");
    model.facet_count = size_t(facet_count);
    if (signed_volume < 0)  // facets turned inwards: turn them outwards
        for (cv::Vec3i& facet : facets) std::swap(facet[1], facet[2]);
    model.mesh_volume_mm3 = std::abs(signed_volume);

    cv::Vec3d low = positions[0], high = positions[0];
    for (const cv::Vec3d& p : positions)
        for (int k = 0; k < 3; ++k) low[k] = std::min(low[k], p[k]), high[k] = std::max(high[k], p[k]);
    const double size = cv::norm(high - low);
    std::vector<cv::Vec3d> normals(facet_count);
    size_t degenerate = 0;
    for (int f = 0; f < facet_count; ++f) {
        const cv::Vec3d &a = positions[facets[f][0]], &b = positions[facets[f][1]], &c = positions[facets[f][2]];
        const cv::Vec3d cross = (b - a).cross(c - a);
        const double length = cv::norm(cross);
        if (!(length > 1e-12 * size * size)) ++degenerate;
        normals[f] = length > 0 ? cross / length : cv::Vec3d(0, 0, 0);
    }
    if (degenerate)
        throw Error("mesh", "the mesh has " + std::to_string(degenerate) + " degenerate (zero-area) facets; repair it first");

    // Half-edge k of facet f runs from corner k to corner k+1; its twin runs back in the neighbour.
    std::vector<std::pair<uint64_t, int>> half_edges(size_t(facet_count) * 3);
    for (int f = 0; f < facet_count; ++f)
        for (int k = 0; k < 3; ++k) half_edges[f * 3 + k] = {edge_key(facets[f][k], facets[f][(k + 1) % 3]), f * 3 + k};
    std::sort(half_edges.begin(), half_edges.end());
    for (size_t i = 1; i < half_edges.size(); ++i)
        if (half_edges[i].first == half_edges[i - 1].first)
            throw Error("mesh", "an edge is run the same way by two facets: the facets are not consistently oriented, "
                                "or more than two meet at an edge (non-manifold); repair it first");
    std::vector<int> twin(half_edges.size());
    size_t border = 0;
    for (int f = 0; f < facet_count; ++f)
        for (int k = 0; k < 3; ++k) {
            const uint64_t key = edge_key(facets[f][(k + 1) % 3], facets[f][k]);
            const auto found = std::lower_bound(half_edges.begin(), half_edges.end(), std::make_pair(key, -1));
            if (found == half_edges.end() || found->first != key) {
                ++border;
                twin[f * 3 + k] = -1;
            } else {
                twin[f * 3 + k] = found->second;
            }
        }
    if (border)
        throw Error("mesh", "the mesh is not closed (" + std::to_string(border) +
                                " border edges; a single scan is a surface): close it with a Poisson mesh (which guesses"
                                " the sides no view saw: stitch views from all round first)");
    report(0.2, "solid: mesh topology");

    // The noise: across each edge, the far corner of one facet against the other facet's plane.
    // On a flat mesh with vertex noise sigma that height has a spread of about 2 sigma.
    model.noise_mm = options.noise_mm;
    if (model.noise_mm == 0) {
        std::vector<double> heights;
        heights.reserve(half_edges.size() / 2);
        for (int f = 0; f < facet_count; ++f)
            for (int k = 0; k < 3; ++k) {
                const int h = twin[f * 3 + k];
                if (h / 3 < f) continue;
                const int far_corner = facets[h / 3][(h % 3 + 2) % 3];
                heights.push_back(std::abs((positions[far_corner] - positions[facets[f][0]]).dot(normals[f])));
            }
        std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
        model.noise_mm = std::max(heights[heights.size() / 2] / 0.6745 / 2, 1e-7 * size);
    }
    const double distance_limit = options.distance_factor * model.noise_mm;
    const double rms_limit = options.max_rms_factor * model.noise_mm;
    // A boundary between two planes is straight when its vertices stray less than this from the
    // line: they carry the noise across the line as well as along the normal (2-D, so more).
    const double straight_limit = 1.5 * distance_limit;
    // A small facet's normal is only known to about 2 sigma over its shortest altitude: its
    // normal may stray from the plane's by max_normal_deg plus three times that.
    std::vector<double> min_cosine(facet_count);
    for (int f = 0; f < facet_count; ++f) {
        const cv::Vec3d &a = positions[facets[f][0]], &b = positions[facets[f][1]], &c = positions[facets[f][2]];
        const double twice_area = cv::norm((b - a).cross(c - a));
        const double longest = std::max({cv::norm(b - a), cv::norm(c - b), cv::norm(a - c)});
        const double spread_deg = 3 * std::atan(2 * model.noise_mm / (twice_area / longest)) * 180 / kPi;
        min_cosine[f] = std::cos(std::min(options.max_normal_deg + spread_deg, 80.0) * kPi / 180);
    }

    std::vector<int> region(facet_count, -1);
    std::vector<Plane> region_planes;
    std::vector<double> region_rms;
    if (given) {
        region = given_region;
        region_planes = given->planes;
        region_rms = given->rms;
    } else if (options.merge) {
        // Seeds: the flattest facets first (least normal change to their neighbours).
        std::vector<float> bend(facet_count, 0);
        for (int f = 0; f < facet_count; ++f)
            for (int k = 0; k < 3; ++k) bend[f] = std::max(bend[f], float(1 - normals[f].dot(normals[twin[f * 3 + k] / 3])));
        std::vector<int> seeds(facet_count);
        std::iota(seeds.begin(), seeds.end(), 0);
        std::stable_sort(seeds.begin(), seeds.end(), [&](int a, int b) { return bend[a] < bend[b]; });

        std::vector<int> claim(facet_count, -1), vertex_stamp(vertex_count, -1), outgoing(vertex_count, 0);
        std::vector<char> tried(facet_count, 0);
        std::vector<int> members, region_vertices, queue;
        int attempt = 0;
        for (size_t s = 0; s < seeds.size(); ++s) {
            const int seed = seeds[s];
            if (region[seed] >= 0 || tried[seed]) continue;
            ++attempt;
            members.clear();
            region_vertices.clear();
            PlaneMoments moments;
            moments.reference = positions[facets[seed][0]];
            auto take = [&](int f) {
                claim[f] = attempt;
                members.push_back(f);
                queue.push_back(f);
                for (int k = 0; k < 3; ++k) {
                    const int v = facets[f][k];
                    if (vertex_stamp[v] == attempt) continue;
                    vertex_stamp[v] = attempt;
                    region_vertices.push_back(v);
                    moments.add(positions[v]);
                }
            };
            // The first plane: through the corners of the seed's two rings of neighbours (one
            // small facet's own plane may tilt by many degrees in the noise).
            Plane plane{positions[facets[seed][0]], normals[seed]};
            {
                PlaneMoments start;
                start.reference = positions[facets[seed][0]];
                for (int k = 0; k < 3; ++k) {
                    const int near_facet = twin[seed * 3 + k] / 3;
                    for (int j = 0; j < 3; ++j) {
                        const int far_facet = twin[near_facet * 3 + j] / 3;
                        for (int c = 0; c < 3; ++c) start.add(positions[facets[far_facet][c]]);
                    }
                }
                const Plane fitted = start.plane();
                plane = {fitted.origin, fitted.normal.dot(normals[seed]) < 0 ? -fitted.normal : fitted.normal};
            }
            size_t fitted_at = 3;
            queue.clear();
            take(seed);
            for (size_t next = 0; next < queue.size(); ++next) {
                const int f = queue[next];
                for (int k = 0; k < 3; ++k) {
                    const int g = twin[f * 3 + k] / 3;
                    if (claim[g] == attempt || region[g] >= 0 || normals[g].dot(plane.normal) < min_cosine[g]) continue;
                    bool near = true;
                    for (int c = 0; c < 3 && near; ++c) near = std::abs(plane.distance(positions[facets[g][c]])) <= distance_limit;
                    if (!near) continue;
                    take(g);
                    if (moments.count >= 2 * fitted_at) {
                        const Plane fitted = moments.plane();
                        plane = {fitted.origin, fitted.normal.dot(plane.normal) < 0 ? -fitted.normal : fitted.normal};
                        fitted_at = moments.count;
                    }
                }
            }
            bool accepted = int(members.size()) >= options.min_facets;
            double rms = 0;
            if (accepted) {
                const Plane fitted = moments.plane();
                plane = {fitted.origin, fitted.normal.dot(plane.normal) < 0 ? -fitted.normal : fitted.normal};
                for (int v : region_vertices) rms += std::pow(plane.distance(positions[v]), 2);
                rms = std::sqrt(rms / double(region_vertices.size()));
                accepted = rms <= rms_limit;
            }
            // Where a region touches itself at a vertex its wire would pinch: the region's facets
            // at that vertex stay triangles, until no such vertex is left.
            for (int pass = 0; accepted && pass < 20; ++pass) {
                for (int v : region_vertices) outgoing[v] = 0;
                bool pinched = false;
                for (int f : members)
                    for (int k = 0; k < 3; ++k)
                        if (claim[twin[f * 3 + k] / 3] != attempt && ++outgoing[facets[f][k]] > 1) pinched = true;
                if (!pinched) break;
                std::vector<int> kept_members;
                for (int f : members) {
                    bool at_pinch = false;
                    for (int k = 0; k < 3; ++k) at_pinch = at_pinch || outgoing[facets[f][k]] > 1;
                    if (at_pinch) {
                        claim[f] = -1;
                        tried[f] = 1;
                    } else {
                        kept_members.push_back(f);
                    }
                }
                members.swap(kept_members);
                accepted = int(members.size()) >= options.min_facets;
            }
            if (!accepted) {
                for (int f : members) tried[f] = 1;
                continue;
            }
            const int id = int(region_planes.size());
            for (int f : members) region[f] = id;
            region_planes.push_back(plane);
            region_rms.push_back(rms);
            if (s % 4096 == 0) report(0.2 + 0.5 * double(s) / double(facet_count), "solid: planar regions");
        }
        // What a region encloses that lies in its plane joins it: the facets (left out, or smaller
        // regions of their own) that only it surrounds, all their corners near its plane (noise tipped
        // their normals, or folded a fan of narrow facets round one vertex over, which also pinches
        // the region there: the region then leaves the whole fan, and smaller regions grow in it,
        // their boundaries with it crossing). The limit grows with the region as the largest
        // of its vertices' noise does (about sigma x sqrt(2 ln n) for n vertices, here 1 sigma more:
        // a vertex of a face of 20000 that Gaussian noise alone puts beyond 4 sigma, and its fan of
        // facets, is no hole in it). Searched from each region's rim, given up at the first corner
        // off its plane.
        std::vector<double> region_facets(region_planes.size(), 0), enclosed_limit(region_planes.size());
        for (int f = 0; f < facet_count; ++f)
            if (region[f] >= 0) ++region_facets[size_t(region[f])];
        for (size_t r = 0; r < region_planes.size(); ++r) {
            const double vertices = std::max(2.0, region_facets[r] / 2);  // a triangulated surface has half as many
            enclosed_limit[r] = std::max(distance_limit, (std::sqrt(2 * std::log(vertices)) + 1) * model.noise_mm);
        }
        std::vector<int> stamp(facet_count, -1), enclosed;
        for (int f = 0; f < facet_count; ++f) {
            const int r = region[f];
            if (r < 0) continue;
            for (int k = 0; k < 3; ++k) {
                const int start = twin[f * 3 + k] / 3;
                if (region[start] == r || stamp[start] == r) continue;
                enclosed.assign(1, start);
                stamp[start] = r;
                bool in_plane = true;
                for (size_t next = 0; next < enclosed.size() && in_plane; ++next) {
                    const int g = enclosed[next];
                    for (int c = 0; c < 3 && in_plane; ++c)
                        in_plane = std::abs(region_planes[r].distance(positions[facets[g][c]])) <= enclosed_limit[size_t(r)];
                    for (int j = 0; j < 3 && in_plane; ++j) {
                        const int h = twin[g * 3 + j] / 3;
                        if (region[h] != r && stamp[h] != r) {
                            stamp[h] = r;
                            enclosed.push_back(h);
                        }
                    }
                }
                if (in_plane)
                    for (int g : enclosed) region[g] = r;
            }
        }
        // Regions wholly taken into others go.
        std::vector<int> renumbered(region_planes.size(), -1);
        std::vector<Plane> kept_planes;
        std::vector<double> kept_rms;
        for (int f = 0; f < facet_count; ++f)
            if (region[f] >= 0 && renumbered[size_t(region[f])] < 0) renumbered[size_t(region[f])] = 0;
        for (size_t r = 0; r < region_planes.size(); ++r)
            if (renumbered[r] == 0) {
                renumbered[r] = int(kept_planes.size());
                kept_planes.push_back(region_planes[r]);
                kept_rms.push_back(region_rms[r]);
            }
        for (int f = 0; f < facet_count; ++f)
            if (region[f] >= 0) region[f] = renumbered[size_t(region[f])];
        region_planes.swap(kept_planes);
        region_rms.swap(kept_rms);
    }
    report(0.7, "solid: boundaries");

    // The B-rep from the regions that are merged (region_of[f] >= 0, into `planes`): vertices
    // moved onto the planes, faces, straight edges, wires and tolerances.
    const std::vector<cv::Vec3d> joined = model.vertices;  // before any vertex moves onto a plane
    model.mesh_vertices = joined;
    auto build_faces = [&](const std::vector<int>& region_of, const std::vector<Plane>& planes, const std::vector<double>& rms) {
        model.vertices = joined;
        model.edges.clear();
        model.faces.clear();
        model.merged_facets = 0;
        // Vertices on planar regions move onto them: onto the plane, the line where two planes
        // meet, or the corner of three (the point nearest to the vertex that satisfies the planes,
        // in the least-squares sense with a heavy weight). The faces then meet exactly, without
        // gaps of the noise's size. A move longer than a few noise widths (planes meeting at a
        // glancing angle) is not made; the edges' tolerances cover that vertex instead.
        if (!planes.empty() && !given) {
            std::vector<std::vector<int>> regions_at(vertex_count);
            for (int f = 0; f < facet_count; ++f)
                if (region_of[f] >= 0)
                    for (int k = 0; k < 3; ++k) {
                        std::vector<int>& around = regions_at[facets[f][k]];
                        if (std::find(around.begin(), around.end(), region_of[f]) == around.end()) around.push_back(region_of[f]);
                    }
            const double weight = 1e8;
            for (int v = 0; v < vertex_count; ++v) {
                if (regions_at[v].empty()) continue;
                cv::Matx33d system = cv::Matx33d::eye();
                cv::Vec3d right = model.vertices[v];
                for (int r : regions_at[v]) {
                    const Plane& plane = planes[r];
                    system += weight * (plane.normal * plane.normal.t());
                    right += weight * plane.normal.dot(plane.origin) * plane.normal;
                }
                cv::Vec3d moved;
                if (!cv::solve(system, right, moved, cv::DECOMP_CHOLESKY)) continue;
                if (cv::norm(moved - model.vertices[v]) <= 3 * distance_limit) model.vertices[v] = moved;
            }
            // No move may fold a facet (turn it over, or collapse it when two of its corners go to
            // one corner of three planes): that facet's corners stay where they were.
            for (bool folded = options.check_faces; folded;) {
                folded = false;
                for (int f = 0; f < facet_count; ++f) {
                    const cv::Vec3i& c = facets[f];
                    const cv::Vec3d before = (joined[c[1]] - joined[c[0]]).cross(joined[c[2]] - joined[c[0]]);
                    const cv::Vec3d after = (positions[c[1]] - positions[c[0]]).cross(positions[c[2]] - positions[c[0]]);
                    if (after.dot(before) > 0.25 * before.dot(before)) continue;
                    for (int k = 0; k < 3; ++k)
                        if (model.vertices[c[k]] != joined[c[k]]) model.vertices[c[k]] = joined[c[k]], folded = true;
                }
            }
            for (int f = 0; f < facet_count; ++f) {
                const cv::Vec3d &a = positions[facets[f][0]], &b = positions[facets[f][1]], &c = positions[facets[f][2]];
                const cv::Vec3d cross = (b - a).cross(c - a);
                if (cv::norm(cross) > 0) normals[f] = cv::normalize(cross);
            }
        }

        // Faces: the regions, then one per remaining facet.
        const int region_count = int(planes.size());
        std::vector<int> face_of(facet_count);
        model.faces.resize(region_count);
        for (int r = 0; r < region_count; ++r) {
            model.faces[r].origin = planes[r].origin;
            model.faces[r].normal = planes[r].normal;
            model.faces[r].merged = true;
            model.faces[r].facet_count = 0;
            model.faces[r].rms_mm = rms[r];
        }
        for (int f = 0; f < facet_count; ++f) {
            if (region_of[f] >= 0) {
                face_of[f] = region_of[f];
                ++model.faces[region_of[f]].facet_count;
                model.faces[region_of[f]].triangles.push_back(facets[f]);
                ++model.merged_facets;
                continue;
            }
            face_of[f] = int(model.faces.size());
            BrepFace face;
            face.origin = positions[facets[f][0]];
            face.normal = normals[f];
            face.triangles.push_back(facets[f]);
            model.faces.push_back(face);
        }
        model.merged_faces = size_t(region_count);
        // A vertex stays a B-rep vertex when a triangle uses it or three or more faces meet there;
        // between two planar faces the boundary runs straight through it.
        std::vector<int> first_face(vertex_count, -1), second_face(vertex_count, -1);
        std::vector<char> kept(vertex_count, 0);
        for (int f = 0; f < facet_count; ++f)
            for (int k = 0; k < 3; ++k) {
                const int v = facets[f][k], face = face_of[f];
                if (face >= region_count) kept[v] = 1;
                if (first_face[v] < 0 || first_face[v] == face) first_face[v] = face;
                else if (second_face[v] < 0 || second_face[v] == face) second_face[v] = face;
                else kept[v] = 1;
            }

        // Boundary half-edges (their two facets on different faces), by start vertex.
        std::vector<int> boundary_start(vertex_count + 1, 0), boundary;
        auto on_boundary = [&](int h) { return face_of[h / 3] != face_of[twin[h] / 3]; };
        for (int h = 0; h < 3 * facet_count; ++h)
            if (on_boundary(h)) ++boundary_start[facets[h / 3][h % 3] + 1];
        for (int v = 0; v < vertex_count; ++v) boundary_start[v + 1] += boundary_start[v];
        boundary.resize(boundary_start[vertex_count]);
        {
            std::vector<int> fill(boundary_start.begin(), boundary_start.end() - 1);
            for (int h = 0; h < 3 * facet_count; ++h)
                if (on_boundary(h)) boundary[fill[facets[h / 3][h % 3]]++] = h;
        }
        auto head = [&](int h) { return facets[h / 3][(h % 3 + 1) % 3]; };
        auto next_on_face = [&](int h) {  // the boundary half-edge of the same face leaving h's head
            const int v = head(h), face = face_of[h / 3];
            for (int i = boundary_start[v]; i < boundary_start[v + 1]; ++i)
                if (face_of[boundary[i] / 3] == face) return boundary[i];
            throw Error("mesh", "internal: a face's boundary is broken at vertex " + std::to_string(v));
        };

        // Chains of boundary half-edges between kept vertices become straight edges.
        struct Piece {
            int start, end;
            std::vector<int> edges;  // signed references
        };
        std::vector<std::vector<Piece>> pieces(model.faces.size());
        std::vector<char> visited(size_t(3 * facet_count), 0);
        std::vector<int> chain, chain_edges;
        auto emit_chain = [&](const std::vector<int>& vertices, int owner, int other) {
            // vertices: the chain as run by `owner`'s boundary; split closed or self-ending chains in three.
            std::vector<size_t> breaks{0};
            const size_t last = vertices.size() - 1;
            if (vertices.front() == vertices.back()) breaks.push_back(last / 3), breaks.push_back(2 * last / 3);
            breaks.push_back(last);
            std::vector<size_t> kept_points;
            for (size_t b = 0; b + 1 < breaks.size(); ++b) {
                kept_points.push_back(breaks[b]);
                douglas_peucker(positions, vertices, breaks[b], breaks[b + 1], straight_limit, kept_points);
            }
            kept_points.push_back(last);
            chain_edges.clear();
            for (size_t i = 0; i + 1 < kept_points.size(); ++i) {
                const auto from = vertices.begin() + std::ptrdiff_t(kept_points[i]);
                const auto to = vertices.begin() + std::ptrdiff_t(kept_points[i + 1]) + 1;
                model.edges.push_back({*from, *(to - 1), 1e-7, std::vector<int>(from, to)});
                chain_edges.push_back(int(model.edges.size()));
            }
            pieces[owner].push_back({vertices.front(), vertices.back(), chain_edges});
            std::vector<int> reversed(chain_edges.rbegin(), chain_edges.rend());
            for (int& e : reversed) e = -e;
            pieces[other].push_back({vertices.back(), vertices.front(), reversed});
        };
        auto walk = [&](int h) {
            chain.assign(1, facets[h / 3][h % 3]);
            const int owner = face_of[h / 3], other = face_of[twin[h] / 3];
            for (;;) {
                visited[h] = visited[twin[h]] = 1;
                chain.push_back(head(h));
                if (kept[head(h)] || head(h) == chain.front()) break;
                h = next_on_face(h);
            }
            emit_chain(chain, owner, other);
        };
        for (int v = 0; v < vertex_count; ++v)
            if (kept[v])
                for (int i = boundary_start[v]; i < boundary_start[v + 1]; ++i)
                    if (!visited[boundary[i]]) walk(boundary[i]);
        for (int h = 0; h < 3 * facet_count; ++h)  // closed boundaries between two planar faces only
            if (on_boundary(h) && !visited[h]) walk(h);
        report(0.85, "solid: wires");

        // Wires: each face's pieces joined end to start; a merged face's outer loop first.
        for (size_t face = 0; face < model.faces.size(); ++face) {
            std::vector<Piece>& own = pieces[face];
            std::unordered_map<int, int> piece_at;
            for (size_t i = 0; i < own.size(); ++i) piece_at[own[i].start] = int(i);
            std::vector<char> used(own.size(), 0);
            std::vector<double> areas;
            for (size_t i = 0; i < own.size(); ++i) {
                if (used[i]) continue;
                std::vector<int> wire;
                cv::Vec3d area(0, 0, 0);
                for (size_t p = i; !used[p];) {
                    used[p] = 1;
                    for (int e : own[p].edges) {
                        wire.push_back(e);
                        const BrepEdge& edge = model.edges[std::abs(e) - 1];
                        const cv::Vec3d &a = positions[e > 0 ? edge.start : edge.end], &b = positions[e > 0 ? edge.end : edge.start];
                        area += a.cross(b);
                    }
                    const auto found = piece_at.find(own[p].end);
                    if (found == piece_at.end()) throw Error("mesh", "internal: a face's boundary does not close");
                    p = size_t(found->second);
                }
                model.faces[face].wires.push_back(wire);
                areas.push_back(area.dot(model.faces[face].normal));
            }
            const size_t outer = size_t(std::max_element(areas.begin(), areas.end()) - areas.begin());
            std::swap(model.faces[face].wires[0], model.faces[face].wires[outer]);
        }

        // Tolerances: how far each straight edge's ends are from the planes of the faces along it.
        std::vector<std::vector<int>> faces_of_edge(model.edges.size());
        for (size_t face = 0; face < model.faces.size(); ++face)
            for (const auto& wire : model.faces[face].wires)
                for (int e : wire) faces_of_edge[std::abs(e) - 1].push_back(int(face));
        model.vertex_tolerance_mm.assign(vertex_count, 1e-7);
        for (size_t e = 0; e < model.edges.size(); ++e) {
            BrepEdge& edge = model.edges[e];
            double distance = 0;
            for (int face : faces_of_edge[e]) {
                const Plane plane{model.faces[face].origin, model.faces[face].normal};
                distance = std::max({distance, std::abs(plane.distance(positions[edge.start])),
                                     std::abs(plane.distance(positions[edge.end]))});
            }
            edge.tolerance_mm = distance * 1.01 + 1e-7;
            for (int v : {edge.start, edge.end})
                model.vertex_tolerance_mm[v] = std::max(model.vertex_tolerance_mm[v], edge.tolerance_mm);
        }
    };

    // Each merged face is checked once its wires are built. Where one would not be a valid B-rep
    // face, the region's facets at the defect become triangles (a sliver, a pinch, a crossing are
    // local), or the whole region when the defect is not local, persists, or leaves too few facets;
    // then the faces are built again. Each case is reported.
    std::vector<char> refused(region_planes.size(), 0);
    const int local_rounds = 8;
    std::vector<char> at_defect(vertex_count, 0);
    for (int round = 0;; ++round) {
        std::vector<int> source;  // the regions still merged
        std::vector<int> renumbered(region_planes.size(), -1), region_of(facet_count, -1);
        std::vector<Plane> planes;
        std::vector<double> rms;
        for (size_t r = 0; r < region_planes.size(); ++r)
            if (!refused[r]) {
                renumbered[r] = int(source.size());
                source.push_back(int(r));
                planes.push_back(region_planes[r]);
                rms.push_back(region_rms[r]);
            }
        for (int f = 0; f < facet_count; ++f)
            if (region[f] >= 0) region_of[f] = renumbered[region[f]];
        build_faces(region_of, planes, rms);
        if (!options.check_faces) break;
        bool any = false;
        const FaceLimits limits = face_limits(model, options);
        for (size_t r = 0; r < source.size(); ++r) {
            const FaceDefect defect = merged_face_defect(model, model.faces[r], limits);
            if (defect.reason.empty()) continue;
            any = true;
            const int id = source[r];
            const std::string plane = "the plane of " + std::to_string(model.faces[r].facet_count) + " facets at " +
                                      point_text(model.faces[r].origin) + " mm";
            int trimmed = 0;
            if (round < local_rounds && !defect.vertices.empty()) {
                for (int v : defect.vertices) at_defect[v] = 1;
                for (int f = 0; f < facet_count; ++f)
                    if (region[f] == id && (at_defect[facets[f][0]] || at_defect[facets[f][1]] || at_defect[facets[f][2]]))
                        region[f] = -1, ++trimmed;
                for (int v : defect.vertices) at_defect[v] = 0;
            }
            if (trimmed > 0 && model.faces[r].facet_count - trimmed >= options.min_facets) {
                model.refused_merges.push_back(std::to_string(trimmed) + " facets of " + plane + " stay triangles: " + defect.reason);
            } else {
                refused[size_t(id)] = 1;
                model.refused_merges.push_back(plane + " stays triangles: " + defect.reason);
            }
        }
        if (!any) break;
    }
    report(1.0, "solid: faces");
    return model;
}

}  // namespace

PlanarFaceModel planar_face_model(const Mesh& mesh, const PlanarFaceOptions& options, const ProgressCallback& progress) {
    if (!(options.simplify_mm >= 0 && std::isfinite(options.simplify_mm)))
        throw Error("simplify_mm", "must be 0 (from the noise) or a positive finite distance in mm");
    if (!(options.simplify_max_volume_change >= 0)) throw Error("simplify_max_volume_change", "must be 0 or positive");
    const bool simplify = options.merge && options.simplify;
    auto share = [&](double from, double to) -> ProgressCallback {
        if (!progress) return nullptr;
        return [=](double fraction, const std::string& stage) { return progress(from + (to - from) * fraction, stage); };
    };
    PlanarFaceModel model = faces_of_mesh(mesh, options, share(0, simplify ? 0.3 : 1));
    // Cylinders are found on the mesh's own facets (its vertices carry the scan's noise, which
    // their fit is held to), then made once the rest is simplified.
    std::vector<detail::CylinderRegion> cylinders;
    if (options.merge && options.cylinders) cylinders = detail::cylinder_regions(model, options, {}, model.cylinder_notes);
    if (!simplify) {
        detail::add_cylinder_faces(model, cylinders);
        return model;
    }

    // The facets of planar faces and cylinders stay, and so do their vertices; the others are simplified.
    std::vector<char> on_cylinder(model.faces.size(), 0);
    for (const detail::CylinderRegion& region : cylinders)
        for (size_t f : region.faces) on_cylinder[f] = 1;
    std::vector<cv::Vec3i> kept, curved;
    std::vector<char> fixed(model.vertices.size(), 0);
    for (size_t f = 0; f < model.faces.size(); ++f) {
        const BrepFace& face = model.faces[f];
        const bool keep = face.merged || on_cylinder[f];
        for (const cv::Vec3i& facet : face.triangles) {
            (keep ? kept : curved).push_back(facet);
            if (keep)
                for (int k = 0; k < 3; ++k) fixed[size_t(facet[k])] = 1;
        }
    }
    const double tolerance = options.simplify_mm > 0 ? options.simplify_mm : options.distance_factor * model.noise_mm;
    const detail::SimplifiedSurface simplified =
        detail::simplify_surface(model.vertices, curved, kept, fixed, tolerance, share(0.3, 0.9));
    if (simplified.facets.size() >= curved.size()) {
        model.curved_facets_before = model.curved_facets_after = curved.size();
        model.simplify_mm = tolerance;
        model.simplified_volume_mm3 = model.mesh_volume_mm3;
        detail::add_cylinder_faces(model, cylinders);
        return model;
    }

    // The faces again, of the planar regions as they were and the simplified facets (larger
    // curved facets, a few noise widths from flat, must not grow into planes that pull their
    // corners off the surface).
    Mesh smaller;
    for (const cv::Vec3d& p : simplified.vertices) smaller.vertices.emplace_back(p);
    GivenRegions regions;
    for (size_t r = 0; r < model.merged_faces; ++r) {
        const BrepFace& face = model.faces[r];
        smaller.faces.insert(smaller.faces.end(), face.triangles.begin(), face.triangles.end());
        regions.of_facet.insert(regions.of_facet.end(), face.triangles.size(), int(r));
        regions.planes.push_back({face.origin, face.normal});
        regions.rms.push_back(face.rms_mm);
    }
    for (size_t f = 0; f < model.faces.size(); ++f)
        if (on_cylinder[f] && !model.faces[f].merged) smaller.faces.push_back(model.faces[f].triangles[0]);
    smaller.faces.insert(smaller.faces.end(), simplified.facets.begin(), simplified.facets.end());
    regions.of_facet.resize(smaller.faces.size(), -1);
    PlanarFaceOptions again = options;
    again.noise_mm = model.noise_mm;  // the simplified facets are not the scan's: its noise stays
    PlanarFaceModel result = faces_of_mesh(smaller, again, share(0.9, 1), &regions);
    result.curved_facets_before = curved.size();
    result.curved_facets_after = simplified.facets.size();
    result.simplify_mm = tolerance;
    result.simplify_deviation_mm = simplified.max_deviation_mm;
    result.simplified_volume_mm3 = result.mesh_volume_mm3;
    result.mesh_volume_mm3 = model.mesh_volume_mm3;
    result.refused_merges.insert(result.refused_merges.begin(), model.refused_merges.begin(), model.refused_merges.end());
    // The simplification keeps the volume at each step (only collapses into a fixed vertex do not):
    // a larger change than allowed, and the curved facets stay as they were.
    const double change = result.simplified_volume_mm3 / model.mesh_volume_mm3 - 1;
    if (std::abs(change) > options.simplify_max_volume_change) {
        char text[160];
        std::snprintf(text, sizeof text, "curved regions not simplified: the volume would change by %+.4f %% (at most %.4f %%)",
                      100 * change, 100 * options.simplify_max_volume_change);
        model.curved_facets_before = model.curved_facets_after = curved.size();
        model.simplify_mm = tolerance;
        model.simplified_volume_mm3 = model.mesh_volume_mm3;
        model.simplify_note = text;
        detail::add_cylinder_faces(model, cylinders);
        return model;
    }
    // The cylinders' facets came through unchanged (their vertices fixed, positions rounded to the
    // mesh's floats): found again among them alone, on the faces built from the simplified mesh.
    using FacetKey = std::array<float, 9>;
    auto key_of = [](const std::vector<cv::Vec3d>& vertices, const cv::Vec3i& facet) {
        std::array<cv::Vec3f, 3> corners{cv::Vec3f(vertices[size_t(facet[0])]), cv::Vec3f(vertices[size_t(facet[1])]),
                                          cv::Vec3f(vertices[size_t(facet[2])])};
        std::sort(corners.begin(), corners.end(),
                  [](const cv::Vec3f& p, const cv::Vec3f& q) { return std::tie(p[0], p[1], p[2]) < std::tie(q[0], q[1], q[2]); });
        FacetKey key;
        for (int k = 0; k < 9; ++k) key[size_t(k)] = corners[size_t(k / 3)][k % 3];
        return key;
    };
    std::set<FacetKey> cylinder_facets;
    for (const detail::CylinderRegion& region : cylinders)
        for (size_t f : region.faces)
            for (const cv::Vec3i& facet : model.faces[f].triangles) cylinder_facets.insert(key_of(model.vertices, facet));
    std::vector<char> eligible(result.faces.size(), 0);
    for (size_t f = 0; f < result.faces.size(); ++f) {
        const auto& facets = result.faces[f].triangles;
        eligible[f] = !facets.empty() && std::all_of(facets.begin(), facets.end(), [&](const cv::Vec3i& facet) {
            return cylinder_facets.count(key_of(result.vertices, facet)) > 0;
        });
    }
    result.cylinder_notes = model.cylinder_notes;
    if (!cylinders.empty())
        detail::add_cylinder_faces(result, detail::cylinder_regions(result, again, eligible, result.cylinder_notes));
    return result;
}

namespace {

// A planar face with a circle in its wires (a cylinder's end): its loops are not polygons.
bool bounded_by_circle(const PlanarFaceModel& model, const BrepFace& face) {
    for (const auto& wire : face.wires)
        for (int e : wire)
            if (model.edges[size_t(std::abs(e) - 1)].radius_mm > 0) return true;
    return false;
}

}  // namespace

std::vector<std::string> merged_face_defects(const PlanarFaceModel& model, const PlanarFaceOptions& options) {
    std::vector<std::string> defects;
    const FaceLimits limits = face_limits(model, options);
    for (size_t f = 0; f < model.faces.size(); ++f) {
        if (!model.faces[f].merged || bounded_by_circle(model, model.faces[f])) continue;
        const FaceDefect defect = merged_face_defect(model, model.faces[f], limits);
        if (!defect.reason.empty()) defects.push_back("face " + std::to_string(f) + ": " + defect.reason);
    }
    return defects;
}

}  // namespace picoscan
