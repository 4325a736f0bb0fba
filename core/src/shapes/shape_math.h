// Geometry and least-squares refinement shared by shape detection and region fitting (internal).
#pragma once

#include "picoscan/shapes.h"

#include <functional>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

namespace picoscan::shape_math {

constexpr double kPi = 3.14159265358979323846;

// Two unit vectors perpendicular to `axis` and to each other.
std::pair<cv::Vec3d, cv::Vec3d> perpendicular_basis(const cv::Vec3d& axis);
double radial_distance(const cv::Vec3d& point, const cv::Vec3d& axis_point, const cv::Vec3d& axis);
double cone_distance(const cv::Vec3d& point, const cv::Vec3d& apex, const cv::Vec3d& axis, double half_angle_rad);

// Levenberg-Marquardt with a forward-difference Jacobian. The model is re-linearised around its
// current state at each step: `residuals(delta, out)` evaluates the model moved by `delta`,
// `apply(delta)` makes that move permanent. Small parameter counts (<= 6) only.
// `check_step`, when given, is called before each iteration (a cancel point: it may throw).
using StepCheck = std::function<void()>;
void least_squares(int parameter_count, const std::function<void(const std::vector<double>&, std::vector<double>&)>& residuals,
                   const std::function<void(const std::vector<double>&)>& apply, int iterations = 30,
                   const StepCheck& check_step = nullptr);

// Which parts of a shape a refinement may move (constraints to another feature, a snapped size).
struct Freedom {
    bool direction = true;               // the axis may tilt
    cv::Vec3d keep_perpendicular_to{0, 0, 0};  // non-zero: it tilts only while staying square to this
    bool position = true;                // the axis may shift (sphere: the centre may move)
    bool along_axis_only = false;        // sphere: the centre moves along `direction` only (coaxial)
    bool size = true;                    // radius (cylinder, sphere) or half angle (cone)
};

// `step` is least_squares' check_step (a cancel point).
void refine_cylinder(DetectedShape& shape, const std::vector<cv::Vec3d>& points, const Freedom& freedom = {},
                     const StepCheck& step = nullptr);
void refine_sphere(DetectedShape& shape, const std::vector<cv::Vec3d>& points, const Freedom& freedom = {},
                   const StepCheck& step = nullptr);
void refine_cone(DetectedShape& shape, const std::vector<cv::Vec3d>& points, const Freedom& freedom = {},
                 const StepCheck& step = nullptr);

}  // namespace picoscan::shape_math
