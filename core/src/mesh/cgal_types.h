// CGAL types and conversions shared by the meshing translation units (only these include CGAL:
// it is header-heavy, so it stays out of the rest of the core).
#pragma once

#include "picoscan/cloud.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include <functional>
#include <utility>
#include <vector>

namespace picoscan::detail {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point3 = Kernel::Point_3;
using Vector3 = Kernel::Vector_3;
using SurfaceMesh = CGAL::Surface_mesh<Point3>;
using PointWithNormal = std::pair<Point3, Vector3>;

inline SurfaceMesh to_surface_mesh(const Mesh& mesh) {
    SurfaceMesh out;
    std::vector<SurfaceMesh::Vertex_index> vertices;
    vertices.reserve(mesh.vertices.size());
    for (const cv::Vec3f& v : mesh.vertices) vertices.push_back(out.add_vertex(Point3(v[0], v[1], v[2])));
    for (const cv::Vec3i& f : mesh.faces) out.add_face(vertices[f[0]], vertices[f[1]], vertices[f[2]]);
    return out;
}

inline Mesh to_mesh(const SurfaceMesh& mesh) {
    Mesh out;
    std::vector<int> index(mesh.number_of_vertices() + mesh.number_of_removed_vertices(), -1);
    for (SurfaceMesh::Vertex_index v : mesh.vertices()) {
        index[v] = static_cast<int>(out.vertices.size());
        const Point3& p = mesh.point(v);
        out.vertices.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    }
    for (SurfaceMesh::Face_index f : mesh.faces()) {
        cv::Vec3i face;
        int k = 0;
        for (SurfaceMesh::Vertex_index v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) {
            if (k < 3) face[k] = index[v];
            ++k;
        }
        if (k == 3) out.faces.push_back(face);
    }
    return out;
}

// Reports the fraction of a stage done; throws Error("cancelled") when the caller cancels.
using StageReport = std::function<void(double fraction, const char* stage)>;

struct PoissonSettings {
    double spacing_mm = 0;      // average spacing of the points
    double triangle_size = 1;   // multiples of the spacing
    double distance = 0.1;      // multiples of the spacing
    int max_faces = 0;          // the surface mesher's triangles grow until a closed surface fits
};

// Each stage of mesh_cloud, in its own translation unit.
Mesh poisson_mesh(const std::vector<PointWithNormal>& points, const PoissonSettings& settings, const StageReport& report);
Mesh advancing_front_mesh(const std::vector<PointWithNormal>& points, double spacing_mm, double max_radius);
// Points thinned to the spacing (coarser when more than max_points would remain), normals
// re-estimated by PCA and flipped to agree with the given ones. `report` gets the fraction of the
// preparation done (0..1), during the normals and the spacing too, and throws to cancel.
std::vector<PointWithNormal> prepare_points(const PointCloud& cloud, double spacing_mm, int max_points,
                                            double& average_spacing_mm, const StageReport& report);
// Moves each vertex onto the plane fitted to its nearest input points (undoes Poisson's smoothing).
void project_onto_points(Mesh& mesh, const std::vector<PointWithNormal>& points, double reach_mm);
// The fraction of the points within reach_mm of a mesh vertex (what the surface covers).
double fraction_of_points_near(const Mesh& mesh, const std::vector<PointWithNormal>& points, double reach_mm);
// A triangle's height over its longest edge, divided by that edge: sqrt(3)/2 for an equilateral
// triangle, 0 for one whose corners lie on a line (or coincide, or are not finite).
double height_over_longest_edge(const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c);
// A face of (almost) no area: its height under 1e-4 of its longest edge (its corners on one line).
bool is_sliver(const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c);
// Indices of the faces that intersect another face, and of the slivers that touch a face they
// share no corner with (FreeCAD's hasSelfIntersections reports those: a vertex put on a line
// through two others is stored as float, up to ~1e-5 mm off it, and the exact test passes it).
std::vector<int> self_intersecting_faces(const Mesh& mesh);
Mesh fill_small_holes(const Mesh& mesh, double max_hole_diameter_mm);
// The closed mesh cut by the plane {x : up . x = height}, the part above kept and the cut
// closed by a flat cap, re-triangulated at about cap_edge_mm (so that the cap has vertices
// of its own, away from the measured rim); closed pieces of less area than smallest_piece_mm2
// that the cut leaves apart are dropped. Throws Error when the mesh is not closed or intersects
// itself.
Mesh clip_at_plane(const Mesh& mesh, const cv::Vec3d& up, double height, double cap_edge_mm, double smallest_piece_mm2);
Mesh simplify(const Mesh& mesh, int target_faces);

}  // namespace picoscan::detail
