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

// The part's own axes, as the contact sheet shows it: "up" the axis of its mass nearest up_hint
// (zero: the camera frame's up, -y, as in a turntable scan), then both squared to the part's
// largest faces where it has them (its top and bottom set up, its sides front). Unit vectors;
// centre is the mean of the vertices.
struct ContactSheetAxes {
    cv::Vec3d centre, up, front;
};
ContactSheetAxes contact_sheet_axes(const Mesh& mesh, const cv::Vec3d& up_hint = {0, 0, 0});

// A contact sheet of a mesh: six labelled tiles (top, bottom, front, right, back, left) along
// contact_sheet_axes; surface filled in rather than measured (Mesh::measured) in orange.
cv::Mat render_contact_sheet(const Mesh& mesh, const cv::Vec3d& up_hint = {0, 0, 0}, int tile_size = 320);

// render_contact_sheet() written as PNG through a temporary file and a rename.
void write_contact_sheet_png(const Mesh& mesh, const std::string& path, const cv::Vec3d& up_hint = {0, 0, 0});

}  // namespace picoscan
