#include "picoscan/fit.h"

#include "picoscan/error.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace picoscan {

PlaneFit fit_plane(const std::vector<cv::Vec3f>& points) {
    if (points.size() < 3) throw Error("plane fit", "needs at least 3 points, got " + std::to_string(points.size()));
    cv::Vec3d centroid(0, 0, 0);
    for (const auto& point : points) centroid += cv::Vec3d(point);
    centroid /= double(points.size());
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (const auto& point : points) {
        const cv::Vec3d d = cv::Vec3d(point) - centroid;
        scatter += d * d.t();
    }
    cv::Mat eigenvalues, eigenvectors;
    cv::eigen(cv::Mat(scatter), eigenvalues, eigenvectors);  // descending order
    if (eigenvalues.at<double>(1) <= 1e-12 * std::max(1.0, eigenvalues.at<double>(0)))
        throw Error("plane fit", "points are collinear");
    PlaneFit fit;
    fit.normal = cv::Vec3d(eigenvectors.row(2));
    fit.offset_mm = fit.normal.dot(centroid);
    double sum_squares = 0;
    for (const auto& point : points) sum_squares += std::pow(fit.normal.dot(cv::Vec3d(point)) - fit.offset_mm, 2);
    fit.rms_mm = std::sqrt(sum_squares / points.size());
    fit.point_count = points.size();
    return fit;
}

SphereFit fit_sphere(const std::vector<cv::Vec3f>& points) {
    if (points.size() < 4) throw Error("sphere fit", "needs at least 4 points, got " + std::to_string(points.size()));
    // Algebraic start: |X|^2 = 2 c.X + (r^2 - |c|^2) is linear in c and the constant.
    cv::Vec3d mean(0, 0, 0);
    for (const auto& point : points) mean += cv::Vec3d(point);
    mean /= double(points.size());
    cv::Matx44d normal_matrix = cv::Matx44d::zeros();
    cv::Vec4d right_side(0, 0, 0, 0);
    for (const auto& point : points) {
        const cv::Vec3d p = cv::Vec3d(point) - mean;  // centred for conditioning
        const cv::Vec4d row(2 * p[0], 2 * p[1], 2 * p[2], 1.0);
        normal_matrix += row * row.t();
        right_side += row * p.dot(p);
    }
    cv::Vec4d solution;
    if (!cv::solve(normal_matrix, right_side, solution, cv::DECOMP_CHOLESKY))
        throw Error("sphere fit", "points are degenerate (planar or collinear)");
    cv::Vec3d centre(solution[0], solution[1], solution[2]);
    const double radius_squared = solution[3] + centre.dot(centre);
    if (!(radius_squared > 0)) throw Error("sphere fit", "points are degenerate");
    double radius = std::sqrt(radius_squared);

    // Gauss-Newton on r_i = |p_i - c| - R.
    for (int iteration = 0; iteration < 20; ++iteration) {
        cv::Matx44d jtj = cv::Matx44d::zeros();
        cv::Vec4d jtr(0, 0, 0, 0);
        for (const auto& point : points) {
            const cv::Vec3d d = cv::Vec3d(point) - mean - centre;
            const double distance = cv::norm(d);
            if (distance == 0) continue;
            const cv::Vec4d jacobian(-d[0] / distance, -d[1] / distance, -d[2] / distance, -1.0);
            const double residual = distance - radius;
            jtj += jacobian * jacobian.t();
            jtr += jacobian * residual;
        }
        cv::Vec4d step;
        if (!cv::solve(jtj, -jtr, step, cv::DECOMP_CHOLESKY)) break;
        centre += cv::Vec3d(step[0], step[1], step[2]);
        radius += step[3];
        if (cv::norm(step) < 1e-12) break;
    }
    SphereFit fit;
    fit.centre = centre + mean;
    fit.radius_mm = radius;
    double sum_squares = 0;
    for (const auto& point : points) sum_squares += std::pow(cv::norm(cv::Vec3d(point) - fit.centre) - radius, 2);
    fit.rms_mm = std::sqrt(sum_squares / points.size());
    fit.point_count = points.size();
    return fit;
}

namespace {

double angle_between_deg(const cv::Vec3d& a, const cv::Vec3d& b) {
    return std::acos(std::clamp(a.dot(b) / (cv::norm(a) * cv::norm(b)), -1.0, 1.0)) * 180.0 / CV_PI;
}

// Angle of two directions as lines (0..90 degrees): how far from parallel they are.
double line_angle_deg(const cv::Vec3d& a, const cv::Vec3d& b) {
    const double angle = angle_between_deg(a, b);
    return std::min(angle, 180.0 - angle);
}

std::string degrees(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.2f", value);
    return text;
}

cv::Vec3d unit_normal(const PlaneFit& plane, const char* name) {
    const double length = cv::norm(plane.normal);
    if (!(length > 1e-9) || !std::isfinite(length)) throw Error(name, "the plane has no normal");
    return plane.normal / length;
}

DatumFrame make_frame(const cv::Vec3d& origin, const cv::Vec3d& x_axis, const cv::Vec3d& y_axis, const cv::Vec3d& z_axis) {
    DatumFrame frame;
    frame.origin = origin;
    frame.x_axis = x_axis;
    frame.y_axis = y_axis;
    frame.z_axis = z_axis;
    // part = R (scan - origin) with the axes as R's rows.
    for (int column = 0; column < 3; ++column) {
        frame.part_from_scan(0, column) = x_axis[column];
        frame.part_from_scan(1, column) = y_axis[column];
        frame.part_from_scan(2, column) = z_axis[column];
    }
    for (int row = 0; row < 3; ++row) {
        frame.part_from_scan(row, 3) = -(frame.part_from_scan(row, 0) * origin[0] + frame.part_from_scan(row, 1) * origin[1] +
                                          frame.part_from_scan(row, 2) * origin[2]);
    }
    return frame;
}

// The primary/secondary part of the 3-2-1 frame: axes, and a point on their common line.
struct DatumAxes {
    cv::Vec3d x, y, z, point_on_line, n1, n2;
};

DatumAxes datum_axes(const PlaneFit& primary, const PlaneFit& secondary, const DatumOptions& options) {
    if (!(options.min_angle_deg > 0 && options.min_angle_deg < 90))
        throw Error("min_angle_deg", "must be between 0 and 90 degrees, is " + degrees(options.min_angle_deg));
    DatumAxes axes;
    axes.n1 = unit_normal(primary, "primary");
    axes.n2 = unit_normal(secondary, "secondary");
    const double angle = line_angle_deg(axes.n1, axes.n2);
    if (angle < options.min_angle_deg)
        throw Error("secondary", "the secondary plane is " + degrees(angle) + " degrees from parallel to the primary "
                    "plane (at least " + degrees(options.min_angle_deg) + " needed): they meet in no well-defined line");
    axes.z = axes.n1;
    axes.y = axes.n2 - axes.n2.dot(axes.z) * axes.z;
    axes.y /= cv::norm(axes.y);
    axes.x = axes.y.cross(axes.z);
    // The point of the line nearest to the origin: n1.p = d1, n2.p = d2, x.p = 0.
    const cv::Matx33d rows(axes.n1[0], axes.n1[1], axes.n1[2], axes.n2[0], axes.n2[1], axes.n2[2], axes.x[0], axes.x[1], axes.x[2]);
    const double d1 = primary.offset_mm / cv::norm(primary.normal), d2 = secondary.offset_mm / cv::norm(secondary.normal);
    axes.point_on_line = rows.solve(cv::Vec3d(d1, d2, 0), cv::DECOMP_LU);
    return axes;
}

}  // namespace

DatumFrame datum_frame(const PlaneFit& primary, const PlaneFit& secondary, const PlaneFit& tertiary, const DatumOptions& options) {
    const DatumAxes axes = datum_axes(primary, secondary, options);
    const cv::Vec3d n3 = unit_normal(tertiary, "tertiary");
    // The third plane must cut the primary/secondary line, i.e. not contain its direction.
    const double crossing = 90.0 - line_angle_deg(n3, axes.x);
    if (crossing < options.min_angle_deg)
        throw Error("tertiary", "the tertiary plane is " + degrees(crossing) + " degrees from parallel to the line where "
                    "the primary and secondary planes meet (at least " + degrees(options.min_angle_deg) +
                    " needed): it fixes no origin along it");
    const double d3 = tertiary.offset_mm / cv::norm(tertiary.normal);
    const double along = (d3 - n3.dot(axes.point_on_line)) / n3.dot(axes.x);
    DatumFrame frame = make_frame(axes.point_on_line + along * axes.x, axes.x, axes.y, axes.z);
    frame.primary_secondary_deg = angle_between_deg(axes.n1, axes.n2);
    frame.primary_tertiary_deg = angle_between_deg(axes.n1, n3);
    frame.secondary_tertiary_deg = angle_between_deg(axes.n2, n3);
    return frame;
}

DatumFrame datum_frame(const PlaneFit& primary, const PlaneFit& secondary, const cv::Vec3d& origin_point, const DatumOptions& options) {
    if (!std::isfinite(origin_point.dot(origin_point))) throw Error("origin_point", "is not a finite point");
    const DatumAxes axes = datum_axes(primary, secondary, options);
    const double along = (origin_point - axes.point_on_line).dot(axes.x);
    DatumFrame frame = make_frame(axes.point_on_line + along * axes.x, axes.x, axes.y, axes.z);
    frame.primary_secondary_deg = angle_between_deg(axes.n1, axes.n2);
    return frame;
}

DatumFrame frame_from_axis(const cv::Vec3d& origin, const cv::Vec3d& up, const cv::Vec3d& x_hint) {
    const double up_length = cv::norm(up);
    if (!(up_length > 1e-12) || !std::isfinite(up_length)) throw Error("up", "is a zero or non-finite vector");
    if (!std::isfinite(origin.dot(origin))) throw Error("origin", "is not a finite point");
    const cv::Vec3d z = up / up_length;
    cv::Vec3d x = x_hint - x_hint.dot(z) * z;
    if (!(cv::norm(x) > 1e-6 * std::max(1.0, cv::norm(x_hint))))
        throw Error("x_hint", "is zero or parallel to the up direction");
    x /= cv::norm(x);
    return make_frame(origin, x, z.cross(x), z);
}

}  // namespace picoscan
