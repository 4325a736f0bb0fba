// Pictures of a scan for people: a shaded, depth-coloured rendering of an organised view.
#pragma once

#include "picoscan/calibration.h"
#include "picoscan/cloud.h"

#include <opencv2/core.hpp>
#include <string>

namespace picoscan {

// CV_8UC3 image of the camera's size: each valid pixel shaded by its normal and coloured by
// depth (near = yellow, far = purple); invalid pixels dark grey.
cv::Mat render_preview(const ScanView& view);

// render_preview() written as PNG through a temporary file and a rename.
void write_preview_png(const ScanView& view, const std::string& path);

// A mesh seen by the rig's camera (ray-cast, shaded like render_preview), cropped to the
// mesh with a margin, written as PNG through a temporary file and a rename.
void write_mesh_preview_png(const Mesh& mesh, const Calibration& camera, const std::string& path);

}  // namespace picoscan
