// Free-space checks: a view's camera saw through every point in front of what it measured.
// A point of another view placed there by a candidate alignment is a contradiction that no
// residual can show (a symmetric part matched the wrong way fits tightly where it overlaps).
#pragma once

#include "picoscan/cloud.h"

#include <opencv2/core.hpp>
#include <vector>

namespace picoscan::detail {

// A view's pinhole camera (its own, or else fitted to its pixel grid: its points are in the
// camera frame, each at its pixel), how well that explains the grid, and its depth map.
// The maps cover the smallest rectangle of the frame holding every measured pixel (outside
// it nothing was measured), whose top-left pixel is `origin`.
struct ViewCamera {
    double fx = 0, fy = 0, cx = 0, cy = 0;
    double fit_rms_px = 0;   // how well the pinhole explains the grid (lens distortion)
    cv::Point origin;        // frame pixel of the maps' (0, 0)
    cv::Mat depth;           // CV_32F: the depth (mm) measured at each pixel, infinite where none
    cv::Mat nearest_depth;   // CV_32F: the smallest depth measured around each pixel
    bool valid() const { return !nearest_depth.empty(); }
};
// measured_area: measured_bounds(view).
ViewCamera view_camera(const ScanView& view, const cv::Rect& measured_area);

struct FreeSpaceCheck {
    size_t checked = 0;     // points that project onto pixels the view measured
    size_t violations = 0;  // of those, points in front of the measured surface by more than the tolerance
    double fraction() const { return checked ? static_cast<double>(violations) / static_cast<double>(checked) : 0.0; }
};
// `points` in the view's camera frame.
FreeSpaceCheck free_space_violations(const ViewCamera& camera, const std::vector<cv::Vec3d>& points, double tolerance_mm);

}  // namespace picoscan::detail
