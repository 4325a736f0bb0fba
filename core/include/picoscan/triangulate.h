// Triangulation of camera -> projector correspondences into an organised point cloud.
#pragma once

#include "picoscan/calibration.h"
#include "picoscan/cloud.h"
#include "picoscan/decode.h"
#include "picoscan/progress.h"

namespace picoscan {

struct TriangulateOptions {
    bool use_rows = true;           // ray-ray least squares where projector v is known
    int distortion_iterations = 4;  // refinements of the projector column plane for lens distortion
    double min_depth_mm = 1.0;      // points nearer than this (or behind) are dropped
    double max_depth_mm = 1e5;
};

// Triangulates with one calibration many times: the camera's per-pixel rays and the
// projector's undistortion table are computed once, in the constructor.
class Triangulator {
public:
    explicit Triangulator(const Calibration& calibration);

    // Camera ray ∩ projector column plane (ray-ray where v is known too), honouring both
    // lenses' distortion. `colour` (CV_8UC3, optional) colours the points.
    ScanView triangulate(const CorrespondenceMap& correspondences, const cv::Mat& colour = cv::Mat(),
                         const TriangulateOptions& options = {}, const ProgressCallback& progress = nullptr) const;

    // The same, writing into `view` and reusing its buffers when their size fits. The view's
    // quality and colour share the inputs' buffers (cv::Mat reference counting).
    void triangulate_into(const CorrespondenceMap& correspondences, const cv::Mat& colour, ScanView& view,
                          const TriangulateOptions& options = {}, const ProgressCallback& progress = nullptr) const;

private:
    Calibration calibration_;
    cv::Mat camera_rays_;     // CV_32FC2, undistorted normalised camera coordinates per pixel
    cv::Mat projector_rays_;  // CV_64FC2, undistorted normalised projector coordinates per projector pixel
    cv::Mat column_planes_;   // CV_32FC4, plane through the projector centre holding column u near
                              // row v (projector frame): unit normal n and n.T, per projector pixel
};

// Throws Error naming `calibration_name` (its file) when the calibration's camera size
// differs from the captures' image size: the wrong calibration for these captures.
// It also checks the captures' projector size, as check_projector_size does.
void check_camera_size(const Calibration& calibration, const CaptureSet& captures, const std::string& calibration_name);

// Throws Error naming `manifest_name` and `calibration_name` when the manifest's projector
// size differs from the calibration's projector_size: the decoded projector coordinates
// would not be in the calibrated projector's pixels, and every point would be wrong.
void check_projector_size(const Calibration& calibration, const PatternSequence& sequence,
                          const std::string& calibration_name, const std::string& manifest_name);

// One-off convenience: builds a Triangulator and triangulates.
ScanView triangulate(const CorrespondenceMap& correspondences, const Calibration& calibration,
                     const cv::Mat& colour = cv::Mat(), const TriangulateOptions& options = {},
                     const ProgressCallback& progress = nullptr);

}  // namespace picoscan
