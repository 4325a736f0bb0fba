// A closed triangle mesh as a boundary representation: facets that lie on one plane (within the
// scan's noise) merged into one planar face, a hole or boss between two such faces made one
// cylindrical face, the rest kept as triangles, written in
// OpenCASCADE's BREP text format so that a CAD host (FreeCAD) only reads the solid back. Each
// face carries its own facets as its triangulation, so the host draws it without meshing it.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

struct PlanarFaceOptions {
    double noise_mm = 0;             // the scan's noise (sigma); 0: estimated from the mesh
    double distance_factor = 4;      // a region's vertices lie within this many sigma of its plane
    double max_normal_deg = 30;      // a facet joins a region when its normal is within this of the plane's
                                     // (plus 3 x its normal's noise: 2 sigma over its shortest altitude)
    double max_rms_factor = 1.5;     // a region's RMS residual must stay below this many sigma
                                     // (a strip of a cylinder is flat within 4 sigma, not within 1.5)
    int min_facets = 30;             // smaller regions stay triangles
    bool merge = true;               // false: one face per facet (and no simplification)
    bool simplify = true;            // the facets left out of planar faces (curved regions) become
                                     // fewer, larger triangles, each within simplify_mm of the mesh;
                                     // the planar faces and their boundaries stay as they are
    double simplify_mm = 0;          // 0: distance_factor x the noise
    double simplify_max_volume_change = 5e-4;  // beyond this (relative), the curved facets stay as they were
    bool check_faces = true;         // no vertex move may fold a facet, and a merged face whose
                                     // boundary would not make a valid B-rep face (merged_face_defects)
                                     // goes back to triangles where it fails; false: neither (as before)
    bool cylinders = true;           // a region of facets left between two planar faces, bounded by one
                                     // whole loop of each, becomes one cylindrical face when its vertices
                                     // lie within max_rms_factor x the noise (RMS) of a cylinder square to
                                     // both planes (a drilled hole, a boss, a shaft); its loops become circles.
                                     // A wall whose facets' normals bunch into a few directions round the
                                     // axis (a prism's flat sides, its corners on the circle) is not one,
                                     // nor one whose vertices' distances from the axis follow such sides.
                                     // Such a region on a cone about that axis (half-angle 2 to 64 degrees:
                                     // a countersink, a chamfered boss, a tapered hole) becomes one conical face.
                                     // A chamfer ring (plane, cylinder, cone, plane along one axis: a hole's
                                     // chamfered or countersunk mouth, a boss's chamfered edge) becomes a
                                     // cylindrical and a conical face sharing the circle where they meet
};

struct BrepEdge {
    int start = 0, end = 0;          // vertex indices; a straight line between them (or a circle)
    double tolerance_mm = 1e-7;      // how far the line may be from the faces' planes
    std::vector<int> chain{};        // the mesh's vertices along it, start to end (empty: just its ends)
    // A circle instead (radius_mm > 0): about `axis` through `center`, from start (== end, at
    // center + radius x x_axis) once round, counter-clockwise seen from the axis' tip.
    double radius_mm = 0;
    cv::Vec3d center{}, axis{}, x_axis{};
};

struct BrepFace {
    cv::Vec3d origin, normal;        // the face's plane; normal points out of the solid
    bool merged = false;             // true: a region of facets; false: one facet
    int facet_count = 1;
    double rms_mm = 0;               // merged: RMS distance of its vertices to the plane
    // Closed loops of signed edge references (edge index + 1, negative when run backwards):
    // the outer boundary first, counter-clockwise seen from outside, then the holes.
    std::vector<std::vector<int>> wires;
    // Its facets (vertex indices, counter-clockwise seen from outside); empty: no triangulation written.
    std::vector<cv::Vec3i> triangles{};
    // A cylinder instead of a plane (radius_mm > 0): about the axis through `origin` along `normal`,
    // its seam (angle 0) along `origin` + radius x x_axis; reversed: the solid is outside it (a hole).
    // Its one wire runs round the circle at the axis' start, up the seam, back round the far circle
    // and down the seam again (the seam edge twice).
    double radius_mm = 0;
    cv::Vec3d x_axis{};
    bool reversed = false;
    // A cone instead of a cylinder (non-zero): radius_mm at `origin`, growing by tan(semi_angle_rad)
    // per mm along `normal` (OpenCASCADE's cone: v runs along its slant line from `origin`'s circle).
    double semi_angle_rad = 0;
};

struct PlanarFaceModel {
    std::vector<cv::Vec3d> vertices;
    // The mesh's own vertices (the first ones of `vertices`, before any was moved onto a plane):
    // what tells a cylinder's wall from a prism's flat sides once both are merged into planes.
    std::vector<cv::Vec3d> mesh_vertices;
    std::vector<double> vertex_tolerance_mm;
    std::vector<BrepEdge> edges;
    std::vector<BrepFace> faces;
    double noise_mm = 0;             // the noise used (given or estimated)
    double mesh_volume_mm3 = 0;      // enclosed by the (outward-turned) mesh
    size_t facet_count = 0;          // facets used (without those collapsed by joining vertices)
    size_t merged_faces = 0, merged_facets = 0;  // planar regions and the facets they hold
    std::vector<std::string> refused_merges;     // planar regions left as triangles, and why
    size_t cylinder_faces = 0, cylinder_facets = 0;  // cylindrical faces (the last faces) and the facets they replace
    size_t cone_faces = 0, cone_facets = 0;      // conical faces (among the last faces, counted apart from the cylinders)
    std::vector<std::string> cylinder_notes;     // regions between two planar faces left as triangles, and why
    // Facets where a cylinder's wall meets its ends (a smooth mesh's rounded edges) that the
    // cylinder and its planes are continued over: how many, the farthest from them, and the volume
    // between them and the facets (summed over the cylinders).
    size_t cylinder_end_facets = 0;
    double cylinder_end_mm = 0, cylinder_end_volume_mm3 = 0;
    // Simplification of the curved regions (simplify): facets there before and after (equal: none
    // done), the tolerance, how far the mesh's vertices are from the simplified facets (the
    // farthest), and the volume enclosed once simplified. Refused (curved facets kept as they
    // were; the reason in simplify_note) when the volume would move by more than
    // simplify_max_volume_change.
    size_t curved_facets_before = 0, curved_facets_after = 0;
    double simplify_mm = 0, simplify_deviation_mm = 0, simplified_volume_mm3 = 0;
    std::string simplify_note;
    std::string summary() const;
};

// Builds the faces of the solid bounded by `mesh`. Vertices at the same position are joined
// first; facets left with two corners at one position are dropped. With options.simplify, the
// facets in no planar face are simplified (fewer faces for a CAD host to draw) and the faces are
// built again from the simplified mesh; mesh_volume_mm3 stays the input's. Throws Error("mesh", ...) saying why the mesh bounds no solid: empty, open (border
// edges), non-manifold edges, inconsistently oriented facets, zero-area facets. Facets turned
// inwards are turned outwards. Self-intersections are check_mesh's (mesh.h).
PlanarFaceModel planar_face_model(const Mesh& mesh, const PlanarFaceOptions& options = {},
                                  const ProgressCallback& progress = nullptr);

// Why each merged face of `model` would not make a valid B-rep face (one line per bad face, empty
// when all are good): its boundary must lie on its plane (within 3 x distance_factor x the noise),
// have no edge of zero length, neither touch nor cross itself (closer than its edges'
// tolerances), run counter-clockwise seen from outside with its holes clockwise, inside it and
// not inside each other. planar_face_model runs this on its own faces unless check_faces is false.
// Faces with a circle in their boundary (a cylinder's ends) are not checked here.
std::vector<std::string> merged_face_defects(const PlanarFaceModel& model, const PlanarFaceOptions& options = {});

// Writes the model as an OpenCASCADE BREP solid (vertices, straight and circular edges, planar
// cylindrical and conical faces, one shell), with each face's triangles as its triangulation and each edge's chain as its polygon on
// the triangulations of its faces (what a viewer meshing the solid would make, so OpenCASCADE's
// mesher keeps them instead). Written to a temporary file and renamed. `progress` is told every 4096 vertices, edges and
// faces; answering false stops it (Error("cancelled", ...), nothing written).
void write_brep(const PlanarFaceModel& model, const std::string& path, const ProgressCallback& progress = nullptr);

}  // namespace picoscan
