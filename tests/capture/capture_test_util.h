// Helpers shared by the capture tests (with and without a display).
#pragma once

#include "picoscan/calibration.h"
#include "picoscan/simulate.h"

#include <opencv2/core.hpp>

namespace picoscan::capture_test {

// The seed rig with its camera scaled down by `factor` (same projector, same pose): quick to
// simulate while keeping the geometry.
inline Calibration small_rig(double factor) {
    Calibration rig = seed_rig_calibration();
    rig.camera_size = cv::Size(int(rig.camera_size.width * factor), int(rig.camera_size.height * factor));
    // Pixel centres are at integer coordinates: scale about the corner -0.5.
    rig.camera_matrix(0, 0) *= factor;
    rig.camera_matrix(1, 1) *= factor;
    rig.camera_matrix(0, 1) *= factor;
    rig.camera_matrix(0, 2) = (rig.camera_matrix(0, 2) + 0.5) * factor - 0.5;
    rig.camera_matrix(1, 2) = (rig.camera_matrix(1, 2) + 0.5) * factor - 0.5;
    return rig;
}

// Number of pixels where two 8-bit images differ.
inline int differing_pixels(const cv::Mat& a, const cv::Mat& b) {
    if (a.size() != b.size() || a.type() != b.type()) return int(std::max(a.total(), b.total()));
    cv::Mat difference;
    cv::compare(a, b, difference, cv::CMP_NE);
    if (difference.channels() > 1) difference = difference.reshape(1);
    return cv::countNonZero(difference);
}

}  // namespace picoscan::capture_test
