// Calibrating a camera-projector rig from captures of a planar board in several poses.
#pragma once

#include "picoscan/board.h"
#include "picoscan/calibration.h"
#include "picoscan/capture_set.h"
#include "picoscan/decode.h"
#include "picoscan/progress.h"
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {
struct CalibrateOptions {
    DecodeOptions decode;
    int homography_half_window_px = 12;  // decoded pixels around a corner used for its local homography
    int min_homography_pixels = 40;       // fewer decoded pixels than this: the corner has no projector point
    double min_corner_fraction = 0.7;     // a pose needs this share of its corners with projector points
    double max_view_rms_px = 1.0;         // poses with a larger camera or projector RMS are dropped, with the reason
    int min_views = 3;                    // fewer usable poses is an error
    int recommended_views = 10;           // fewer gives a warning
    double min_pose_spread_deg = 5.0;     // largest angle between board orientations; less is degenerate
    // Fewer lens parameters for few poses: radial k1 only, and the camera's principal point at
    // the image centre (the model SLStudio uses). With the latter, the joint refinement keeps
    // both principal points where the separate calibrations put them (OpenCV's stereo
    // calibration fixes them together).
    bool radial_k1_only = false;
    bool camera_principal_point_at_centre = false;
};

// What one board pose shows: the board's corners in the camera and, where the projected codes
// allow, in the projector. Small plain data, so poses can be captured and observed one by one.
struct PoseObservation {
    std::string name;              // the pose's capture directory
    cv::Size camera_size, projector_size;
    std::string problem;           // why the pose cannot be used ("" when it can)
    std::vector<cv::Point3f> board_points;   // every corner found, board frame (mm)
    std::vector<cv::Point2f> camera_points;  // the same corners in the camera (px)
    std::vector<int> projector_corner;       // indices into the above of corners with projector points
    std::vector<cv::Point2f> projector_points;  // their projector points (px)
};

// Finds the board in the pose's white frame (or the mean of its phase frames), decodes the
// projected codes, and maps every corner into the projector through a homography fitted on
// the decoded pixels around it (Moreno & Taubin 2012). Throws Error naming the pose when its
// sequence does not encode both projector axes.
PoseObservation observe_pose(const CaptureSet& pose, const BoardSpec& board, const CalibrateOptions& options = {});

struct CalibrationPoseReport {
    std::string name;
    bool used = false;
    std::string reason;        // why it was not used
    int corners = 0;           // corners found in the camera image
    int projector_corners = 0; // of those, corners given a projector point
    double camera_rms_px = 0, projector_rms_px = 0;
};

struct CalibrationReport {
    Calibration calibration;
    double camera_rms_px = 0, projector_rms_px = 0, stereo_rms_px = 0;
    std::vector<CalibrationPoseReport> poses;
    std::vector<std::string> warnings;
    // Per used corner: reprojection residuals (px) in the camera and in the projector.
    std::vector<cv::Point2f> camera_residuals, projector_residuals;
    std::vector<cv::Point2f> camera_corners;  // all corners used, camera pixels (coverage)
    std::vector<cv::Matx44d> board_poses;     // board -> camera, per used pose
};

// Calibrates camera intrinsics, projector intrinsics and camera -> projector extrinsics from
// the observed poses. No initial projector guess is assumed: Zhang's method initialises both
// devices, then both and their relative pose are refined together (stereo calibration).
// Unusable poses are reported with the reason; throws Error naming the poses when too few
// remain, when image sizes differ, or when the poses are degenerate (all parallel).
CalibrationReport calibrate_rig(const std::vector<PoseObservation>& poses, const CalibrateOptions& options = {},
                                const ProgressCallback& progress = nullptr);

}  // namespace picoscan
