// Mesh repair and checks: small-hole filling (Liepa 2003: triangulate, refine, fair),
// edge-collapse simplification (Lindstrom-Turk) that never makes the surface cross itself,
// and the topology check before export.
#define CGAL_EIGEN3_ENABLED 1
#include "mesh/cgal_types.h"
#include "picoscan/error.h"
#include "picoscan/mesh.h"

#include <CGAL/Box_intersection_d/Box_with_info_d.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/clip.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Bounded_normal_change_filter.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>
#include <CGAL/squared_distance_3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <set>
#include <unordered_map>

namespace picoscan {

namespace detail {

double height_over_longest_edge(const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c) {
    const double longest = std::max({cv::norm(b - a), cv::norm(c - b), cv::norm(a - c)});
    // The cross product's length is twice the area: the longest edge times its height.
    return longest > 0 ? cv::norm((b - a).cross(c - a)) / (longest * longest) : 0.0;
}

bool is_sliver(const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c) {
    return !(height_over_longest_edge(a, b, c) >= 1e-4);
}

namespace {

// Pairs of a sliver and a face it shares no corner with that come within float noise of each
// other (8 to 16 units in the last place of the float coordinates; FreeCAD's check found a
// sliver 1e-7 mm off another face's edge at 1 mm from the origin, not 1e-6 mm). A
// sliver is about its longest edge: the nearest points of that segment and a triangle are an
// end of the segment and the triangle, or the segment and an edge of the triangle, or the
// segment passes through the triangle.
void add_touching_slivers(const Mesh& mesh, std::vector<int>& faces) {
    auto corner = [&](int f, int k) { return cv::Vec3d(mesh.vertices[mesh.faces[f][k]]); };
    auto point = [](const cv::Vec3d& x) { return Point3(x[0], x[1], x[2]); };
    using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, int>;
    std::vector<Box> slivers, all;
    std::vector<double> reach(mesh.faces.size(), 0);
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        const int face = static_cast<int>(f);
        const cv::Vec3d a = corner(face, 0), b = corner(face, 1), c = corner(face, 2);
        CGAL::Bbox_3 box = point(a).bbox() + point(b).bbox() + point(c).bbox();
        all.emplace_back(box, face);
        if (!is_sliver(a, b, c)) continue;
        const double largest = std::max({cv::norm(a, cv::NORM_INF), cv::norm(b, cv::NORM_INF), cv::norm(c, cv::NORM_INF)});
        reach[f] = std::ldexp(largest, -20);
        box.dilate(1);  // ulps, then the reach
        slivers.emplace_back(CGAL::Bbox_3(box.xmin() - reach[f], box.ymin() - reach[f], box.zmin() - reach[f],
                                          box.xmax() + reach[f], box.ymax() + reach[f], box.zmax() + reach[f]),
                             face);
    }
    if (slivers.empty()) return;
    auto test = [&](const Box& sliver_box, const Box& other_box) {
        const int s = sliver_box.info(), o = other_box.info();
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                if (mesh.faces[s][i] == mesh.faces[o][j]) return;
        // The sliver's longest edge.
        int k = 0;
        for (int e = 1; e < 3; ++e)
            if (cv::norm(corner(s, (e + 1) % 3) - corner(s, e)) > cv::norm(corner(s, (k + 1) % 3) - corner(s, k))) k = e;
        const Kernel::Segment_3 segment(point(corner(s, k)), point(corner(s, (k + 1) % 3)));
        const Kernel::Triangle_3 triangle(point(corner(o, 0)), point(corner(o, 1)), point(corner(o, 2)));
        const double near = reach[s] * reach[s];
        bool touching = !triangle.is_degenerate() && !segment.is_degenerate() && CGAL::do_intersect(segment, triangle);
        for (int i = 0; i < 3 && !touching; ++i) {
            touching = (!triangle.is_degenerate() && CGAL::squared_distance(point(corner(s, i)), triangle) < near) ||
                       CGAL::squared_distance(segment, Kernel::Segment_3(point(corner(o, i)), point(corner(o, (i + 1) % 3)))) < near;
        }
        if (touching) {
            faces.push_back(s);
            faces.push_back(o);
        }
    };
    CGAL::box_intersection_d(slivers.begin(), slivers.end(), all.begin(), all.end(), test);
}

}  // namespace

std::vector<int> self_intersecting_faces(const Mesh& mesh) {
    const SurfaceMesh surface = to_surface_mesh(mesh);
    std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> pairs;
    CGAL::Polygon_mesh_processing::self_intersections(surface, std::back_inserter(pairs));
    std::vector<int> faces;
    for (const auto& [a, b] : pairs) {
        faces.push_back(static_cast<int>(a));
        faces.push_back(static_cast<int>(b));
    }
    add_touching_slivers(mesh, faces);
    return faces;
}

Mesh fill_small_holes(const Mesh& mesh, double max_hole_diameter_mm) {
    SurfaceMesh surface = to_surface_mesh(mesh);
    std::vector<SurfaceMesh::Halfedge_index> borders;
    CGAL::Polygon_mesh_processing::extract_boundary_cycles(surface, std::back_inserter(borders));
    for (SurfaceMesh::Halfedge_index border : borders) {
        cv::Vec3d lo(1e30, 1e30, 1e30), hi(-1e30, -1e30, -1e30);
        for (SurfaceMesh::Halfedge_index h : CGAL::halfedges_around_face(border, surface)) {
            const Point3& p = surface.point(surface.target(h));
            const cv::Vec3d q(p.x(), p.y(), p.z());
            for (int k = 0; k < 3; ++k) {
                lo[k] = std::min(lo[k], q[k]);
                hi[k] = std::max(hi[k], q[k]);
            }
        }
        if (cv::norm(hi - lo) > max_hole_diameter_mm) continue;  // a real opening, not a gap
        std::vector<SurfaceMesh::Face_index> faces;
        std::vector<SurfaceMesh::Vertex_index> vertices;
        CGAL::Polygon_mesh_processing::triangulate_refine_and_fair_hole(surface, border, std::back_inserter(faces),
                                                                        std::back_inserter(vertices));
    }
    return to_mesh(surface);
}

namespace {

// The same surface with its vertices in the order of their coordinates and its faces in the
// order of their vertices. CGAL's corefinement (PMP::clip) pairs the two meshes' bounding boxes
// in an order that depends on where they lie in memory (Box_intersection_d::ID_FROM_BOX_ADDRESS,
// boxes of two arrays), and creates and links the cut's elements in that order: the same cut
// came out with its halfedges in another order in a second run in one process, and the remeshing
// of the cap that walks them gave another mesh. Rebuilt, the result no longer depends on it.
SurfaceMesh in_canonical_order(const SurfaceMesh& mesh) {
    using Vertex = SurfaceMesh::Vertex_index;
    std::vector<Vertex> order(mesh.vertices().begin(), mesh.vertices().end());
    std::sort(order.begin(), order.end(), [&](Vertex a, Vertex b) { return mesh.point(a) < mesh.point(b); });
    std::vector<int> rank(mesh.number_of_vertices() + mesh.number_of_removed_vertices(), -1);
    for (size_t i = 0; i < order.size(); ++i) rank[order[i]] = static_cast<int>(i);
    std::vector<std::vector<int>> faces;
    faces.reserve(mesh.number_of_faces());
    for (SurfaceMesh::Face_index f : mesh.faces()) {
        std::vector<int> face;
        for (Vertex v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) face.push_back(rank[v]);
        std::rotate(face.begin(), std::min_element(face.begin(), face.end()), face.end());  // same turn
        faces.push_back(std::move(face));
    }
    std::sort(faces.begin(), faces.end());
    SurfaceMesh out;
    std::vector<Vertex> added;
    added.reserve(order.size());
    for (Vertex v : order) added.push_back(out.add_vertex(mesh.point(v)));
    for (const std::vector<int>& face : faces) {
        std::vector<Vertex> corners;
        for (int v : face) corners.push_back(added[static_cast<size_t>(v)]);
        if (out.add_face(corners) == SurfaceMesh::null_face())
            throw Error("mesh", "cutting it at the table left a non-manifold surface");
    }
    return out;
}

}  // namespace

Mesh clip_at_plane(const Mesh& mesh, const cv::Vec3d& up, double height, double cap_edge_mm, double smallest_piece_mm2) {
    namespace PMP = CGAL::Polygon_mesh_processing;
    SurfaceMesh surface = to_surface_mesh(mesh);
    if (!CGAL::is_closed(surface)) throw Error("mesh", "is not closed: it cannot be cut and capped at the table");
    // CGAL keeps the negative side of the plane: -up . x + height < 0, above the table.
    const Kernel::Plane_3 plane(-up[0], -up[1], -up[2], height);
    try {
        if (!PMP::clip(surface, plane, CGAL::parameters::clip_volume(true).throw_on_self_intersection(true)))
            throw Error("mesh", "cutting it at the table left a non-manifold surface");
    } catch (const PMP::Corefinement::Self_intersection_exception&) {
        throw Error("mesh", "intersects itself near the table: it cannot be capped there");
    }
    // Where the surface dipped below the table and came back up, the cut can pinch off a crumb
    // (4 faces, 0.011 mm^2 beside the hole of FreeCAD's eight-view walkthrough, at 1 mm spacing):
    // a closed piece smaller than a sample's patch (smallest_piece_mm2) is no part of the part.
    auto piece = surface.add_property_map<SurfaceMesh::Face_index, std::size_t>("f:piece", 0).first;
    const std::size_t pieces = PMP::connected_components(surface, piece);
    if (pieces > 1) {
        std::vector<double> area(pieces, 0.0);
        for (SurfaceMesh::Face_index f : surface.faces()) area[piece[f]] += PMP::face_area(f, surface);
        std::vector<std::size_t> crumbs;
        for (std::size_t c = 0; c < pieces; ++c)
            if (area[c] < smallest_piece_mm2) crumbs.push_back(c);
        if (crumbs.size() == pieces) throw Error("mesh", "cutting it at the table left only crumbs");
        if (!crumbs.empty()) PMP::remove_connected_components(surface, crumbs, piece);
    }
    surface.remove_property_map(piece);
    surface.collect_garbage();
    surface = in_canonical_order(surface);
    // The cap: faces with every corner on the plane. Re-triangulated with vertices of its
    // own, its edge to the sides kept as it is.
    auto on_plane = [&](SurfaceMesh::Vertex_index v) {
        const Point3& p = surface.point(v);
        return std::abs(up[0] * p.x() + up[1] * p.y() + up[2] * p.z() - height) < 1e-6 * (1 + std::abs(height));
    };
    std::vector<SurfaceMesh::Face_index> cap;
    std::set<SurfaceMesh::Face_index> in_cap;
    for (SurfaceMesh::Face_index f : surface.faces()) {
        bool flat = true;
        for (SurfaceMesh::Vertex_index v : CGAL::vertices_around_face(surface.halfedge(f), surface)) flat = flat && on_plane(v);
        if (flat) {
            cap.push_back(f);
            in_cap.insert(f);
        }
    }
    if (cap.empty()) throw Error("mesh", "does not reach the table: nothing to cap");
    auto rim = surface.add_property_map<SurfaceMesh::Edge_index, bool>("e:rim", false).first;
    for (SurfaceMesh::Edge_index e : surface.edges()) {
        const SurfaceMesh::Face_index a = surface.face(surface.halfedge(e, 0)), b = surface.face(surface.halfedge(e, 1));
        rim[e] = in_cap.count(a) != in_cap.count(b);
    }
    PMP::isotropic_remeshing(cap, cap_edge_mm, surface,
                             CGAL::parameters::number_of_iterations(3).protect_constraints(true).edge_is_constrained_map(rim));
    surface.collect_garbage();
    return to_mesh(surface);
}

namespace {

namespace SMS = CGAL::Surface_mesh_simplification;
using Vertex = SurfaceMesh::Vertex_index;
using Face = SurfaceMesh::Face_index;

// Passes of edge collapse over all the edges; the second and later ones retry the edges refused
// before (most collapses happen in the first).
constexpr int kSimplificationPasses = 4;

Kernel::Triangle_3 face_triangle(const SurfaceMesh& mesh, Face f) {
    const SurfaceMesh::Halfedge_index h = mesh.halfedge(f);
    return {mesh.point(mesh.source(h)), mesh.point(mesh.target(h)), mesh.point(mesh.target(mesh.next(h)))};
}

// A triangle with the mesh's vertices it is made of (to know which corners two triangles share).
struct Corners {
    Point3 point[3];
    Vertex vertex[3];
    CGAL::Bbox_3 box() const { return point[0].bbox() + point[1].bbox() + point[2].bbox(); }
};

Corners corners_of(const SurfaceMesh& mesh, Face f) {
    Corners c;
    int k = 0;
    for (Vertex v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
        c.vertex[k] = v;
        c.point[k] = mesh.point(v);
        ++k;
    }
    return c;
}

// Whether two triangles of a surface meet anywhere but at the corner or the edge they share:
// with no shared corner, any contact; with one, the edge opposite it in either triangle
// meeting the other triangle (their planes meet along a line through the corner, which leaves
// each triangle through its opposite edge); with a shared edge, the two folded flat onto each
// other (coplanar, on the same side of the edge). The predicates are exact (CGAL's Epick).
bool triangles_cross(const Corners& a, const Corners& b) {
    int shared = 0, in_a[3], in_b[3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (a.vertex[i] == b.vertex[j]) {
                in_a[shared] = i;
                in_b[shared] = j;
                ++shared;
            }
    const Kernel::Triangle_3 ta(a.point[0], a.point[1], a.point[2]), tb(b.point[0], b.point[1], b.point[2]);
    if (shared == 0) return CGAL::do_intersect(ta, tb);
    if (shared == 1) {
        const int i = in_a[0], j = in_b[0];
        return CGAL::do_intersect(tb, Kernel::Segment_3(a.point[(i + 1) % 3], a.point[(i + 2) % 3])) ||
               CGAL::do_intersect(ta, Kernel::Segment_3(b.point[(j + 1) % 3], b.point[(j + 2) % 3]));
    }
    if (shared == 2) {
        const Point3 &s = a.point[in_a[0]], &t = a.point[in_a[1]];
        const Point3& a_apex = a.point[3 - in_a[0] - in_a[1]];
        const Point3& b_apex = b.point[3 - in_b[0] - in_b[1]];
        return CGAL::coplanar(s, t, a_apex, b_apex) && CGAL::coplanar_orientation(s, t, a_apex, b_apex) == CGAL::POSITIVE;
    }
    return true;  // the same three corners twice
}

// The mesh's faces by cells of a grid, each face listed in every cell its bounding box
// touches. A collapse moves one vertex: its faces are listed again where they now are. The
// old entries stay (a lookup reads the faces' current corners and skips removed faces).
class FaceGrid {
public:
    FaceGrid(const SurfaceMesh& mesh, double cell) : mesh_(mesh), cell_(cell), seen_(mesh.number_of_faces() + mesh.number_of_removed_faces(), 0) {
        for (Face f : mesh.faces()) add(f);
    }
    void add(Face f) {
        const CGAL::Bbox_3 box = corners_of(mesh_, f).box();
        for_each_cell(box, [&](long long key) { cells_[key].push_back(f); });
    }
    // Calls visit(face) once for each live face listed in a cell that box touches.
    template <class Visit>
    void faces_near(const CGAL::Bbox_3& box, Visit visit) {
        ++stamp_;
        for_each_cell(box, [&](long long key) {
            const auto found = cells_.find(key);
            if (found == cells_.end()) return;
            for (Face f : found->second) {
                if (seen_[f] == stamp_ || mesh_.is_removed(f)) continue;
                seen_[f] = stamp_;
                visit(f);
            }
        });
    }

private:
    template <class Visit>
    void for_each_cell(const CGAL::Bbox_3& box, Visit visit) const {
        // 21 bits per axis around the origin: +-1 million cells.
        const auto index = [&](double v) { return static_cast<long long>(std::floor(v / cell_)) + (1 << 20); };
        for (long long x = index(box.xmin()); x <= index(box.xmax()); ++x)
            for (long long y = index(box.ymin()); y <= index(box.ymax()); ++y)
                for (long long z = index(box.zmin()); z <= index(box.zmax()); ++z)
                    visit(((x & 0x1FFFFF) << 42) | ((y & 0x1FFFFF) << 21) | (z & 0x1FFFFF));
    }
    const SurfaceMesh& mesh_;
    double cell_;
    std::unordered_map<long long, std::vector<Face>> cells_;
    std::vector<unsigned> seen_;
    unsigned stamp_ = 0;
};

// Lindstrom-Turk's placement rounded to float, the precision the Mesh keeps: the crossing test
// then sees the vertex where it will be written.
struct FloatPlacement {
    SMS::LindstromTurk_placement<SurfaceMesh> placement;
    template <class Profile>
    boost::optional<typename Profile::Point> operator()(const Profile& profile) const {
        const boost::optional<typename Profile::Point> exact = placement(profile);
        if (!exact) return exact;
        return Point3(static_cast<float>(exact->x()), static_cast<float>(exact->y()), static_cast<float>(exact->z()));
    }
};

// Refuses a collapse that turns one of the remaining faces over (CGAL's bounded normal change)
// or whose new faces (the star of the merged vertex) cross each other or a face near them.
class CrossingFilter {
public:
    CrossingFilter(const SurfaceMesh& mesh, FaceGrid& grid) : mesh_(&mesh), grid_(&grid) {}
    template <class Profile>
    boost::optional<typename Profile::Point> operator()(const Profile& profile, boost::optional<typename Profile::Point> placement) const {
        placement = turn_filter_(profile, placement);
        if (!placement) return placement;
        // The star after the collapse: the faces around either end but the one or two on the
        // edge, with the moving corner (the middle one) at the placement, named after v0.
        std::vector<Corners> star;
        const auto& triangles = profile.triangles();
        const size_t on_edge = (profile.left_face_exists() ? 1 : 0) + (profile.right_face_exists() ? 1 : 0);
        for (size_t i = on_edge; i < triangles.size(); ++i) {
            const auto& t = triangles[i];
            star.push_back({{mesh_->point(t.v0), *placement, mesh_->point(t.v2)}, {t.v0, profile.v0(), t.v2}});
        }
        if (star.empty()) return placement;
        CGAL::Bbox_3 box = star[0].box();
        std::vector<CGAL::Bbox_3> boxes;
        for (const Corners& c : star) {
            boxes.push_back(c.box());
            box += boxes.back();
        }
        for (size_t i = 0; i < star.size(); ++i)
            for (size_t j = i + 1; j < star.size(); ++j)
                if (CGAL::do_overlap(boxes[i], boxes[j]) && triangles_cross(star[i], star[j])) return boost::none;
        bool crossed = false;
        grid_->faces_near(box, [&](Face f) {
            if (crossed) return;
            const Corners c = corners_of(*mesh_, f);
            for (Vertex v : c.vertex)
                if (v == profile.v0() || v == profile.v1()) return;  // replaced by the star
            const CGAL::Bbox_3 face_box = c.box();
            if (!CGAL::do_overlap(face_box, box)) return;
            for (size_t i = 0; i < star.size() && !crossed; ++i)
                crossed = CGAL::do_overlap(boxes[i], face_box) && triangles_cross(star[i], c);
        });
        if (crossed) return boost::none;
        return placement;
    }

private:
    const SurfaceMesh* mesh_;
    FaceGrid* grid_;
    SMS::Bounded_normal_change_filter<> turn_filter_;
};

// Lists the faces around each merged vertex in the grid where they now are.
struct RegridVisitor : SMS::Edge_collapse_visitor_base<SurfaceMesh> {
    RegridVisitor(const SurfaceMesh& mesh, FaceGrid& grid) : mesh(&mesh), grid(&grid) {}
    void OnCollapsed(const Profile&, const Vertex& v) {
        for (Face f : CGAL::faces_around_target(mesh->halfedge(v), *mesh))
            if (f != SurfaceMesh::null_face()) grid->add(f);
    }
    const SurfaceMesh* mesh;
    FaceGrid* grid;
};

}  // namespace

Mesh simplify(const Mesh& mesh, int target_faces) {
    // Lindstrom-Turk edge collapses, each refused when it would turn a face over or make the
    // surface cross itself (CrossingFilter: the new faces tested against the faces near them).
    // A refused edge is tried again when its neighbourhood changes, and once more in a further
    // pass over all the edges; collapses go on until the target or until none is allowed.
    namespace SMS = CGAL::Surface_mesh_simplification;
    SurfaceMesh surface = to_surface_mesh(mesh);
    const size_t target = static_cast<size_t>(std::max(target_faces, 4));
    if (surface.number_of_faces() <= target) return mesh;
    double area = 0;
    for (SurfaceMesh::Face_index f : surface.faces()) area += std::sqrt(CGAL::to_double(face_triangle(surface, f).squared_area()));
    // The grid's cells: about the edge of the target's triangles (equilateral, covering the area).
    const double cell = std::max(std::sqrt(4 * area / (std::sqrt(3.0) * double(target))), 1e-6);
    for (int pass = 0; pass < kSimplificationPasses && surface.number_of_faces() > target; ++pass) {
        const size_t before = surface.number_of_faces();
        FaceGrid grid(surface, cell);
        // A closed triangle mesh has 3/2 edges per face.
        const SMS::Count_stop_predicate<SurfaceMesh> stop(target * 3 / 2);
        SMS::edge_collapse(surface, stop,
                           CGAL::parameters::get_placement(FloatPlacement())
                               .filter(CrossingFilter(surface, grid))
                               .visitor(RegridVisitor(surface, grid)));
        surface.collect_garbage();
        if (surface.number_of_faces() >= before) break;
    }
    Mesh simplified = to_mesh(surface);
    // The filter's promise, checked on the result: a crossing there is a defect of this code,
    // unless the surface crossed itself before.
    const std::vector<int> crossing = self_intersecting_faces(simplified);
    if (!crossing.empty() && self_intersecting_faces(mesh).empty())
        throw Error("mesh simplification", "left " + std::to_string(crossing.size() / 2) +
                                               " pairs of faces crossing each other (a defect: please report it)");
    return simplified;
}

}  // namespace detail

std::string MeshCheck::summary() const {
    char text[400];
    std::snprintf(text, sizeof text,
                  "%zu vertices, %zu faces, %zu component(s); %s; %zu border edges, %zu non-manifold edges, "
                  "%zu non-manifold vertices%s%s",
                  vertices, faces, components, watertight() ? "watertight" : "NOT watertight", border_edges,
                  non_manifold_edges, non_manifold_vertices, self_intersecting ? "; self-intersecting" : "",
                  closed_volume ? "; encloses a volume (printable)" : "");
    std::string out = text;
    if (closed_volume) {
        std::snprintf(text, sizeof text, " of %.1f cm^3", volume_mm3 / 1000.0);
        out += text;
    }
    if (filled_fraction >= 0) {
        std::snprintf(text, sizeof text, "; %.1f %% of the surface filled in, not measured", 100 * filled_fraction);
        out += text;
        if (closed_volume && filled_fraction > kLargeFilledFraction)
            out += " (WARNING: the closed volume rests on surface that was guessed, not scanned)";
    }
    return out;
}

MeshCheck check_mesh(const Mesh& mesh) {
    MeshCheck check;
    check.vertices = mesh.vertices.size();
    check.faces = mesh.faces.size();
    // Faces per undirected edge.
    std::map<std::pair<int, int>, std::vector<int>> edges;
    for (size_t f = 0; f < mesh.faces.size(); ++f)
        for (int k = 0; k < 3; ++k) {
            const int a = mesh.faces[f][k], b = mesh.faces[f][(k + 1) % 3];
            edges[{std::min(a, b), std::max(a, b)}].push_back(static_cast<int>(f));
        }
    std::vector<int> parent(mesh.faces.size());
    std::iota(parent.begin(), parent.end(), 0);
    auto root = [&](int x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    for (const auto& [edge, faces] : edges) {
        if (faces.size() == 1) ++check.border_edges;
        if (faces.size() > 2) ++check.non_manifold_edges;
        for (size_t i = 1; i < faces.size(); ++i) parent[root(faces[i])] = root(faces[0]);
    }
    for (size_t f = 0; f < parent.size(); ++f) check.components += root(static_cast<int>(f)) == static_cast<int>(f) ? 1 : 0;
    // A vertex is manifold when its faces form one fan (joined through edges at the vertex).
    std::vector<std::vector<int>> faces_of(mesh.vertices.size());
    for (size_t f = 0; f < mesh.faces.size(); ++f)
        for (int k = 0; k < 3; ++k) faces_of[static_cast<size_t>(mesh.faces[f][k])].push_back(static_cast<int>(f));
    for (size_t v = 0; v < faces_of.size(); ++v) {
        const std::vector<int>& around = faces_of[v];
        if (around.size() < 2) continue;
        std::vector<size_t> fan(around.size());  // local union-find over the faces around v
        std::iota(fan.begin(), fan.end(), size_t{0});
        auto group = [&](size_t i) {
            while (fan[i] != i) i = fan[i] = fan[fan[i]];
            return i;
        };
        for (size_t i = 0; i < around.size(); ++i)
            for (size_t j = i + 1; j < around.size(); ++j) {
                // Two faces around v are joined when they share a second vertex (an edge at v).
                int shared = 0;
                for (int a = 0; a < 3; ++a)
                    for (int b = 0; b < 3; ++b) shared += mesh.faces[around[i]][a] == mesh.faces[around[j]][b] ? 1 : 0;
                if (shared >= 2) fan[group(i)] = group(j);
            }
        std::set<size_t> groups;
        for (size_t i = 0; i < around.size(); ++i) groups.insert(group(i));
        if (groups.size() > 1) ++check.non_manifold_vertices;
    }
    if (mesh.measured.size() == mesh.vertices.size() && !mesh.faces.empty()) {
        double total = 0, filled = 0;
        for (const cv::Vec3i& f : mesh.faces) {
            const cv::Vec3d a(mesh.vertices[f[0]]), b(mesh.vertices[f[1]]), c(mesh.vertices[f[2]]);
            const double area = 0.5 * cv::norm((b - a).cross(c - a));
            total += area;
            // A face counts as filled when most of its corners are.
            const int measured = mesh.measured[f[0]] + mesh.measured[f[1]] + mesh.measured[f[2]];
            if (measured < 2) filled += area;
        }
        check.filled_fraction = total > 0 ? filled / total : 0;
    }
    if (check.watertight()) {
        check.self_intersecting = !detail::self_intersecting_faces(mesh).empty();
        double volume = 0;  // divergence theorem over outward-facing triangles
        for (const cv::Vec3i& f : mesh.faces) {
            const cv::Vec3d a(mesh.vertices[f[0]]), b(mesh.vertices[f[1]]), c(mesh.vertices[f[2]]);
            volume += a.dot(b.cross(c)) / 6.0;
        }
        check.volume_mm3 = volume;
        check.closed_volume = !check.self_intersecting && volume > 0;
    }
    return check;
}

}  // namespace picoscan
