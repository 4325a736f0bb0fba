// Curved regions of a solid in fewer, larger triangles: CGAL's edge collapse (Lindstrom and Turk,
// "Fast and memory efficient polygonal simplification", 1998: each new vertex keeps the volume),
// each collapse allowed only while the input's vertices stay within the tolerance of the facets.
// (CGAL's polyhedral envelope filter bounds the other way round exactly, but took 390 s for
// 89 000 facets.)
#include "solid/simplify_surface.h"

#include "mesh/cgal_types.h"
#include "picoscan/error.h"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <unordered_set>
#include <tuple>

namespace picoscan::detail {

namespace {

namespace SMS = CGAL::Surface_mesh_simplification;
using Vertex = SurfaceMesh::Vertex_index;
using Face = SurfaceMesh::Face_index;
using IndexMap = SurfaceMesh::Property_map<Vertex, int>;
using FixedMap = SurfaceMesh::Property_map<Vertex, bool>;
using PointsMap = SurfaceMesh::Property_map<Face, std::vector<int>>;
using NormalMap = SurfaceMesh::Property_map<Vertex, Kernel::Vector_3>;

// What the collapses share: each input vertex (its point) belongs to one current facet within
// the tolerance of it; a collapse is allowed only while every point of the facets it changes stays
// within the tolerance of one of the facets it leaves (Cohen, Manocha and Olano's idea of tracking
// the surface a simplified facet stands for, with the input's vertices as the samples). So every
// input vertex stays within the tolerance of the simplified surface.
struct Tracking {
    SurfaceMesh* mesh;
    std::vector<Point3> points;  // the input's vertices (the soup's)
    IndexMap original;           // each mesh vertex: the input vertex it stands for
    FixedMap fixed;
    PointsMap owned;             // each facet: its points
    NormalMap normal;            // each mesh vertex: the input's normal there (its facets' summed)
    double tolerance2;
    std::unordered_set<uint64_t> outside_edges;  // edges of the facets that stay (input vertex pairs)
    std::vector<Face> changing{};  // the facets around the edge being collapsed
};

std::vector<Face> faces_around(const SurfaceMesh& mesh, Vertex a, Vertex b) {
    std::vector<Face> around;
    for (Vertex v : {a, b})
        for (Face f : CGAL::faces_around_target(mesh.halfedge(v), mesh))
            if (f != SurfaceMesh::null_face() && std::find(around.begin(), around.end(), f) == around.end()) around.push_back(f);
    return around;
}

Kernel::Triangle_3 triangle_of(const SurfaceMesh& mesh, Face f) {
    const auto h = mesh.halfedge(f);
    return {mesh.point(mesh.source(h)), mesh.point(mesh.target(h)), mesh.point(mesh.target(mesh.next(h)))};
}

struct NewFacet {
    Face face;
    Kernel::Triangle_3 triangle;
};

// The facets around a and b once a and b are one vertex at `place` (the two on edge ab go).
std::vector<NewFacet> after_collapse(const SurfaceMesh& mesh, Vertex a, Vertex b, const Point3& place) {
    std::vector<NewFacet> facets;
    for (Face f : faces_around(mesh, a, b)) {
        std::array<Point3, 3> corners;
        int moved = 0, k = 0;
        for (Vertex v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
            const bool goes = v == a || v == b;
            moved += goes;
            corners[size_t(k++)] = goes ? place : mesh.point(v);
        }
        if (moved == 1) facets.push_back({f, Kernel::Triangle_3(corners[0], corners[1], corners[2])});
    }
    return facets;
}

double distance2(const Point3& p, const Kernel::Triangle_3& t) { return CGAL::to_double(CGAL::squared_distance(p, t)); }

// The facet of `facets` that point p of facet `owner` goes to: its owner's new shape when that
// is near enough, else the first near enough, else none.
const NewFacet* home(const Tracking& tracking, const std::vector<NewFacet>& facets, Face owner, const Point3& p) {
    for (const NewFacet& facet : facets)
        if (facet.face == owner && distance2(p, facet.triangle) <= tracking.tolerance2) return &facet;
    for (const NewFacet& facet : facets)
        if (distance2(p, facet.triangle) <= tracking.tolerance2) return &facet;
    return nullptr;
}

// A fixed vertex stays where it is: an edge between two is not collapsed, an edge with one goes
// into it; otherwise Lindstrom-Turk's placement (which keeps the enclosed volume).
struct KeepFixed {
    const Tracking* tracking;
    SMS::LindstromTurk_placement<SurfaceMesh> base{};
    template <typename Profile>
    boost::optional<typename Profile::Point> operator()(const Profile& profile) const {
        const bool first = tracking->fixed[profile.v0()], second = tracking->fixed[profile.v1()];
        if (first && second) return boost::none;
        if (first) return profile.p0();
        if (second) return profile.p1();
        return base(profile);
    }
};

uint64_t edge_key(int a, int b) { return (uint64_t(uint32_t(std::min(a, b))) << 32) | uint32_t(std::max(a, b)); }

// Refuses a collapse that would join two fixed vertices already joined by an edge outside the
// simplified facets (the closed surface would then have that edge three times), turn a facet over
// (CGAL's own check looks only at neighbouring facets' angles), or leave a point of the changed
// facets, or the new vertex itself, farther than the tolerance from the facets.
struct WithinTolerance {
    const Tracking* tracking;
    template <typename Profile>
    boost::optional<typename Profile::Point> operator()(const Profile& profile, boost::optional<typename Profile::Point> place) const {
        if (!place) return place;
        const SurfaceMesh& mesh = *tracking->mesh;
        if (tracking->fixed[profile.v0()] || tracking->fixed[profile.v1()]) {
            const Vertex stays = tracking->fixed[profile.v0()] ? profile.v0() : profile.v1();
            const Vertex goes = stays == profile.v0() ? profile.v1() : profile.v0();
            for (Vertex w : CGAL::vertices_around_target(mesh.halfedge(goes), mesh))
                if (w != stays && tracking->fixed[w] &&
                    tracking->outside_edges.count(edge_key(tracking->original[stays], tracking->original[w])))
                    return boost::none;
        }
        bool near = false;  // the new vertex: near the facets there now
        for (Face f : faces_around(mesh, profile.v0(), profile.v1()))
            near = near || distance2(*place, triangle_of(mesh, f)) <= tracking->tolerance2;
        if (!near) return boost::none;
        const std::vector<NewFacet> after = after_collapse(mesh, profile.v0(), profile.v1(), *place);
        // No facet turns by more than 75 degrees at once (over, or onto its edge), nor ends up facing
        // away from the input's normal at its corners (turned over step by step).
        for (const NewFacet& facet : after) {
            const Kernel::Vector_3 was = triangle_of(mesh, facet.face).supporting_plane().orthogonal_vector(),
                                   now = facet.triangle.supporting_plane().orthogonal_vector();
            if (!(CGAL::to_double(was * now) > 0.25 * std::sqrt(CGAL::to_double(was.squared_length() * now.squared_length()))))
                return boost::none;
            for (Vertex v : CGAL::vertices_around_face(mesh.halfedge(facet.face), mesh))
                if (!(CGAL::to_double(tracking->normal[v] * now) > 0)) return boost::none;
        }
        for (Face f : faces_around(mesh, profile.v0(), profile.v1()))
            for (int p : tracking->owned[f])
                if (!home(*tracking, after, f, tracking->points[size_t(p)])) return boost::none;
        return place;
    }
};

// After a collapse: the vertex kept takes over the place (and fixedness) of the one that went when
// that one was fixed; the points of the changed facets stay with their facet while it is near
// enough, else go to one that is.
struct Reassign : SMS::Edge_collapse_visitor_base<SurfaceMesh> {
    Tracking* tracking;
    explicit Reassign(Tracking* tracking_) : tracking(tracking_) {}
    template <typename Profile>
    void OnCollapsing(const Profile& profile, const boost::optional<Point3>&) {
        tracking->changing = faces_around(*tracking->mesh, profile.v0(), profile.v1());
    }
    template <typename Profile>
    void OnCollapsed(const Profile& profile, Vertex kept) {
        Tracking& t = *tracking;
        for (Vertex v : {profile.v0(), profile.v1()})
            if (v != kept && t.fixed[v]) t.original[kept] = t.original[v], t.fixed[kept] = true;
        t.normal[kept] = t.normal[profile.v0()] + t.normal[profile.v1()];
        std::vector<NewFacet> left;  // the facets around the kept vertex
        for (Face f : CGAL::faces_around_target(t.mesh->halfedge(kept), *t.mesh)) {
            if (f != SurfaceMesh::null_face()) left.push_back({f, triangle_of(*t.mesh, f)});
        }
        std::vector<std::pair<Face, int>> moves;
        for (Face f : t.changing) {
            std::vector<int> stay;
            for (int p : t.owned[f]) {
                const NewFacet* to = home(t, left, f, t.points[size_t(p)]);
                if (to && to->face == f) stay.push_back(p);
                else moves.emplace_back(to ? to->face : left.front().face, p);  // none: the filter let none through
            }
            t.owned[f].swap(stay);
        }
        for (const auto& [f, p] : moves) t.owned[f].push_back(p);
    }
};

// Never stops the collapses (they end when none is allowed) but when the caller cancels; tells the
// caller every 1024 edges looked at.
struct UntilCancelled {
    const ProgressCallback* progress;
    bool* cancelled;
    mutable size_t calls = 0;
    template <typename Cost, typename Profile, typename Count>
    bool operator()(const Cost&, const Profile&, Count initial, Count current) const {
        if (!*progress || ++calls % 1024 != 0) return false;
        const double done = 1 - double(current) / double(std::max<Count>(initial, 1));
        *cancelled = !(*progress)(done, "solid: simplifying curved regions");
        return *cancelled;
    }
};

}  // namespace

SimplifiedSurface simplify_surface(const std::vector<cv::Vec3d>& vertices, const std::vector<cv::Vec3i>& facets,
                                   const std::vector<cv::Vec3i>& others, const std::vector<char>& fixed, double tolerance_mm,
                                   const ProgressCallback& progress) {
    SimplifiedSurface result{vertices, facets, 0};
    if (facets.empty()) return result;
    // The facets as a polygon soup of the vertices they use; CGAL's orientation pass duplicates a
    // vertex where two fans of facets only touch (a surface must be manifold there).
    std::vector<int> soup_index(vertices.size(), -1), original;
    std::vector<Point3> points;
    std::vector<std::array<size_t, 3>> polygons;
    for (const cv::Vec3i& facet : facets) {
        std::array<size_t, 3> polygon{};
        for (int k = 0; k < 3; ++k) {
            int& index = soup_index[size_t(facet[k])];
            if (index < 0) {
                index = int(points.size());
                const cv::Vec3d& p = vertices[size_t(facet[k])];
                points.emplace_back(p[0], p[1], p[2]);
                original.push_back(facet[k]);
            }
            polygon[size_t(k)] = size_t(index);
        }
        polygons.push_back(polygon);
    }
    const size_t distinct = points.size();
    CGAL::Polygon_mesh_processing::orient_polygon_soup(points, polygons);
    if (polygons.size() != facets.size()) return result;
    std::map<std::tuple<double, double, double>, int> at_position;
    if (points.size() > distinct)
        for (size_t i = 0; i < distinct; ++i) at_position[{points[i].x(), points[i].y(), points[i].z()}] = original[i];
    for (size_t i = distinct; i < points.size(); ++i) {  // duplicates: the vertex at their position
        const auto found = at_position.find({points[i].x(), points[i].y(), points[i].z()});
        if (found == at_position.end()) return result;
        original.push_back(found->second);
    }
    for (size_t f = 0; f < polygons.size(); ++f)  // the input is oriented: nothing may have turned
        for (int k = 0; k < 3; ++k)
            if (original[polygons[f][size_t(k)]] != facets[f][k]) return result;

    SurfaceMesh mesh;
    IndexMap index = mesh.add_property_map<Vertex, int>("v:picoscan_original", -1).first;
    FixedMap is_fixed = mesh.add_property_map<Vertex, bool>("v:picoscan_fixed", false).first;
    PointsMap owned = mesh.add_property_map<Face, std::vector<int>>("f:picoscan_points").first;
    NormalMap normal = mesh.add_property_map<Vertex, Kernel::Vector_3>("v:picoscan_normal", CGAL::NULL_VECTOR).first;
    std::vector<char> split(vertices.size(), 0);
    for (size_t i = distinct; i < points.size(); ++i) split[size_t(original[i])] = 1;
    std::vector<Vertex> added;
    for (size_t i = 0; i < points.size(); ++i) {
        added.push_back(mesh.add_vertex(points[i]));
        index[added.back()] = original[i];
        // A vertex split in two fans: neither copy may move apart from the other.
        is_fixed[added.back()] = fixed[size_t(original[i])] || split[size_t(original[i])];
    }
    std::vector<char> assigned(points.size(), 0);
    for (const auto& polygon : polygons) {
        const Face f = mesh.add_face(added[polygon[0]], added[polygon[1]], added[polygon[2]]);
        if (f == SurfaceMesh::null_face()) return result;
        const Kernel::Vector_3 n = triangle_of(mesh, f).supporting_plane().orthogonal_vector();
        for (size_t p : polygon) {
            if (!assigned[p]) assigned[p] = 1, owned[f].push_back(int(p));
            normal[added[p]] = normal[added[p]] + n;
        }
    }

    Tracking tracking{&mesh, points, index, is_fixed, owned, normal, tolerance_mm * tolerance_mm, {}};
    for (const cv::Vec3i& facet : others)
        for (int k = 0; k < 3; ++k) tracking.outside_edges.insert(edge_key(facet[k], facet[(k + 1) % 3]));
    bool cancelled = false;
    SMS::edge_collapse(mesh, UntilCancelled{&progress, &cancelled},
                       CGAL::parameters::get_cost(SMS::LindstromTurk_cost<SurfaceMesh>())
                           .get_placement(KeepFixed{&tracking})
                           .filter(WithinTolerance{&tracking})
                           .visitor(Reassign(&tracking)));
    if (cancelled) throw Error("cancelled", "make solid was stopped");

    result.facets.clear();
    for (Vertex v : mesh.vertices()) {
        const Point3& p = mesh.point(v);
        result.vertices[size_t(index[v])] = cv::Vec3d(p.x(), p.y(), p.z());
    }
    for (SurfaceMesh::Face_index f : mesh.faces()) {
        cv::Vec3i facet;
        int k = 0;
        for (Vertex v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) facet[k++] = index[v];
        result.facets.push_back(facet);
    }
    // How far the input's vertices ended up from the simplified facets (the envelope bounds only
    // the other way round).
    using Primitive = CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>;
    using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
    const Tree tree(faces(mesh).first, faces(mesh).second, mesh);
    double farthest2 = 0;
    for (size_t i = 0; i < distinct; ++i) farthest2 = std::max(farthest2, tree.squared_distance(points[i]));
    result.max_deviation_mm = std::sqrt(farthest2);
    return result;
}

}  // namespace picoscan::detail
