// Pictures and an HTML report of a rig calibration.
#pragma once

#include "picoscan/board.h"
#include "picoscan/calibrate.h"
#include <opencv2/core.hpp>
#include <string>

namespace picoscan {
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
