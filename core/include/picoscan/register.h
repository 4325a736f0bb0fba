// Registering views into one model: features on the white frames lifted to 3D, a RANSAC
// rigid fit, point-to-plane ICP with trimmed correspondences, then a global refinement of
// all views together so the error does not accumulate around a full turn.
// Poses map view (camera) coordinates to model coordinates; the first view is the model frame.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace picoscan {

struct RegistrationOptions {
    int orb_features = 4000;            // ORB keypoints per white frame and simulated tilt
    double ransac_inlier_mm = 1.5;      // 3D distance for a feature match to count as an inlier
    int ransac_iterations = 20000;
    int min_ransac_inliers = 6;         // fewer: not even tried (ICP and the texture check judge the rest)
    int icp_iterations = 100;
    double icp_trim_fraction = 0.85;    // keep this best fraction of correspondences each iteration
    double icp_max_distance_mm = 3.0;   // correspondences farther apart than this are never used
    double sample_spacing_mm = 0.7;     // points are thinned to about this spacing for ICP
    double min_overlap = 0.08;          // fraction of the smaller view's points with a close partner
    int global_sweeps = 6;              // multi-view refinement passes over all views
    // align_views: view -> model guesses, one per view (a previous alignment, a manual one);
    // ICP starts from them instead of features. Empty: features (or the turntable).
    std::vector<cv::Matx44d> initial_poses;
    // align_views: the views are one full round of a turntable, in order, in equal steps
    // (360 / count degrees); the axis is unknown and is estimated from all the views together.
    bool turntable_round = false;
};

// Rigid transform turning `moving` (view coordinates) into `fixed`'s view coordinates.
struct PairRegistration {
    cv::Matx44d transform = cv::Matx44d::eye();
    int feature_matches = 0;   // ORB matches with a 3D point in both views
    int ransac_inliers = 0;
    double overlap = 0;        // fraction of points with a partner within icp_max_distance_mm
    double rms_mm = 0;         // point-to-plane RMS over the kept correspondences
    // Correlation of the white-frame levels of paired points: near 1 when the paint lines up,
    // near 0 when a symmetric shape was matched the wrong way round; NaN without texture.
    double texture_agreement = 0;
    // The larger fraction of either view's points lying where the other view's camera saw
    // through (free space): a wrong fit puts surface there however well the overlap fits.
    double free_space_conflict = 0;
    // Smallest / largest eigenvalue of the final point-to-plane system (centred and scaled):
    // near 0 when the overlap lets the views slide along each other (planes, a cylinder).
    double stability = 0;
    int alternatives = 0;      // other distinct fits that passed every check (a symmetric part)
    bool converged = false;
    std::string problem;       // why it failed, empty when it worked
};

// Registers one pair. Without `initial_guess`, the coarse alignment comes from ORB features;
// with it (a turntable step, a previous result), ICP starts from there.
PairRegistration register_pair(const ScanView& fixed, const ScanView& moving, const RegistrationOptions& options = {},
                               const std::optional<cv::Matx44d>& initial_guess = std::nullopt);

// A rotation stage: views taken every step_deg around an axis given in the camera frame.
struct TurntableAxis {
    cv::Vec3d point_mm;     // a point on the axis
    cv::Vec3d direction;    // unit; positive steps turn the part right-handed about it
    double step_deg = 45;
};

// The transform from view i's coordinates to view 0's for a part turned i steps.
cv::Matx44d turntable_pose(const TurntableAxis& axis, int step);

// Calibrates a turntable from aligned views taken in equal steps around it (view -> model
// poses, view 0 first): the common rotation axis, a point on it nearest the views' origin,
// and the mean step. Throws Error when the rotations do not share one axis within
// max_axis_spread_deg (not a turntable sequence). Use the result with --turntable next time.
TurntableAxis fit_turntable_axis(const std::vector<cv::Matx44d>& poses, double max_axis_spread_deg = 1.0);

struct ViewAlignment {
    std::string name;
    cv::Matx44d pose = cv::Matx44d::eye();  // view -> model
    bool aligned = false;
    double overlap = 0;     // best overlap with the other aligned views
    double rms_mm = 0;      // point-to-plane residual against the other views after refinement
    std::string problem;    // why it was left out, empty when aligned
    int placement = 0;      // align_placements: the placement the view belongs to
};

// align_placements: how one placement (the part set down once) was joined to the model.
struct PlacementAlignment {
    std::string name;                          // "placement 1", "placement 2", ...
    bool aligned = false;
    cv::Matx44d pose = cv::Matx44d::eye();     // placement frame (its first view's camera) -> model
    int aligned_views = 0;                     // of its views, those aligned within the placement
    double overlap = 0;       // fraction of the smaller placement cloud with a partner in the fit it joined by
    double rms_mm = 0;        // point-to-plane residual of that fit
    double noise_mm = 0;      // residual of its own views against each other: the scan's noise
    double free_space_conflict = 0;  // largest fraction of points lying where a camera of the other placement saw through
    double stability = 0;     // as PairRegistration::stability
    int alternatives = 0;     // other distinct fits that passed every check (a part that looks alike flipped)
    std::string problem;      // why it was left out, empty when aligned
};

struct Alignment {
    std::vector<ViewAlignment> views;  // in input order; views[0] defines the model frame
    // With RegistrationOptions::turntable_round: the step found (view k+1 -> view k) and how
    // many neighbouring pairs agreed on it.
    std::optional<cv::Matx44d> turntable_step;
    int turntable_supporting_pairs = 0;
    std::vector<PlacementAlignment> placements;  // align_placements only
    int aligned_count() const;
};

// Aligns all views: a tree of pairwise registrations grown from view 0, neighbours in the
// given order first (turntable order), then simultaneous multi-view point-to-plane ICP over
// every overlapping pair, which closes the loops. Views that cannot be registered are
// reported, not forced.
// `names` label the views in messages (file names). With `turntable`, its steps are the
// initial guesses instead of features.
Alignment align_views(const std::vector<ScanView>& views, const std::vector<std::string>& names,
                      const RegistrationOptions& options = {}, const std::optional<TurntableAxis>& turntable = std::nullopt,
                      const ProgressCallback& progress = nullptr);

// A scan in several placements: the part set down again between them (standing, then
// flipped to show the face it stood on), each a turntable round or a set of hand-held views.
struct PlacementPlan {
    std::vector<size_t> views;               // indices into the views; a turntable round in order
    std::optional<TurntableAxis> turntable;  // known turntable axis (camera frame) for this placement
    bool turntable_round = false;            // one full round, axis unknown (RegistrationOptions::turntable_round)
};

// Aligns each placement on its own (as align_views, with its turntable), then the placements
// to each other by their shape alone (no guess, no shared paint needed): each placement's
// views merged into one cloud, shape-histogram (FPFH) hypotheses refined by trimmed ICP,
// and a fit accepted only when it is the only one that passes, fixes the pose (nothing
// slides), fits within the scan's own noise, and puts no point where any view's camera of
// the other placement saw through. Then all views are refined together (a turntable round
// moves as one body). A placement that does not align is named with the reason, never
// forced in. The model frame is the first view of the first placement.
Alignment align_placements(const std::vector<ScanView>& views, const std::vector<std::string>& names,
                           const std::vector<PlacementPlan>& placements, const RegistrationOptions& options = {},
                           const ProgressCallback& progress = nullptr);

// How far apart two poses are: the angle (degrees) of the rotation a^-1 * b, and how far
// (mm) the two move the point `at` apart. Give `at` on the part (its centroid): measured at
// the camera origin, 400 mm away, a tiny angle would show as a large shift.
struct PoseDifference { double rotation_deg = 0; double translation_mm = 0; };
PoseDifference pose_difference(const cv::Matx44d& a, const cv::Matx44d& b, const cv::Vec3d& at = {0, 0, 0});

}  // namespace picoscan
