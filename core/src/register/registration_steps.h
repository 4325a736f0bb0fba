// The steps of registration, shared by register_pair and align_views.
#pragma once

#include "picoscan/register.h"
#include "register/point_grid.h"
#include "register/visibility.h"

#include <opencv2/core.hpp>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace picoscan::detail {

// ORB keypoints of a view's white frame that land on a measured point, with that point.
struct ViewFeatures {
    std::vector<cv::Vec3d> points;  // view frame
    cv::Mat descriptors;            // one row per point
};
// measured_area: measured_bounds(view).
ViewFeatures view_features(const ScanView& view, const cv::Rect& measured_area, int max_features);

// Fast point feature histograms (Rusu et al. 2009) of the samples thinned to spacing_mm,
// over neighbourhoods of radius_mm: for views whose white frames share too few features
// (large viewpoint changes, plain parts). Descriptors are CV_32F.
ViewFeatures geometric_features(const SurfaceSamples& samples, double spacing_mm, double radius_mm);

// Least-squares rigid transform taking `from` onto `to` (Kabsch / Umeyama without scale).
cv::Matx44d rigid_fit(const std::vector<cv::Vec3d>& from, const std::vector<cv::Vec3d>& to);

struct CoarseAlignment {
    cv::Matx44d transform = cv::Matx44d::eye();  // moving -> fixed
    int matches = 0;
    int inliers = 0;
};
// Matches descriptors and fits rigid transforms by RANSAC on the 3D points: the best few
// distinct hypotheses, most inliers first (a symmetric part has several good ones).
std::vector<CoarseAlignment> match_features(const ViewFeatures& fixed, const ViewFeatures& moving,
                                            const RegistrationOptions& options, int hypotheses = 1);

struct IcpResult {
    cv::Matx44d transform = cv::Matx44d::eye();  // moving -> fixed
    double rms_mm = 0;
    double overlap = 0;  // matched moving samples / the smaller sample count
    bool converged = false;
    // Correlation of the white-frame levels of paired points: near 1 when the paint lines up,
    // near 0 when a symmetric shape was matched the wrong way round; NaN without texture.
    double texture_agreement = std::numeric_limits<double>::quiet_NaN();
    // Smallest / largest eigenvalue of the point-to-plane system (centred, rotation scaled by
    // the spread): near 0 when the overlap lets the views slide (planes, a cylinder).
    double stability = 0;
    int joined = -1;     // the index of the earlier fit it stopped at (see EarlierFits), or -1
};
// Fits ICP already converged to for the same pair: a run that comes within kJoinDeg and
// kJoinMm of one (at the moving view's centroid) stops there, since it would end on that fit
// (ICP from 2 degrees and 2 mm off ends on it; register_samples skips such starts altogether).
struct EarlierFits {
    std::vector<cv::Matx44d> transforms;  // moving -> fixed
    cv::Vec3d centroid{0, 0, 0};          // of the moving view, its own frame
};
constexpr double kJoinDeg = 0.5, kJoinMm = 0.5;
// Point-to-plane ICP with trimmed correspondences, starting from `initial`. coarse_first: a
// start from features, far from its fit: the first iterations pair a subsample of the moving
// samples (the result is still reached and judged with all of them).
IcpResult icp_point_to_plane(const SurfaceSamples& fixed, const SurfaceSamples& moving, const cv::Matx44d& initial,
                             const RegistrationOptions& options, const EarlierFits& earlier = {}, bool coarse_first = false);

// The same, for several pairs of views related by one shared transform (the step of a
// turntable takes every view k+1 into view k's frame, since the camera stays where it is).
struct SamplePair { const SurfaceSamples* fixed; const SurfaceSamples* moving; };
IcpResult icp_point_to_plane(const std::vector<SamplePair>& pairs, const cv::Matx44d& initial, const RegistrationOptions& options,
                             const EarlierFits& earlier = {}, bool coarse_first = false);

// Rotation and translation -> 4x4 transform, and the inverse of such a transform.
cv::Matx44d rigid_transform(const cv::Matx33d& rotation, const cv::Vec3d& translation);
cv::Matx44d inverse_rigid(const cv::Matx44d& transform);

// Small-motion update: rotation vector (rad) and translation -> 4x4 transform.
cv::Matx44d motion_matrix(const cv::Vec3d& rotation_vector, const cv::Vec3d& translation);

// What registration needs of a view, computed once.
struct ViewData {
    SurfaceSamples samples;
    ViewFeatures features;        // ORB on the white frame (feature mode only)
    ViewCamera camera;            // for the free-space check
    bool textured = false;        // the white frame carries paint worth comparing
    cv::Vec3d centroid{0, 0, 0};  // of the samples, view frame
};
ViewData view_data(const ScanView& view, const RegistrationOptions& options, bool with_features);

// The larger fraction, of either view's points, lying where the other view's camera saw
// through (in front of what it measured): a contradiction however well the overlap fits.
double free_space_conflict(const ViewData& fixed, const ViewData& moving, const cv::Matx44d& moving_to_fixed);
constexpr double kMaxFreeSpaceConflict = 0.02;
// Below this, the overlap leaves a direction of motion unfixed (see IcpResult::stability):
// a pose found from features alone cannot be confirmed. A guided pose (turntable, earlier
// poses) keeps its guess along such a direction.
constexpr double kMinStability = 0.01;

// Multi-view refinement: every active view against every other, all poses solved together
// (view `anchor` and its group fixed; none moves without move_views). Views with the same
// entry in `groups` move as one rigid body (a turntable round); empty: each view alone.
// Returns each view's point-to-plane RMS against the others.
std::vector<double> refine_together(const std::vector<ViewData>& data, std::vector<cv::Matx44d>& poses,
                                    const std::vector<bool>& active, int anchor, bool move_views,
                                    const RegistrationOptions& options, const ProgressCallback& progress,
                                    const std::vector<int>& groups = {});

// printf of one number, for messages.
std::string format(const char* pattern, double value);

}  // namespace picoscan::detail
