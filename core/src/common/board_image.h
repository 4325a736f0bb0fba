// The image a calibration board is detected in, shared by the rig and stereo calibrations.
#pragma once

#include "picoscan/capture_set.h"

#include <opencv2/core.hpp>

namespace picoscan::detail {

// The capture set's white frame, else the mean of its phase frames; empty when it has neither.
cv::Mat board_image(const CaptureSet& captures);

}  // namespace picoscan::detail
