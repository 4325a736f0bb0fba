// Fitting where the user points: a plane, cylinder, sphere or cone fitted by least squares to a
// picked region of a scan (point indices, or a seed point with a radius, optionally grown over the
// smooth surface), the kind chosen from the residuals against the scan's noise, with optional
// constraints to another feature (parallel, perpendicular, coaxial) and sizes snapped to nominal.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/progress.h"
#include "picoscan/shapes.h"

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

struct RegionSelection {
    double radius_mm = 5;            // points within this distance of the seed's nearest point
    double seed_radius_mm = 2;       // grown faces (grow_face): the ball the first fit is made on
    // > 0 (all three): the points in a box of these half sizes around the seed's nearest point,
    // along box_axes (its rows, unit and square to each other, in the cloud's frame), instead of
    // the ball of radius_mm.
    cv::Vec3d box_half_size_mm{0, 0, 0};
    cv::Matx33d box_axes = cv::Matx33d::eye();
    bool grow = false;               // true: the face at the seed, grown as the kind that fits it (grow_face)
    double max_gap_mm = 1.0;         // growing: from cube to neighbouring cube of this size
    double max_normal_step_deg = 20; // growing: a point's normal agrees with the fitted shape's within this
};

// The face at a picked point, grown by fitting (fit_at_point with `grow`): the largest ball
// around the point (seed_radius_mm, halved while it holds an edge) that one kind fits within
// reject_factor x the noise starts each allowed kind; each is then grown over the surface
// (from cube to neighbouring cube of max_gap_mm) to the points within max(4, reject_factor) x
// the noise of it whose normals agree with its own within max_normal_step_deg, refitted and
// regrown until it settles, then again from its fit on the largest face another kind grew.
// A scanner's normals turn gradually over an edge; the distance to the fitted shape does not,
// so the face stops there (growing by normal steps ran from the demo part's short boss onto its
// top and the block). Of the kinds whose face it fits within accept_factor x the noise, the
// simplest whose face holds at least 90 % of the largest one's points is taken (a flat chamfer:
// a plane; a short boss: a cylinder).
struct GrownFace {
    std::vector<int> region;         // the cloud's points on the face, sorted
    ShapeKind kind = ShapeKind::Plane;
    double noise_mm = 0;             // given, or estimated from the scan around the point
    double seed_radius_mm = 0;       // the ball that started it
    std::string report;              // one line: each kind's face and why this one
};

// Indices of the cloud's points in the region picked at `seed` (the nearest point to it starts
// it); with `grow`, grow_face's with the automatic kinds and the noise estimated. Throws
// Error("seed", ...) when the cloud is empty, Error("cloud", ...) when growing needs
// normals it lacks, Error("radius_mm"/"max_gap_mm", ...) for bad options, Error("cancelled", ...)
// when `progress` answers false (it is told every 65 536 points looked at).
std::vector<int> select_region(const PointCloud& cloud, const cv::Vec3d& seed, const RegionSelection& selection = {},
                               const ProgressCallback& progress = nullptr);

// Indices of the cloud's points whose projection by `cloud_to_screen` (a 4 x 4 projective map into
// screen pixels: x, y, _, w; points with w <= 0 are behind the eye) falls inside `polygon` (a lasso
// drawn on the screen, closed implicitly; even-odd rule). Every point under the lasso is taken,
// hidden ones too. Throws Error("polygon", ...) for fewer than 3 corners.
std::vector<int> select_in_polygon(const PointCloud& cloud, const cv::Matx44d& cloud_to_screen,
                                   const std::vector<cv::Vec2d>& polygon);

enum class FitConstraint { Free, Parallel, Perpendicular, Coaxial };

struct RegionFitOptions {
    bool automatic = true;           // choose the kind from the residuals; false: fit `kind`
    ShapeKind kind = ShapeKind::Plane;
    bool planes = true, cylinders = true, spheres = true, cones = true;  // kinds the automatic choice may take
    // The scan's noise (sigma). 0: the best fit's RMS stands for it.
    double noise_mm = 0;
    // The simplest kind (plane, sphere, cylinder, cone) whose RMS is within max(accept_factor x
    // noise, (1 + margin) x the best RMS) is chosen: a curved shape must fit clearly better.
    double accept_factor = 1.5, margin = 0.1;
    // With a given noise, a region no kind fits within reject_factor x noise is refused.
    double reject_factor = 3;
    double min_cone_half_angle_deg = 2;  // a narrower cone is a cylinder
    // A constraint to a reference feature: its direction (a plane's normal, an axis) and, for
    // Coaxial, a point on its axis. Plane: Parallel (normal along it), Perpendicular (normal square
    // to it). Cylinder: Parallel, Perpendicular (axis), Coaxial. Cone: Parallel, Coaxial. Sphere:
    // Coaxial (centre on the axis).
    FitConstraint constraint = FitConstraint::Free;
    cv::Vec3d reference_point{0, 0, 0}, reference_direction{0, 0, 1};
    // > 0: a cylinder's or sphere's diameter within snap_tolerance_mm of a multiple of this is
    // set to it and the rest refitted; kept only when the RMS stays within the accept threshold.
    double snap_step_mm = 0, snap_tolerance_mm = 0.05;
};

struct RegionFit {
    DetectedShape shape;             // the chosen fit; shape.inliers is the region
    double noise_mm = 0;             // the noise used (given, or the best RMS)
    // RMS of each kind's fit (negative: not tried).
    double plane_rms_mm = -1, sphere_rms_mm = -1, cylinder_rms_mm = -1, cone_rms_mm = -1;
    bool snapped = false;
    double fitted_radius_mm = 0;     // before snapping
    std::string report;              // one line: the kinds' RMS and why this one
};

// Throws Error("region", ...) for fewer than 10 points or when no kind fits within
// reject_factor x noise, Error("constraint", ...) for a constraint the kind cannot take,
// Error("reference_direction", ...) for a zero direction.
// `progress` is told before each kind is fitted and at each iteration of its least-squares fit;
// answering false cancels (Error("cancelled", ...)).
RegionFit fit_region(const PointCloud& cloud, const std::vector<int>& region, const RegionFitOptions& options = {},
                     const ProgressCallback& progress = nullptr);

// The scan's noise (sigma) around `centre`: the median RMS of quadrics fitted to small
// neighbourhoods of up to 200 of the points within radius_mm of it (curvature does not count;
// the few neighbourhoods across an edge do not move the median). Throws Error("cloud", ...)
// when too few points lie there.
double estimate_noise(const PointCloud& cloud, const cv::Vec3d& centre, double radius_mm);
// The same over the whole scan: the median over up to 200 neighbourhoods spread evenly over its
// points. A mesh made from the scan is no measure of it (a mesher that flattens a face leaves its
// cut no noise): hosts take a default tolerance from this. Throws Error("cloud", ...) for fewer
// than 24 finite points.
double estimate_scan_noise(const PointCloud& cloud);

// The face at `seed` (see GrownFace). `fit` gives the kinds allowed (automatic with its kind
// flags and constraint, or its one kind), the noise (0: estimated) and reject_factor.
// Throws Error("seed", ...) when no kind fits even the smallest ball at the point or the face
// holds less than 2/3 of the points within seed_radius_mm / 2 of it (an edge or a corner),
// Error("region", ...) when the face is too small to tell its kind or size (fewer than
// 30 points; a curved kind whose points bend less than reject_factor x the noise; two curved
// kinds that fit it alike), and as select_region does for bad options or cancelling.
GrownFace grow_face(const PointCloud& cloud, const cv::Vec3d& seed, const RegionSelection& selection,
                    const RegionFitOptions& fit = {}, const ProgressCallback& progress = nullptr);

std::string to_string(FitConstraint constraint);

}  // namespace picoscan
