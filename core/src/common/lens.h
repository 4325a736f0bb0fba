// OpenCV's lens distortion model (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]]), both ways.
// Normalised coordinates: x = X/Z, y = Y/Z before the intrinsic matrix.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <string>

namespace picoscan::detail {

class LensDistortion {
public:
    // `coefficients`: 1xN or Nx1 double, N in {4, 5, 8, 12, 14}; tilt terms (13, 14) must be zero.
    explicit LensDistortion(const cv::Mat& coefficients);

    bool is_zero() const { return zero_; }

    // Undistorted -> distorted normalised coordinates.
    cv::Vec2d distort(const cv::Vec2d& undistorted) const {
        const double x = undistorted[0], y = undistorted[1];
        const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
        const auto& k = k_;
        const double radial = (1 + k[0] * r2 + k[1] * r4 + k[4] * r6) / (1 + k[5] * r2 + k[6] * r4 + k[7] * r6);
        return {x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x) + k[8] * r2 + k[9] * r4,
                y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y + k[10] * r2 + k[11] * r4};
    }

    // Distorted -> undistorted, by Newton's method to ~1e-12 (exact inverse of distort()).
    cv::Vec2d undistort(const cv::Vec2d& distorted) const;

private:
    std::array<double, 12> k_{};
    bool zero_ = true;
};

// Pixel <-> normalised coordinates through an intrinsic matrix [fx s cx; 0 fy cy; 0 0 1].
inline cv::Vec2d pixel_to_normalised(const cv::Matx33d& matrix, const cv::Vec2d& pixel) {
    const double y = (pixel[1] - matrix(1, 2)) / matrix(1, 1);
    return {(pixel[0] - matrix(0, 2) - matrix(0, 1) * y) / matrix(0, 0), y};
}
inline cv::Vec2d normalised_to_pixel(const cv::Matx33d& matrix, const cv::Vec2d& normalised) {
    return {matrix(0, 0) * normalised[0] + matrix(0, 1) * normalised[1] + matrix(0, 2),
            matrix(1, 1) * normalised[1] + matrix(1, 2)};
}

}  // namespace picoscan::detail
