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

// A part's own coordinate system found on a scan (or a model) by 3-2-1 datum alignment: the
// primary plane fixes Z (its normal), the secondary plane fixes X (the line where it meets the
// primary plane; Y is its normal made square to Z), and a third plane or a point fixes the origin
// along that line. The planes' normals are used as given: flip one to flip its axis.
struct DatumOptions {
    // Datums nearer to parallel than this are refused: their line or corner would be ill-defined.
    double min_angle_deg = 10;
};
struct DatumFrame {
    cv::Matx44d part_from_scan = cv::Matx44d::eye();  // takes scan coordinates into the part frame
    cv::Vec3d origin, x_axis, y_axis, z_axis;          // the part frame in scan coordinates
    // Angles between the datums' normals (90 for a square part): how far the part is from square.
    double primary_secondary_deg = 0, primary_tertiary_deg = 0, secondary_tertiary_deg = 0;
};
// Throws Error("secondary"/"tertiary", ...) naming the angle when two datums are nearer to
// parallel than options.min_angle_deg, Error("min_angle_deg", ...) for a bad option.
DatumFrame datum_frame(const PlaneFit& primary, const PlaneFit& secondary, const PlaneFit& tertiary,
                       const DatumOptions& options = {});
// The origin is the point of the primary/secondary line nearest to `origin_point`.
DatumFrame datum_frame(const PlaneFit& primary, const PlaneFit& secondary, const cv::Vec3d& origin_point,
                       const DatumOptions& options = {});
// A frame with Z along `up` (a turntable's axis, a base plane's normal), X along `x_hint` made
// square to Z, and its origin at `origin`. Throws Error("up"/"x_hint", ...) for zero or parallel vectors.
DatumFrame frame_from_axis(const cv::Vec3d& origin, const cv::Vec3d& up, const cv::Vec3d& x_hint);

}  // namespace picoscan
