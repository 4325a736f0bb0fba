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

struct MeshOptions {
    MeshMethod method = MeshMethod::Poisson;
    double sample_spacing_mm = 0.4;     // the cloud is thinned to about this spacing first (0 keeps all)
    // Poisson: triangle size and the distance the surface may stray from the implicit one,
    // both in multiples of the average point spacing.
    double poisson_triangle_size = 1.0;
    double poisson_distance = 0.1;
    // Advancing front: triangles whose circumradius exceeds this multiple of the spacing are not made.
    double advancing_front_max_radius = 4.0;
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
    std::string summary() const;        // one line for the user
};

MeshCheck check_mesh(const Mesh& mesh);

// Points need normals (from a ScanView, pointing to its camera); they are re-estimated by PCA
// over the neighbours and flipped to agree with the given ones. Throws Error for an empty or
// degenerate cloud (too few points, all on a line or a plane for Poisson).
Mesh mesh_cloud(const PointCloud& cloud, const MeshOptions& options = {}, const ProgressCallback& progress = nullptr);

}  // namespace picoscan
