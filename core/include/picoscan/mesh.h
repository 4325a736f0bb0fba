// Surface meshing of merged clouds with CGAL 5.5: normals oriented towards the sensor,
// Poisson (watertight) or advancing-front (open surfaces) reconstruction, small-hole
// filling, simplification, and a manifold/watertight check before export.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/progress.h"

#include <string>
#include <vector>

namespace picoscan {

// Poisson and AdvancingFront mesh points (mesh_cloud); Grid joins the pixels of one view
// (grid_mesh, through mesh_view in pipeline.h).
enum class MeshMethod { Poisson, AdvancingFront, Grid };

// What becomes of the side a single placement never saw (the face the part stood on).
// Poisson makes the closed surface first; the fill then decides what stays of it. Open needs
// no closed surface: the points are contoured where they are (band_surface), in seconds.
enum class MeshFill {
    Open,     // the unseen side is left open: nothing invented (band_surface, not Poisson)
    Table,    // closed by a flat cap on the turntable's plane (a part standing on the table)
    Poisson,  // Poisson's own smooth closure (invented; the mesh check says how much)
};

struct MeshOptions {
    MeshMethod method = MeshMethod::Poisson;
    double sample_spacing_mm = 0.4;     // the cloud is thinned to about this spacing first (0 keeps all)
    // Poisson: triangle size and the distance the surface may stray from the implicit one,
    // both in multiples of the average point spacing.
    double poisson_triangle_size = 1.0;
    double poisson_distance = 0.1;
    // Advancing front: triangles whose circumradius exceeds this multiple of the spacing are not made.
    double advancing_front_max_radius = 4.0;
    MeshFill fill = MeshFill::Poisson;  // Poisson: what closes the unseen side
    // MeshFill::Table: the turntable's axis pointing either way (the table is on the side the
    // scan did not see), in the cloud's frame; zero when unknown: the table's plane is then
    // fitted to the lowest rim of the measured surface.
    cv::Vec3d table_axis{0, 0, 0};
    // The budget that bounds meshing time: the cloud is thinned coarser than sample_spacing_mm
    // until at most max_points remain, and Poisson's surface triangles grow until a closed
    // surface the size of the data's bounding sphere has at most max_faces.
    int max_points = 200000;
    int max_faces = 400000;
    double max_hole_diameter_mm = 10;   // holes up to this size are filled (triangulate, refine, fair)
    int target_faces = 0;               // simplify to about this many faces (0 keeps all)
    GridMeshOptions grid;               // MeshMethod::Grid
};

// The mesh's topology, checked before export.
struct MeshCheck {
    size_t vertices = 0, faces = 0;
    size_t border_edges = 0;            // edges with one face: holes
    size_t non_manifold_edges = 0;      // edges with more than two faces
    size_t non_manifold_vertices = 0;
    size_t components = 0;
    bool self_intersecting = false;
    bool watertight() const { return faces > 0 && border_edges == 0 && non_manifold_edges == 0 && non_manifold_vertices == 0; }
    bool closed_volume = false;         // watertight and without self-intersections: printable
    double volume_mm3 = 0;              // enclosed volume when closed
    // Share of the surface area (0..1) not measured but filled in (Mesh::measured); negative
    // when the mesh does not say. A closed mesh with much of it encloses guessed volume.
    double filled_fraction = -1;
    static constexpr double kLargeFilledFraction = 0.02;
    std::string summary() const;        // one line for the user
};

MeshCheck check_mesh(const Mesh& mesh);

// Which fill a name means ("open", "table", "poisson"); throws Error naming `what` otherwise.
MeshFill mesh_fill_from_name(const std::string& name, const std::string& what);

// Points need normals (from a ScanView, pointing to its camera); they are re-estimated by PCA
// over the neighbours and flipped to agree with the given ones. Throws Error for an empty or
// degenerate cloud (too few points, all on a line or a plane for Poisson).
Mesh mesh_cloud(const PointCloud& cloud, const MeshOptions& options = {}, const ProgressCallback& progress = nullptr);

// The open surface of oriented points (normals towards the side they were seen from), with
// nothing invented: the signed distance to the points' tangent planes, contoured by marching
// tetrahedra on a band of voxel_mm cubes around the points (about their spacing); faces
// farther than 1.5 voxels from every point are cut. A manifold whose borders are the edges of
// the data; sheets closer than about two voxels may merge. Throws Error("cancelled") when
// progress returns false, Error for a bad voxel or a cloud without normals.
Mesh band_surface(const PointCloud& cloud, double voxel_mm, const ProgressCallback& progress = nullptr);

}  // namespace picoscan
