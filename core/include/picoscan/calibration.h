// Calibration of one camera and one projector (OpenCV FileStorage YAML, millimetres), and
// the procedure that measures it from captures of a board.
// Convention: X_projector = R * X_camera + T; pixel centres at integer coordinates.
#pragma once

#include "picoscan/capture_set.h"
#include "picoscan/decode.h"
#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

// The largest camera or projector image PicoScan accepts (per side, and in all): sizes read
// from files are checked against these before anything is allocated for them.
constexpr int kLargestImageSide = 16384;
constexpr int64_t kLargestImagePixels = int64_t(1) << 26;  // 64 Mpixel

struct Calibration {
    cv::Size camera_size;
    cv::Matx33d camera_matrix = cv::Matx33d::eye();
    cv::Mat camera_distortion = cv::Mat::zeros(1, 5, CV_64F);  // OpenCV order k1 k2 p1 p2 [k3 ...]
    cv::Size projector_size;
    cv::Matx33d projector_matrix = cv::Matx33d::eye();
    cv::Mat projector_distortion = cv::Mat::zeros(1, 5, CV_64F);
    cv::Matx33d R = cv::Matx33d::eye();  // camera -> projector rotation
    cv::Vec3d T{0, 0, 0};                // camera -> projector translation, mm
    // Optional: 256-entry CV_8U table that linearises the projector's response (gamma); apply
    // it to every pattern level before projecting (render_pattern's response_lut). Empty if
    // the response was not measured.
    cv::Mat projector_inverse_response;
};

// Reads a calibration file. Besides PicoScan's own keys it understands
// SLMaster's caliInfo.yml (M1 D1 S M4 D4 Rlp Tlp) and SLStudio's calibration.xml
// (Kc kc Kp kp Rp Tp frameWidth frameHeight screenResX screenResY).
// Throws Error naming the file and the missing or malformed key.
Calibration read_calibration(const std::string& path);

// Writes PicoScan's own format through a temporary file and a rename.
void write_calibration(const Calibration& calibration, const std::string& path);

// Checks sizes, matrix shapes and finiteness; throws Error naming `source` and the bad key.
void validate_calibration(const Calibration& calibration, const std::string& source);

}  // namespace picoscan

// ---------------------------------------------------------------------------------------
// Projector response (gamma) calibration.

namespace picoscan {

// Grey levels to project as flat frames for measuring the response: `count` levels from 0 to
// 255, evenly spaced.
std::vector<int> response_levels(int count = 17);

struct ProjectorResponse {
    std::vector<int> levels;
    std::vector<double> relative_light;  // camera response per level, 0 at level 0, 1 at 255
    double gamma = 1;                    // best power-law fit, for reporting
    cv::Mat inverse_lut;                 // 256 x CV_8U: level to send for each wanted light level
};

// Measures the response from camera images of flat frames of the given levels (same order),
// averaging the pixels that the projector lights well (or those in `mask`). Throws Error when
// the levels are not increasing from 0 to 255, the images differ in size, or the camera sees
// no usable change of light.
ProjectorResponse measure_projector_response(const std::vector<int>& levels, const std::vector<cv::Mat>& images,
                                             const cv::Mat& mask = cv::Mat());

}  // namespace picoscan

// ---------------------------------------------------------------------------------------
// Calibrating a camera-projector rig from captures of a planar board.

namespace picoscan {

enum class BoardKind { Chessboard, Circles, AsymmetricCircles, Charuco };

// A printed planar target. Chessboard: inner corners (columns x rows), square side.
// Circles: grid of circles (columns x rows), centre spacing. ChArUco: squares (columns x rows),
// square side, marker side, ArUco dictionary (OpenCV's predefined dictionary number).
struct BoardSpec {
    BoardKind kind = BoardKind::Chessboard;
    cv::Size size{9, 6};
    double square_mm = 10;
    double marker_mm = 0;
    int dictionary = 0;
};

// Parses "chessboard:COLSxROWS:SQUARE_MM", "circles:COLSxROWS:SPACING_MM",
// "acircles:COLSxROWS:SPACING_MM" or "charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICTIONARY]".
// Throws Error("--board", ...) explaining the expected form.
BoardSpec parse_board_spec(const std::string& text);

// The board's feature points in its own frame (z = 0, mm), in the order detection returns them.
std::vector<cv::Point3f> board_points(const BoardSpec& board);

// Features of the board found in one grey image: image points and their board-point indices.
struct BoardDetection {
    std::vector<cv::Point2f> image_points;
    std::vector<int> point_ids;
};
// Returns false when the board is not found. Sub-pixel accurate.
bool detect_board(const cv::Mat& grey, const BoardSpec& board, BoardDetection& detection);

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

// Pictures of a calibration, CV_8UC3: residuals of every corner in the camera and the projector
// (scatter plots), where in the camera image corners were seen (coverage, one colour per pose),
// and the rig drawn in 3D (camera and projector frusta, board poses), seen from above and
// obliquely.
cv::Mat plot_calibration_residuals(const CalibrationReport& report);
cv::Mat plot_calibration_coverage(const CalibrationReport& report);
cv::Mat draw_calibration_rig(const CalibrationReport& report, const BoardSpec& board);

// A self-contained HTML page (pictures embedded) with the errors per pose, the pictures above,
// the parameters and the warnings; written through a temporary file and a rename.
void write_calibration_report(const CalibrationReport& report, const BoardSpec& board, const std::string& path);

}  // namespace picoscan
