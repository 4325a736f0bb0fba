// Pinhole + OpenCV lens distortion of one camera or projector, in double precision.
// Used by the simulator to turn camera pixels into rays and scene points into projector pixels.
#pragma once

#include <opencv2/core.hpp>
#include <array>
#include <string>

namespace picoscan::detail {

class LensModel {
public:
    LensModel() = default;
    // `distortion`: OpenCV order k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]] (4, 5, 8 or 12
    // coefficients; 14 is accepted when the tilt terms are zero). Throws Error naming `name`.
    LensModel(const cv::Matx33d& matrix, const cv::Mat& distortion, cv::Size image_size,
              const std::string& name);

    // Normalised undistorted (x, y) -> normalised distorted (x, y).
    cv::Vec2d distort(const cv::Vec2d& undistorted) const;
    // Inverse of distort by Newton's method (to ~1e-15). False where it does not converge
    // or the result lies beyond the radius where the lens mapping stays one-to-one.
    // `start`, if given, is a guess close to the solution (e.g. from the neighbouring pixel's);
    // `jacobian`, if given, receives d(distorted)/d(undistorted) at the solution.
    bool undistort(const cv::Vec2d& distorted, cv::Vec2d& undistorted, const cv::Vec2d* start = nullptr,
                   cv::Matx22d* jacobian = nullptr) const;

    // Point in the lens frame (mm) -> distorted pixel. False behind the lens or beyond
    // the one-to-one radius (where distortion would fold far-away points into the image).
    bool project(const cv::Vec3d& point, cv::Vec2d& pixel) const;
    // Distorted pixel -> unit ray direction in the lens frame.
    bool pixel_ray(const cv::Vec2d& pixel, cv::Vec3d& direction) const;

    // Pixel <-> normalised distorted coordinates (camera matrix only, with skew).
    cv::Vec2d to_pixel(const cv::Vec2d& distorted) const;
    cv::Vec2d from_pixel(const cv::Vec2d& pixel) const;

    bool has_distortion() const { return has_distortion_; }
    double max_radius_squared() const { return max_r2_; }

private:
    struct Evaluation {
        double x, y;                // distorted point
        double j00, j01, j10, j11;  // d(distorted)/d(undistorted)
    };
    Evaluation evaluate(double x, double y) const;
    // Distortion and its Jacobian d(distorted)/d(undistorted).
    void distort_with_jacobian(const cv::Vec2d& p, cv::Vec2d& d, cv::Matx22d& jacobian) const;

    double fx_ = 1, fy_ = 1, cx_ = 0, cy_ = 0, skew_ = 0;
    // k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4
    std::array<double, 12> k_{};
    bool has_distortion_ = false;
    bool rational_ = false;  // k4..k6 in use
    double max_r2_ = 1e12;  // undistorted r^2 up to which the mapping is one-to-one
};

}  // namespace picoscan::detail
