#include "picoscan/fit.h"

#include "picoscan/error.h"

#include <cmath>

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

}  // namespace picoscan
