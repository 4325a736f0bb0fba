// Two or more cameras sharing one projector.
//
// Every camera is calibrated with the projector (picoscan calibrate, one Calibration per
// camera). All cameras are then known in one frame, camera 1's, and a point can be
// triangulated camera-camera through the projector codes both cameras decoded; a point that
// a second camera does not confirm (stray light, interreflections) can be rejected.
#pragma once

#include "picoscan/calibration.h"
#include "picoscan/cloud.h"
#include "picoscan/decode.h"

#include <opencv2/core.hpp>

namespace picoscan {

// Pose of camera `to` relative to camera `from` (X_to = M * X_from), derived through the
// projector both were calibrated with.
cv::Matx44d camera_to_camera(const Calibration& from, const Calibration& to);

struct CameraPairOptions {
    // Codes (projector pixels) must agree within this for camera B to confirm a point of A.
    double max_code_difference_px = 0.5;
};

// Camera-camera triangulation: for each pixel of camera A, the sub-pixel point of camera B
// that decoded the same projector (u, v), then the two camera rays intersected (the midpoint of
// their closest points). Both maps need u and v (rows projected). The result is organised on
// camera A's grid, in camera A's frame; pixels B does not see are NaN.
ScanView triangulate_camera_pair(const CorrespondenceMap& map_a, const Calibration& calibration_a,
                                 const CorrespondenceMap& map_b, const Calibration& calibration_b,
                                 const CameraPairOptions& options = {});

// Removes from `view` (camera A's organised cloud) the points camera B does not confirm: the
// point projected into B must land on a pixel that decoded the same projector code. Returns how
// many points were removed.
int reject_unconfirmed_points(ScanView& view, const Calibration& calibration_a, const CorrespondenceMap& map_b,
                              const Calibration& calibration_b, const CameraPairOptions& options = {});

}  // namespace picoscan
