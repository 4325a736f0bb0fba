#include "register/visibility.h"

#include "cloud/view_check.h"
#include "common/pixel.h"
#include "register/point_grid.h"

#include <opencv2/imgproc.hpp>
#include <cmath>
#include <limits>

namespace picoscan::detail {

ViewCamera view_camera(const ScanView& view, const cv::Rect& measured_area) {
    ViewCamera camera;
    if (view.points.empty()) return camera;
    // x = fx X/Z + cx and y = fy Y/Z + cy, least squares over a subset of the measured pixels:
    // every third row and column of the frame (those within the measured area).
    const auto first_third = [](int from) { return (from + 2) / 3 * 3; };
    cv::Matx22d ax = cv::Matx22d::zeros(), ay = cv::Matx22d::zeros();
    cv::Vec2d bx(0, 0), by(0, 0);
    size_t used = 0;
    for (int y = first_third(measured_area.y); y < measured_area.y + measured_area.height; y += 3)
        for (int x = first_third(measured_area.x); x < measured_area.x + measured_area.width; x += 3) {
            const cv::Vec3f p = view.points.at<cv::Vec3f>(y, x);
            if (!is_finite_point(p) || p[2] <= 0) continue;
            const double u = p[0] / p[2], v = p[1] / p[2];
            ax += cv::Matx22d(u * u, u, u, 1);
            bx += cv::Vec2d(u * x, x);
            ay += cv::Matx22d(v * v, v, v, 1);
            by += cv::Vec2d(v * y, y);
            ++used;
        }
    if (used < 100) return camera;
    if (view.camera_matrix(0, 0) > 0) {  // the view knows its camera
        camera.fx = view.camera_matrix(0, 0);
        camera.fy = view.camera_matrix(1, 1);
        camera.cx = view.camera_matrix(0, 2);
        camera.cy = view.camera_matrix(1, 2);
    } else {
        cv::Vec2d solution_x, solution_y;
        if (!cv::solve(ax, bx, solution_x) || !cv::solve(ay, by, solution_y)) return camera;
        camera.fx = solution_x[0];
        camera.cx = solution_x[1];
        camera.fy = solution_y[0];
        camera.cy = solution_y[1];
    }
    // Only the measured area: the part is small in the frame, and a whole frame's maps cost
    // more to fill and erode than the rest of a view's preparation.
    const cv::Rect& area = measured_area;
    camera.origin = area.tl();
    cv::Mat depth(area.size(), CV_32F, cv::Scalar(std::numeric_limits<float>::infinity()));
    double squared = 0;
    size_t counted = 0;
    for (int y = area.y; y < area.y + area.height; ++y)
        for (int x = area.x; x < area.x + area.width; ++x) {
            const cv::Vec3f p = view.points.at<cv::Vec3f>(y, x);
            if (!is_finite_point(p) || p[2] <= 0) continue;
            depth.at<float>(y - area.y, x - area.x) = p[2];
            if ((x % 3) || (y % 3)) continue;
            const double ex = camera.fx * p[0] / p[2] + camera.cx - x, ey = camera.fy * p[1] / p[2] + camera.cy - y;
            squared += ex * ex + ey * ey;
            ++counted;
        }
    camera.fit_rms_px = std::sqrt(squared / static_cast<double>(counted));
    // The nearest surface within a few pixels (more where the pinhole fits worse): a point
    // counts as seen through only if it is in front of all of them. Beyond the area's edge
    // nothing was measured, so erosion's border (the largest value) changes nothing.
    // At most 8 pixels: a camera matrix that does not describe the view (given in memory) must
    // not make the kernel huge, nor its size overflow an int (NaN counts as the most).
    const double spread_px = camera.fit_rms_px < 8 ? camera.fit_rms_px : 8;
    const int radius = 2 + static_cast<int>(std::ceil(2 * spread_px));
    cv::erode(depth, camera.nearest_depth, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * radius + 1, 2 * radius + 1)));
    camera.depth = depth;
    return camera;
}

FreeSpaceCheck free_space_violations(const ViewCamera& camera, const std::vector<cv::Vec3d>& points, double tolerance_mm) {
    FreeSpaceCheck check;
    if (!camera.valid()) return check;
    const int width = camera.nearest_depth.cols, height = camera.nearest_depth.rows;
    for (const cv::Vec3d& p : points) {
        if (p[2] <= 0) continue;
        int x = 0, y = 0;
        if (!round_to_pixel(std::round(camera.fx * p[0] / p[2] + camera.cx) - camera.origin.x, width, x) ||
            !round_to_pixel(std::round(camera.fy * p[1] / p[2] + camera.cy) - camera.origin.y, height, y))
            continue;
        // Only where the view measured: an unmeasured pixel may be a shadow, not empty space.
        if (!std::isfinite(camera.depth.at<float>(y, x))) continue;
        const float surface = camera.nearest_depth.at<float>(y, x);
        ++check.checked;
        if (p[2] < surface - tolerance_mm) ++check.violations;
    }
    return check;
}

}  // namespace picoscan::detail
