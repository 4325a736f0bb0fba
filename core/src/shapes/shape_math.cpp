#include "shape_math.h"

#include <algorithm>
#include <cmath>

namespace picoscan::shape_math {

std::pair<cv::Vec3d, cv::Vec3d> perpendicular_basis(const cv::Vec3d& axis) {
    const cv::Vec3d helper = std::abs(axis[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
    const cv::Vec3d first = cv::normalize(axis.cross(helper));
    return {first, axis.cross(first)};
}

double radial_distance(const cv::Vec3d& point, const cv::Vec3d& axis_point, const cv::Vec3d& axis) {
    const cv::Vec3d offset = point - axis_point;
    return cv::norm(offset - offset.dot(axis) * axis);
}

double cone_distance(const cv::Vec3d& point, const cv::Vec3d& apex, const cv::Vec3d& axis, double half_angle_rad) {
    const cv::Vec3d offset = point - apex;
    const double along = offset.dot(axis);
    const double across = cv::norm(offset - along * axis);
    return across * std::cos(half_angle_rad) - along * std::sin(half_angle_rad);
}

void least_squares(int parameter_count, const std::function<void(const std::vector<double>&, std::vector<double>&)>& residuals,
                   const std::function<void(const std::vector<double>&)>& apply, int iterations,
                   const StepCheck& check_step) {
    if (parameter_count == 0) return;
    std::vector<double> delta(parameter_count, 0.0), current, moved;
    residuals(delta, current);
    const int count = int(current.size());
    auto cost_of = [](const std::vector<double>& r) {
        double sum = 0;
        for (double value : r) sum += value * value;
        return sum;
    };
    double cost = cost_of(current), damping = 1e-4;
    const double step = 1e-7;
    for (int iteration = 0; iteration < iterations; ++iteration) {
        if (check_step) check_step();
        cv::Mat jacobian(count, parameter_count, CV_64F);
        for (int p = 0; p < parameter_count; ++p) {
            std::fill(delta.begin(), delta.end(), 0.0);
            delta[p] = step;
            residuals(delta, moved);
            for (int i = 0; i < count; ++i) jacobian.at<double>(i, p) = (moved[i] - current[i]) / step;
        }
        const cv::Mat normal = jacobian.t() * jacobian;
        const cv::Mat gradient = jacobian.t() * cv::Mat(current);
        bool improved = false;
        for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
            cv::Mat damped = normal.clone();
            for (int p = 0; p < parameter_count; ++p) damped.at<double>(p, p) *= 1.0 + damping;
            cv::Mat solution;
            if (!cv::solve(damped, -gradient, solution, cv::DECOMP_SVD)) break;
            for (int p = 0; p < parameter_count; ++p) delta[p] = solution.at<double>(p);
            residuals(delta, moved);
            const double moved_cost = cost_of(moved);
            if (moved_cost < cost) {
                apply(delta);
                residuals(std::vector<double>(parameter_count, 0.0), current);
                improved = cost - moved_cost > 1e-12 * cost;
                cost = cost_of(current);
                damping = std::max(damping * 0.1, 1e-9);
                if (!improved) return;  // converged
            } else {
                damping *= 10;
            }
        }
        if (!improved) return;
    }
}

namespace {

// The tilt moves the freedom allows: none, one (square to a reference) or two.
std::vector<cv::Vec3d> tilt_directions(const cv::Vec3d& axis, const Freedom& freedom) {
    if (!freedom.direction) return {};
    if (cv::norm(freedom.keep_perpendicular_to) > 0) return {cv::normalize(axis.cross(freedom.keep_perpendicular_to))};
    const auto [first, second] = perpendicular_basis(axis);
    return {first, second};
}

}  // namespace

void refine_cylinder(DetectedShape& shape, const std::vector<cv::Vec3d>& points, const Freedom& freedom,
                     const StepCheck& step) {
    cv::Vec3d axis_point = shape.point, axis = shape.direction;
    double radius = shape.radius_mm;
    // Moves: axis tilt (0 to 2), axis shift perpendicular to it (0 or 2), radius (0 or 1).
    const int tilts = int(tilt_directions(axis, freedom).size()), shifts = freedom.position ? 2 : 0;
    const int count = tilts + shifts + (freedom.size ? 1 : 0);
    auto moved = [&](const std::vector<double>& d, cv::Vec3d& p, cv::Vec3d& a, double& r) {
        const std::vector<cv::Vec3d> tilt = tilt_directions(axis, freedom);
        const auto [first, second] = perpendicular_basis(axis);
        a = axis;
        for (int i = 0; i < tilts; ++i) a += d[i] * tilt[i];
        a = cv::normalize(a);
        p = axis_point;
        if (shifts) p += d[tilts] * first + d[tilts + 1] * second;
        r = radius + (freedom.size ? d[tilts + shifts] : 0.0);
    };
    least_squares(
        count,
        [&](const std::vector<double>& d, std::vector<double>& out) {
            cv::Vec3d p, a;
            double r;
            moved(d, p, a, r);
            out.resize(points.size());
            for (size_t i = 0; i < points.size(); ++i) out[i] = radial_distance(points[i], p, a) - r;
        },
        [&](const std::vector<double>& d) { moved(d, axis_point, axis, radius); }, 30, step);
    shape.point = axis_point;
    shape.direction = axis;
    shape.radius_mm = radius;
}

void refine_sphere(DetectedShape& shape, const std::vector<cv::Vec3d>& points, const Freedom& freedom,
                   const StepCheck& step) {
    cv::Vec3d centre = shape.point;
    double radius = shape.radius_mm;
    const int moves = !freedom.position ? 0 : freedom.along_axis_only ? 1 : 3;
    auto moved = [&](const std::vector<double>& d, cv::Vec3d& c, double& r) {
        c = centre;
        if (moves == 1) c += d[0] * shape.direction;
        if (moves == 3) c += cv::Vec3d(d[0], d[1], d[2]);
        r = radius + (freedom.size ? d[moves] : 0.0);
    };
    least_squares(
        moves + (freedom.size ? 1 : 0),
        [&](const std::vector<double>& d, std::vector<double>& out) {
            cv::Vec3d c;
            double r;
            moved(d, c, r);
            out.resize(points.size());
            for (size_t i = 0; i < points.size(); ++i) out[i] = cv::norm(points[i] - c) - r;
        },
        [&](const std::vector<double>& d) { moved(d, centre, radius); }, 30, step);
    shape.point = centre;
    shape.radius_mm = radius;
}

void refine_cone(DetectedShape& shape, const std::vector<cv::Vec3d>& points, const Freedom& freedom,
                 const StepCheck& step) {
    cv::Vec3d apex = shape.point, axis = shape.direction;
    double half_angle = shape.half_angle_deg * kPi / 180;
    // Moves: apex (3, or 1 along the axis when the axis line is fixed), axis tilt (0 to 2), half angle (0 or 1).
    const int apex_moves = freedom.position ? 3 : 1, tilts = int(tilt_directions(axis, freedom).size());
    auto moved = [&](const std::vector<double>& d, cv::Vec3d& p, cv::Vec3d& a, double& angle) {
        const std::vector<cv::Vec3d> tilt = tilt_directions(axis, freedom);
        p = apex + (apex_moves == 3 ? cv::Vec3d(d[0], d[1], d[2]) : d[0] * axis);
        a = axis;
        for (int i = 0; i < tilts; ++i) a += d[apex_moves + i] * tilt[i];
        a = cv::normalize(a);
        angle = half_angle + (freedom.size ? d[apex_moves + tilts] : 0.0);
    };
    least_squares(
        apex_moves + tilts + (freedom.size ? 1 : 0),
        [&](const std::vector<double>& d, std::vector<double>& out) {
            cv::Vec3d p, a;
            double angle;
            moved(d, p, a, angle);
            out.resize(points.size());
            for (size_t i = 0; i < points.size(); ++i) out[i] = cone_distance(points[i], p, a, angle);
        },
        [&](const std::vector<double>& d) { moved(d, apex, axis, half_angle); }, 30, step);
    shape.point = apex;
    shape.direction = axis;
    shape.half_angle_deg = half_angle * 180 / kPi;
}

}  // namespace picoscan::shape_math
