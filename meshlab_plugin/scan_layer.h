// Moving scans between the PicoScan core and MeshLab layers.
//
// A layer made from an organised ScanView keeps what the core needs to rebuild the view:
// each vertex's camera pixel (per-vertex attribute "picoscan_pixel" = y * width + x) and the
// pixel grid with the camera focal length (per-mesh attribute "picoscan_grid"). Vertices stay
// in the camera frame; the view's pose is the layer's transform (cm.Tr), as MeshLab's own
// alignment tool keeps it. Vertex colour is the white frame, vertex quality the fringe modulation.
#pragma once

#include "picoscan/cloud.h"

#include <common/meshmodel.h>

#include <vector>

namespace picoscan_meshlab {

// The per-mesh attribute "picoscan_grid".
struct ScanGrid {
    int width = 0, height = 0;
    double focal_px = 0;
};

// The organised view of a layer: the view (pose = layer transform) and its camera focal length.
struct LayerView {
    picoscan::ScanView view;
    double focal_px = 0;
};

// Fills an empty layer with the valid points of `view`, their pixels and the grid.
void fill_layer(MeshModel& layer, const picoscan::ScanView& view, double focal_px);
// Fills an empty layer with a mesh (no pixel grid: such a layer cannot be cleaned or aligned).
void fill_layer(MeshModel& layer, const picoscan::Mesh& mesh);

// True when the layer carries the pixel grid of a PicoScan reconstruction.
bool has_scan_grid(MeshModel& layer);
// Rebuilds the organised view of a layer with a pixel grid (check has_scan_grid first).
LayerView layer_view(MeshModel& layer);
// Deletes the vertices (and faces using them) whose pixel is no longer valid in `view`.
// Returns how many vertices were deleted.
int remove_vertices_missing_from(MeshModel& layer, const picoscan::ScanView& view);

// The layer's vertices, optionally transformed by the layer's transform and/or limited to the selection.
std::vector<cv::Vec3f> layer_points(MeshModel& layer, bool apply_transform, bool selected_only);

cv::Matx44d layer_pose(MeshModel& layer);
void set_layer_pose(MeshModel& layer, const cv::Matx44d& pose);

}  // namespace picoscan_meshlab
