// Least-squares fits of simple shapes to points, for measuring scans against references
// (a calibration sphere, a flat plate).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace picoscan {

struct PlaneFit {
    cv::Vec3d normal;       // unit
    double offset_mm = 0;   // plane: normal . X = offset_mm
    double rms_mm = 0;      // RMS of the point-to-plane distances
    size_t point_count = 0;
};

struct SphereFit {
    cv::Vec3d centre;
    double radius_mm = 0;
    double rms_mm = 0;      // RMS of the radial residuals |X - centre| - radius
    size_t point_count = 0;
};

// Total least squares plane (through the centroid, normal = smallest principal axis).
// Throws Error for fewer than 3 points or collinear points.
PlaneFit fit_plane(const std::vector<cv::Vec3f>& points);

// Geometric sphere fit: algebraic start, then Gauss-Newton on the radial residuals.
// Throws Error for fewer than 4 points or a degenerate (planar) set.
SphereFit fit_sphere(const std::vector<cv::Vec3f>& points);

}  // namespace picoscan
