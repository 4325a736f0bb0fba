// Moving scans between the PicoScan core and MeshLab layers.
//
// A layer made from an organised ScanView keeps what the core needs to rebuild the view:
// each vertex's camera pixel (per-vertex texture coordinates u = x, v = y, which MeshLab saves
// in PLY as texture_u/texture_v) and the view's camera: in full (intrinsics and every
// distortion coefficient) as the per-mesh attribute "picoscan_camera" while the layer is in
// memory, and as the layer's MeshLab camera (cm.shot: focal, centre, viewport and the first
// five distortion coefficients), which MeshLab writes into PLY and reads back, so a reopened
// layer can still be cleaned, aligned and fused. Vertices stay in the camera frame; the view's
// pose is the layer's transform (cm.Tr), as MeshLab's own alignment tool keeps it. Vertex colour
// is the white frame, vertex quality the fringe modulation.
#pragma once

#include "picoscan/cloud.h"

#include <common/meshmodel.h>

#include <string>
#include <vector>

namespace picoscan_meshlab {

// The per-mesh attribute "picoscan_camera": the pixel grid and the full camera of the view.
struct LayerCamera {
    int width = 0, height = 0;
    double matrix[9] = {};
    double distortion[14] = {};  // OpenCV order
    int distortion_count = 0;
};

// Fills an empty layer with the valid points of `view` (which must know its camera), their
// pixels and the camera.
void fill_layer(MeshModel& layer, const picoscan::ScanView& view);
// Fills an empty layer with a mesh (no pixel grid: such a layer cannot be cleaned or aligned).
void fill_layer(MeshModel& layer, const picoscan::Mesh& mesh);

// What missing_scan_data did to make a reopened layer whole, for the log.
struct LayerRepair {
    QString view_file;          // the PicoScan view PLY the pixel grid and camera were taken from
    int normals_from_grid = 0;  // vertices saved without a normal that got one from the pixel grid
};

// Empty when the layer carries the pixel grid and camera of a PicoScan view: in memory, read
// back from a PLY saved with texture coordinates and camera, or taken from a PicoScan view PLY
// (its own file, or one beside it that holds its points). A layer saved without its normals gets
// them again from the pixel grid. Otherwise what it lacks.
std::string missing_scan_data(MeshModel& layer, LayerRepair* repair = nullptr);
// Rebuilds the organised view of a layer (check missing_scan_data first); pose = layer transform.
picoscan::ScanView layer_view(MeshModel& layer);
// Deletes the vertices (and faces using them) whose pixel is no longer valid in `view`.
// Returns how many vertices were deleted.
int remove_vertices_missing_from(MeshModel& layer, const picoscan::ScanView& view);

// The layer's triangles (deleted ones left out), optionally through the layer's transform.
picoscan::Mesh layer_mesh(MeshModel& layer, bool apply_transform);

// The layer's vertices, optionally transformed by the layer's transform and/or limited to the selection.
std::vector<cv::Vec3f> layer_points(MeshModel& layer, bool apply_transform, bool selected_only);

cv::Matx44d layer_pose(MeshModel& layer);
void set_layer_pose(MeshModel& layer, const cv::Matx44d& pose);

}  // namespace picoscan_meshlab
