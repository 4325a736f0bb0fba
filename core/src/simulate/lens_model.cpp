#include "simulate/lens_model.h"

#include "picoscan/error.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace picoscan::detail {

LensModel::LensModel(const cv::Matx33d& matrix, const cv::Mat& distortion, cv::Size image_size,
                     const std::string& name) {
    fx_ = matrix(0, 0);
    fy_ = matrix(1, 1);
    cx_ = matrix(0, 2);
    cy_ = matrix(1, 2);
    skew_ = matrix(0, 1);
    if (!(std::isfinite(fx_) && std::isfinite(fy_) && fx_ > 0 && fy_ > 0 && std::isfinite(cx_) &&
          std::isfinite(cy_) && std::isfinite(skew_)))
        throw Error(name, "camera matrix needs finite, positive focal lengths");
    if (image_size.width <= 0 || image_size.height <= 0)
        throw Error(name, "image size must be positive");

    if (!distortion.empty()) {
        cv::Mat coeffs;
        distortion.convertTo(coeffs, CV_64F);
        if (coeffs.rows != 1 && coeffs.cols != 1)
            throw Error(name, "distortion must be a vector of coefficients");
        coeffs = coeffs.reshape(1, 1);
        const int count = coeffs.cols;
        if (count != 4 && count != 5 && count != 8 && count != 12 && count != 14)
            throw Error(name, "distortion needs 4, 5, 8, 12 or 14 coefficients, got " + std::to_string(count));
        for (int i = 0; i < count; ++i) {
            const double value = coeffs.at<double>(0, i);
            if (!std::isfinite(value)) throw Error(name, "distortion coefficient " + std::to_string(i) + " is not finite");
            if (i < 12) k_[i] = value;
            else if (value != 0.0) throw Error(name, "tilted-sensor distortion (tau_x, tau_y) is not supported");
        }
    }
    has_distortion_ = std::any_of(k_.begin(), k_.end(), [](double v) { return v != 0.0; });
    rational_ = k_[5] != 0.0 || k_[6] != 0.0 || k_[7] != 0.0;
    if (!has_distortion_) return;

    // Radius up to which the distortion stays one-to-one: the first radius (on any of a
    // ring of directions) where the Jacobian determinant stops being positive. Points beyond
    // it could fold back into the image, so project()/undistort() refuse them. The search
    // only needs to reach well past the image (whose corners are the farthest points).
    double corner_r = 0;
    for (const cv::Vec2d& corner : {cv::Vec2d(-0.5, -0.5), cv::Vec2d(image_size.width - 0.5, -0.5),
                                   cv::Vec2d(-0.5, image_size.height - 0.5),
                                   cv::Vec2d(image_size.width - 0.5, image_size.height - 0.5)})
        corner_r = std::max(corner_r, cv::norm(from_pixel(corner)));
    const int directions = 64;
    double max_r = 0;
    for (double r_limit = std::max(1.0, 3.0 * corner_r);; r_limit *= 2) {
        const double step = r_limit / 1000;
        max_r = r_limit;
        double reach = std::numeric_limits<double>::infinity();  // distorted radius at max_r, least over directions
        for (int a = 0; a < directions; ++a) {
            const double angle = 2.0 * CV_PI * a / directions;
            const double c = std::cos(angle), s = std::sin(angle);
            double r = step;
            for (; r <= max_r; r += step) {
                const Evaluation e = evaluate(r * c, r * s);
                if (!(e.j00 * e.j11 - e.j01 * e.j10 > 0.0)) {
                    max_r = r - step;
                    break;
                }
            }
            const Evaluation e = evaluate(max_r * c, max_r * s);
            reach = std::min(reach, std::hypot(e.x, e.y));
        }
        // Done when the mapping folds, or when it carries the searched disc well past the image.
        if (max_r < r_limit || reach > 1.5 * corner_r || r_limit >= 20.0) break;
    }
    max_r2_ = max_r * max_r;
}

// Distortion of (x, y) and its Jacobian, on plain doubles so the Newton loop stays in registers.
inline LensModel::Evaluation LensModel::evaluate(double x, double y) const {
    const double k1 = k_[0], k2 = k_[1], p1 = k_[2], p2 = k_[3], k3 = k_[4];
    const double s1 = k_[8], s2 = k_[9], s3 = k_[10], s4 = k_[11];
    const double r2 = x * x + y * y;
    const double num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double num_d = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
    double g = num, g_d = num_d;  // radial factor and dg/d(r2)
    if (rational_) {              // divisions only for the 8+ coefficient model
        const double k4 = k_[5], k5 = k_[6], k6 = k_[7];
        const double den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6));
        const double den_d = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2);
        g = num / den;
        g_d = (num_d * den - num * den_d) / (den * den);
    }
    const double prism_x = s1 + 2.0 * s2 * r2;  // d(thin prism x term)/d(r2)
    const double prism_y = s3 + 2.0 * s4 * r2;
    Evaluation e;
    e.x = x * g + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + r2 * (s1 + s2 * r2);
    e.y = y * g + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + r2 * (s3 + s4 * r2);
    e.j00 = g + 2.0 * x * x * g_d + 2.0 * p1 * y + 6.0 * p2 * x + 2.0 * x * prism_x;
    e.j01 = 2.0 * x * y * g_d + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * y * prism_x;
    e.j10 = 2.0 * x * y * g_d + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * x * prism_y;
    e.j11 = g + 2.0 * y * y * g_d + 6.0 * p1 * y + 2.0 * p2 * x + 2.0 * y * prism_y;
    return e;
}

void LensModel::distort_with_jacobian(const cv::Vec2d& p, cv::Vec2d& d, cv::Matx22d& jacobian) const {
    const Evaluation e = evaluate(p[0], p[1]);
    d = cv::Vec2d(e.x, e.y);
    jacobian = cv::Matx22d(e.j00, e.j01, e.j10, e.j11);
}

cv::Vec2d LensModel::distort(const cv::Vec2d& undistorted) const {
    if (!has_distortion_) return undistorted;
    cv::Vec2d d;
    cv::Matx22d j;
    distort_with_jacobian(undistorted, d, j);
    return d;
}

bool LensModel::undistort(const cv::Vec2d& distorted, cv::Vec2d& undistorted, const cv::Vec2d* start,
                          cv::Matx22d* jacobian) const {
    if (!has_distortion_) {
        undistorted = distorted;
        if (jacobian) *jacobian = cv::Matx22d::eye();
        return true;
    }
    // Newton's method on distort(p) = distorted, started from a neighbour's solution or the
    // distorted point itself (distortion is a small perturbation of the identity inside the
    // image). Halving the step when the residual grows keeps strong distortion from running away.
    const double tx = distorted[0], ty = distorted[1];
    double x = start ? (*start)[0] : tx, y = start ? (*start)[1] : ty;
    Evaluation e = evaluate(x, y);
    double rx = e.x - tx, ry = e.y - ty;
    double residual2 = rx * rx + ry * ry;
    const double rounding = 1e-15 * (1.0 + std::abs(tx) + std::abs(ty));
    const double floor2 = rounding * rounding;
    for (int iteration = 0; iteration < 60 && residual2 > floor2; ++iteration) {
        const double det = e.j00 * e.j11 - e.j01 * e.j10;
        if (!(std::abs(det) > 1e-300)) return false;
        const double step_x = (e.j11 * rx - e.j01 * ry) / det;
        const double step_y = (e.j00 * ry - e.j10 * rx) / det;
        double scale = 1.0;
        bool improved = false;
        for (int halving = 0; halving < 30; ++halving) {
            const double cx = x - scale * step_x, cy = y - scale * step_y;
            const Evaluation ec = evaluate(cx, cy);
            const double crx = ec.x - tx, cry = ec.y - ty;
            const double c2 = crx * crx + cry * cry;
            if (c2 < residual2) {
                x = cx;
                y = cy;
                e = ec;
                rx = crx;
                ry = cry;
                residual2 = c2;
                improved = true;
                break;
            }
            // Near the solution a failed full step only means rounding noise: stop.
            if (residual2 < 1e6 * floor2) break;
            scale *= 0.5;
        }
        if (!improved) break;
    }
    if (!(residual2 < 1e6 * floor2)) return false;  // not converged (to ~1e-12)
    if (x * x + y * y > max_r2_) return false;
    undistorted = cv::Vec2d(x, y);
    if (jacobian) *jacobian = cv::Matx22d(e.j00, e.j01, e.j10, e.j11);
    return true;
}

cv::Vec2d LensModel::to_pixel(const cv::Vec2d& distorted) const {
    return {fx_ * distorted[0] + skew_ * distorted[1] + cx_, fy_ * distorted[1] + cy_};
}

cv::Vec2d LensModel::from_pixel(const cv::Vec2d& pixel) const {
    const double y = (pixel[1] - cy_) / fy_;
    const double x = (pixel[0] - cx_ - skew_ * y) / fx_;
    return {x, y};
}

bool LensModel::project(const cv::Vec3d& point, cv::Vec2d& pixel) const {
    if (!(point[2] > 0.0)) return false;
    const cv::Vec2d normalised(point[0] / point[2], point[1] / point[2]);
    if (normalised.dot(normalised) > max_r2_) return false;
    pixel = to_pixel(distort(normalised));
    return true;
}

bool LensModel::pixel_ray(const cv::Vec2d& pixel, cv::Vec3d& direction) const {
    cv::Vec2d p;
    if (!undistort(from_pixel(pixel), p)) return false;
    direction = cv::normalize(cv::Vec3d(p[0], p[1], 1.0));
    return true;
}

}  // namespace picoscan::detail
