// Binocular structured light: two calibrated cameras, a projector that only labels pixels.
//
// Each camera decodes the projector's codes (its absolute phase); the two images are
// rectified, and each left pixel is matched to the sub-pixel position on the same rectified
// row of the right image whose code is equal. The projector needs no calibration, and its
// lens and response (gamma) errors are the same in both cameras, so they largely cancel.
// Convention: X_right = R * X_left + T (OpenCV's stereoCalibrate), millimetres, pixel centres
// at integer coordinates.
#pragma once

#include "picoscan/board.h"
#include "picoscan/calibration.h"
#include "picoscan/capture_set.h"
#include "picoscan/cloud.h"
#include "picoscan/decode.h"
#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace picoscan {

struct StereoCalibration {
    cv::Size left_size, right_size;
    cv::Matx33d left_matrix = cv::Matx33d::eye(), right_matrix = cv::Matx33d::eye();
    cv::Mat left_distortion = cv::Mat::zeros(1, 5, CV_64F);  // OpenCV order k1 k2 p1 p2 [k3 ...]
    cv::Mat right_distortion = cv::Mat::zeros(1, 5, CV_64F);
    cv::Matx33d R = cv::Matx33d::eye();  // left -> right rotation
    cv::Vec3d T{0, 0, 0};                // left -> right translation, mm

    double baseline_mm() const;  // distance between the camera centres
};

// Which calibration a file holds: one camera and a projector, or two cameras.
enum class CalibrationKind { CameraProjector, Stereo };
// Decided by the keys: a second camera's intrinsics (camera2_matrix, M2 or cam2_intrinsics)
// make it a stereo file. Throws Error naming the file when it cannot be read.
CalibrationKind calibration_kind(const std::string& path);

// Reads a stereo calibration: PicoScan's keys (camera1_size camera1_matrix camera1_distortion
// camera2_* R T), OpenCV's stereo sample (M1 D1 M2 D2 R T, optional R1 R2 P1 P2 Q, which are
// not used), OpenCV's structured-light tutorial (cam1_intrinsics cam1_distorsion cam1_size
// cam2_* R T), Rlr/Tlr for R/T, and S, image_size or imageSize for a size both cameras share.
// Throws Error naming the file and the missing, duplicated or malformed key.
StereoCalibration read_stereo_calibration(const std::string& path);

// Writes PicoScan's keys through a temporary file and a rename.
void write_stereo_calibration(const StereoCalibration& calibration, const std::string& path);

// Checks sizes, matrix shapes, R a rotation, T finite and non-zero; throws Error naming
// `source` and the bad key.
void validate_stereo_calibration(const StereoCalibration& calibration, const std::string& source);

// The stereo pair implied by two camera-projector calibrations that share one projector.
StereoCalibration stereo_from_projector_calibrations(const Calibration& left, const Calibration& right);

// ---------------------------------------------------------------------------------------
// Calibrating two cameras from images of a board both see.

struct StereoCalibrateOptions {
    double max_view_rms_px = 1.0;  // poses with a larger RMS in either camera are dropped, with the reason
    int min_views = 3;             // fewer usable poses is an error
    int recommended_views = 10;    // fewer gives a warning
    double min_pose_spread_deg = 5.0;  // largest angle between board orientations; less is degenerate
    // Lens model: k1 k2 p1 p2, plus k3 when true (wide-angle lenses). With ordinary lenses a
    // free k3 trades off against k2 and the principal point, which turns the cameras' relative
    // rotation (MATLAB's calibrator also fits two radial terms by default).
    bool radial_k3 = false;
};

// A pose folder's board image: with a manifest (or DIR/sequence.json) the capture set's white
// frame, else the mean of its phase frames; without one, the folder's only image file.
// Throws Error naming the folder.
cv::Mat load_board_image(const std::string& directory, const std::string& manifest = "");

// One board pose: the board image of each camera (a white frame is enough) and a name.
struct StereoBoardView {
    std::string name;
    cv::Mat left, right;  // grey or colour, 8 or 16 bit
};

struct StereoPoseReport {
    std::string name;
    bool used = false;
    std::string reason;  // why it was not used
    int corners = 0;     // corners both cameras found
    double left_rms_px = 0, right_rms_px = 0;
    double epipolar_rms_px = 0;  // distance of the right corners from the left corners' epipolar lines
};

struct StereoCalibrationReport {
    StereoCalibration calibration;
    double left_rms_px = 0, right_rms_px = 0, stereo_rms_px = 0, epipolar_rms_px = 0;
    std::vector<StereoPoseReport> poses;
    std::vector<std::string> warnings;
};

// Detects the board in both images of every pose (detect_board), calibrates each camera
// (Zhang), then both together with their relative pose (stereo calibration). Unusable poses
// are reported with the reason; throws Error naming the poses when too few remain, when the
// image sizes differ between poses, or when the poses are degenerate (all parallel).
StereoCalibrationReport calibrate_stereo(const std::vector<StereoBoardView>& views, const BoardSpec& board,
                                         const StereoCalibrateOptions& options = {},
                                         const ProgressCallback& progress = nullptr);

// Re-estimates the rotation and the direction of the baseline from the projector codes both
// cameras decoded (columns and rows needed), keeping both cameras' intrinsics and the
// baseline's length: for a rig whose cameras moved since calibration, or a file whose R, T
// do not fit the captures. The code of every third first-camera pixel is located in both
// cameras (a linear fit of pixel position against code over the code cell's pixels), and
// an essential matrix is fitted with RANSAC on the undistorted pairs and decomposed.
// Throws Error when rows are missing, too few codes are shared, or too few pairs agree.
struct ExtrinsicsRefinement {
    StereoCalibration calibration;
    int pairs = 0, inliers = 0;
    double median_epipolar_before_px = 0, median_epipolar_after_px = 0;  // first camera's pixels
    double rotation_change_deg = 0;
};
ExtrinsicsRefinement refine_stereo_extrinsics(const CorrespondenceMap& left, const CorrespondenceMap& right,
                                              const StereoCalibration& calibration);

// A self-contained HTML page with the errors per pose and camera, the epipolar error and the
// rig; written through a temporary file and a rename.
void write_stereo_calibration_report(const StereoCalibrationReport& report, const std::string& path);

// ---------------------------------------------------------------------------------------
// Binocular reconstruction.

struct StereoOptions {
    // A left pixel's match must lead back, searching the left row for the right code, to
    // within this of the pixel (rectified pixels).
    double max_left_right_difference_px = 1.0;
    // Neighbouring rectified pixels whose column codes differ by more than this (projector
    // pixels) are not interpolated between: a depth jump or a wrong code.
    double max_code_step_px = 8.0;
    // Where both cameras decoded projector rows: a match whose row codes disagree by more than
    // this many rectified pixels across the row is dropped, and when the median of all matches
    // does, the calibration does not fit the captures and the reconstruction is refused.
    double max_epipolar_error_px = 1.0;
    double min_depth_mm = 1.0;  // points nearer than this (or behind) are dropped
    double max_depth_mm = 1e5;
};

// What happened to the left camera's pixels.
struct StereoStatistics {
    int left_decoded = 0;           // left pixels with a column code
    int matched = 0;                // a single crossing of that code on the right row
    int ambiguous = 0;              // the code crosses the right row more than once
    int left_right_consistent = 0;  // matches that lead back to their pixel
    int epipolar_rejected = 0;      // consistent matches whose row codes disagree
    int behind = 0;                 // consistent matches that triangulate behind the cameras
    int valid = 0;                  // points triangulated
    double median_epipolar_error_px = std::numeric_limits<double>::quiet_NaN();  // NaN without rows
    // Three-view triangulation (a camera-projector calibration given): points refined with the
    // projector as a third view, and the median distance of their projector column from the
    // decoded one (projector pixels; NaN without).
    int three_view = 0;
    double median_projector_residual_px = std::numeric_limits<double>::quiet_NaN();
    double left_right_consistency() const { return matched > 0 ? double(left_right_consistent) / matched : 0; }
};

struct StereoReconstruction {
    ScanView view;  // organised on the left camera's pixel grid, left camera frame
    StereoStatistics statistics;
};

// Rectifies once per calibration (each camera's rays, the rectified grids and where they
// sample the images), then matches and triangulates any number of decoded pairs.
class StereoMatcher {
public:
    explicit StereoMatcher(const StereoCalibration& calibration);
    // Three views: `projector` is a camera-projector calibration of the first camera with the
    // projector that lit the captures. Each point is then placed on its first-camera ray where
    // it best explains the first camera's projector codes and the second camera's match
    // together (Gauss-Newton), rather than from the two cameras alone. The projector's lens and
    // response errors then count again (the two-camera path cancels them). reconstruct() throws
    // Error when the projector's columns do not fit the points (a median over 1 projector pixel).
    // Throws Error when the calibration is invalid or its camera size is not the first camera's.
    StereoMatcher(const StereoCalibration& calibration, const Calibration& projector);
    ~StereoMatcher();
    StereoMatcher(StereoMatcher&&) noexcept;
    StereoMatcher& operator=(StereoMatcher&&) noexcept;

    // `colour` (CV_8UC3 of the left size, optional) colours the points. Throws Error when the
    // maps' sizes differ from the calibration's, when the left map has no column code, and
    // when the row codes show that the calibration does not fit the captures.
    StereoReconstruction reconstruct(const CorrespondenceMap& left, const CorrespondenceMap& right,
                                     const cv::Mat& colour = cv::Mat(), const StereoOptions& options = {},
                                     const ProgressCallback& progress = nullptr) const;

    // The rectified common frame: rotation of each camera into it and the rectified
    // intrinsics (the same focal length and cy for both), for pictures and checks.
    cv::Matx33d left_rectification() const;
    cv::Matx33d right_rectification() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Decodes both capture sets (decode, columns and, where projected, rows) and reconstructs.
// Throws Error naming the calibration file when a camera's size differs from its captures.
StereoReconstruction reconstruct_stereo(const CaptureSet& left, const CaptureSet& right,
                                        const StereoCalibration& calibration, const DecodeOptions& decode_options = {},
                                        const StereoOptions& options = {}, const ProgressCallback& progress = nullptr);

}  // namespace picoscan
