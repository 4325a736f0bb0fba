// A calibration's board poses must not all be parallel: such a set does not constrain the
// focal length. Shared by the camera-projector and the stereo calibration.
#pragma once

#include "picoscan/error.h"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace picoscan::detail {

// `rotations`: the boards' Rodrigues vectors in one camera. Throws Error when the largest angle
// between two board normals is below `min_spread_deg`.
inline void require_pose_spread(const std::vector<cv::Mat>& rotations, double min_spread_deg) {
    double spread_deg = 0;
    for (size_t a = 0; a < rotations.size(); ++a)
        for (size_t b = a + 1; b < rotations.size(); ++b) {
            cv::Matx33d ra, rb;
            cv::Rodrigues(rotations[a], ra);
            cv::Rodrigues(rotations[b], rb);
            const cv::Vec3d na(ra(0, 2), ra(1, 2), ra(2, 2)), nb(rb(0, 2), rb(1, 2), rb(2, 2));
            // |cos|: a board seen from its back (corners found in the opposite order) is still parallel.
            spread_deg = std::max(spread_deg, std::acos(std::clamp(std::abs(na.dot(nb)), 0.0, 1.0)) * 180 / CV_PI);
        }
    if (spread_deg >= min_spread_deg) return;
    char problem[200];
    std::snprintf(problem, sizeof problem,
                  "the board poses are degenerate: all nearly parallel (largest angle between them %.1f deg, need %.0f); "
                  "tilt the board in different directions",
                  spread_deg, min_spread_deg);
    throw Error("board poses", problem);
}

}  // namespace picoscan::detail
