#include "common/lens.h"

#include "picoscan/error.h"

namespace picoscan::detail {

LensDistortion::LensDistortion(const cv::Mat& coefficients) {
    cv::Mat values;
    coefficients.convertTo(values, CV_64F);
    values = values.reshape(1, 1);
    const int count = values.cols;
    if (count > 14) throw Error("distortion", "more than 14 coefficients");
    for (int index = 0; index < count && index < 12; ++index) k_[index] = values.at<double>(index);
    if (count > 12 && (values.at<double>(12) != 0 || values.at<double>(13) != 0))
        throw Error("distortion", "tilted-sensor terms (tau x, tau y) are not supported");
    zero_ = true;
    for (double value : k_) zero_ = zero_ && value == 0;
}

cv::Vec2d LensDistortion::undistort(const cv::Vec2d& distorted) const {
    if (zero_) return distorted;
    cv::Vec2d estimate = distorted;
    for (int iteration = 0; iteration < 30; ++iteration) {
        const cv::Vec2d residual = distort(estimate) - distorted;
        if (std::abs(residual[0]) + std::abs(residual[1]) < 1e-14) break;
        // Jacobian by central differences: cheap and accurate enough for Newton's method.
        constexpr double step = 1e-7;
        const cv::Vec2d dx = (distort(estimate + cv::Vec2d(step, 0)) - distort(estimate - cv::Vec2d(step, 0))) / (2 * step);
        const cv::Vec2d dy = (distort(estimate + cv::Vec2d(0, step)) - distort(estimate - cv::Vec2d(0, step))) / (2 * step);
        const double determinant = dx[0] * dy[1] - dy[0] * dx[1];
        if (std::abs(determinant) < 1e-12) break;
        estimate[0] -= (dy[1] * residual[0] - dy[0] * residual[1]) / determinant;
        estimate[1] -= (-dx[1] * residual[0] + dx[0] * residual[1]) / determinant;
    }
    return estimate;
}

}  // namespace picoscan::detail
