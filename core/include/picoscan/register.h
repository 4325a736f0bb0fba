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
};

struct Alignment {
    std::vector<ViewAlignment> views;  // in input order; views[0] defines the model frame
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

// How far apart two poses are: the angle (degrees) of the rotation a^-1 * b, and how far
// (mm) the two move the point `at` apart. Give `at` on the part (its centroid): measured at
// the camera origin, 400 mm away, a tiny angle would show as a large shift.
struct PoseDifference { double rotation_deg = 0; double translation_mm = 0; };
PoseDifference pose_difference(const cv::Matx44d& a, const cv::Matx44d& b, const cv::Vec3d& at = {0, 0, 0});

}  // namespace picoscan
