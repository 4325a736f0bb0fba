// Mesh repair and checks: small-hole filling (Liepa 2003: triangulate, refine, fair),
// edge-collapse simplification (Lindstrom-Turk), and the topology check before export.
#define CGAL_EIGEN3_ENABLED 1
#include "mesh/cgal_types.h"
#include "picoscan/error.h"
#include "picoscan/mesh.h"

#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/clip.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Bounded_normal_change_filter.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <numeric>
#include <set>

namespace picoscan {

namespace detail {

std::vector<int> self_intersecting_faces(const Mesh& mesh) {
    const SurfaceMesh surface = to_surface_mesh(mesh);
    std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> pairs;
    CGAL::Polygon_mesh_processing::self_intersections(surface, std::back_inserter(pairs));
    std::vector<int> faces;
    for (const auto& [a, b] : pairs) {
        faces.push_back(static_cast<int>(a));
        faces.push_back(static_cast<int>(b));
    }
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

Mesh clip_at_plane(const Mesh& mesh, const cv::Vec3d& up, double height, double cap_edge_mm) {
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

Mesh simplify(const Mesh& mesh, int target_faces) {
    // Edge collapse checks only that the faces around the collapsed edge keep their
    // orientation: faces farther away may end up crossing them (seen at the through hole
    // and the boss of the mechanical part at a few thousand faces). Collapses that turn a
    // face by more than 90 degrees are refused, and the result is checked; one that crosses
    // itself is made again with more faces, up to the mesh as it was.
    namespace SMS = CGAL::Surface_mesh_simplification;
    for (size_t target = static_cast<size_t>(target_faces); target < mesh.faces.size(); target = target * 3 / 2) {
        SurfaceMesh surface = to_surface_mesh(mesh);
        // A closed triangle mesh has 3/2 edges per face.
        const SMS::Count_stop_predicate<SurfaceMesh> stop(target * 3 / 2);
        SMS::edge_collapse(surface, stop, CGAL::parameters::filter(SMS::Bounded_normal_change_filter<>()));
        surface.collect_garbage();
        Mesh simplified = to_mesh(surface);
        if (self_intersecting_faces(simplified).empty()) return simplified;
    }
    return mesh;
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
        check.self_intersecting = CGAL::Polygon_mesh_processing::does_self_intersect(detail::to_surface_mesh(mesh));
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
