#include "picoscan/multi_camera.h"

#include "picoscan/error.h"

#include "common/lens.h"
#include "common/parallel.h"
#include "common/pixel.h"

#include <opencv2/calib3d.hpp>

#include <cmath>
#include <limits>

namespace picoscan {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

void require_rows(const CorrespondenceMap& map, const char* which) {
    if (map.projector_v.empty() || cv::countNonZero(map.projector_v == map.projector_v) == 0)
        throw Error(which, "camera-camera work needs projector rows decoded (patterns --rows)");
}

// Projector-indexed table of camera B: for each projector pixel (rounded u, v), a camera-B pixel
// that decoded it (-1 where none did).
cv::Mat index_by_projector_code(const CorrespondenceMap& map, cv::Size projector_size) {
    cv::Mat table(projector_size, CV_32SC2, cv::Scalar(-1, -1));
    for (int y = 0; y < map.projector_u.rows; ++y)
        for (int x = 0; x < map.projector_u.cols; ++x) {
            const float u = map.projector_u.at<float>(y, x), v = map.projector_v.at<float>(y, x);
            if (!std::isfinite(u) || !std::isfinite(v)) continue;
            int column = 0, row = 0;
            if (!detail::round_to_pixel(u, table.cols, column) || !detail::round_to_pixel(v, table.rows, row)) continue;
            table.at<cv::Vec2i>(row, column) = cv::Vec2i(x, y);
        }
    return table;
}

// Sub-pixel camera-B position of projector code (u, v), starting from pixel `start`: Newton
// steps on B's decoded code field, whose local Jacobian comes from neighbouring pixels.
bool locate_code(const CorrespondenceMap& map, cv::Vec2i start, double u, double v, cv::Point2d& found) {
    double x = start[0], y = start[1];
    for (int iteration = 0; iteration < 4; ++iteration) {
        const int xi = int(std::floor(x)), yi = int(std::floor(y));
        if (xi < 1 || yi < 1 || xi + 2 >= map.projector_u.cols || yi + 2 >= map.projector_u.rows) return false;
        auto code = [&](int px, int py, double& cu, double& cv_) {
            cu = map.projector_u.at<float>(py, px);
            cv_ = map.projector_v.at<float>(py, px);
            return std::isfinite(cu) && std::isfinite(cv_);
        };
        double u00, v00, u10, v10, u01, v01, u11, v11;
        if (!code(xi, yi, u00, v00) || !code(xi + 1, yi, u10, v10) || !code(xi, yi + 1, u01, v01) || !code(xi + 1, yi + 1, u11, v11))
            return false;
        const double fx = x - xi, fy = y - yi;
        const double cu = (u00 * (1 - fx) + u10 * fx) * (1 - fy) + (u01 * (1 - fx) + u11 * fx) * fy;
        const double cvv = (v00 * (1 - fx) + v10 * fx) * (1 - fy) + (v01 * (1 - fx) + v11 * fx) * fy;
        const double du_dx = (u10 - u00) * (1 - fy) + (u11 - u01) * fy, du_dy = (u01 - u00) * (1 - fx) + (u11 - u10) * fx;
        const double dv_dx = (v10 - v00) * (1 - fy) + (v11 - v01) * fy, dv_dy = (v01 - v00) * (1 - fx) + (v11 - v10) * fx;
        const double determinant = du_dx * dv_dy - du_dy * dv_dx;
        if (std::abs(determinant) < 1e-9) return false;
        const double eu = u - cu, ev = v - cvv;
        const double step_x = (dv_dy * eu - du_dy * ev) / determinant, step_y = (-dv_dx * eu + du_dx * ev) / determinant;
        x += std::clamp(step_x, -2.0, 2.0);
        y += std::clamp(step_y, -2.0, 2.0);
        if (std::abs(step_x) + std::abs(step_y) < 1e-4) {
            found = {x, y};
            return true;
        }
    }
    return false;  // no convergence: no reliable match
}

}  // namespace

cv::Matx44d camera_to_camera(const Calibration& from, const Calibration& to) {
    // X_p = R_f X_from + T_f = R_t X_to + T_t  =>  X_to = R_t^T (R_f X_from + T_f - T_t)
    const cv::Matx33d rotation = to.R.t() * from.R;
    const cv::Vec3d translation = to.R.t() * (from.T - to.T);
    cv::Matx44d pose = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) pose(r, c) = rotation(r, c);
        pose(r, 3) = translation[r];
    }
    return pose;
}

ScanView triangulate_camera_pair(const CorrespondenceMap& map_a, const Calibration& calibration_a,
                                 const CorrespondenceMap& map_b, const Calibration& calibration_b,
                                 const CameraPairOptions& options) {
    require_rows(map_a, "camera A");
    require_rows(map_b, "camera B");
    if (map_a.projector_u.size() != calibration_a.camera_size || map_b.projector_u.size() != calibration_b.camera_size)
        throw Error("calibration", "camera_size does not match the decoded captures");
    const cv::Matx44d a_to_b = camera_to_camera(calibration_a, calibration_b);
    const cv::Matx33d rotation_b_to_a = a_to_b.get_minor<3, 3>(0, 0).t();
    const cv::Vec3d centre_b_in_a = -(rotation_b_to_a * cv::Vec3d(a_to_b(0, 3), a_to_b(1, 3), a_to_b(2, 3)));
    const detail::LensDistortion lens_a(calibration_a.camera_distortion), lens_b(calibration_b.camera_distortion);
    const cv::Mat table = index_by_projector_code(map_b, calibration_b.projector_size);

    ScanView view;
    view.points = cv::Mat(map_a.projector_u.size(), CV_32FC3, cv::Scalar::all(kNaN));
    view.quality = map_a.quality;
    view.colours = cv::Mat(map_a.projector_u.size(), CV_8UC3, cv::Scalar::all(200));
    view.normals = cv::Mat(map_a.projector_u.size(), CV_32FC3, cv::Scalar::all(kNaN));
    detail::parallel_rows(map_a.projector_u.rows, [&](int begin, int end) {
        for (int y = begin; y < end; ++y)
            for (int x = 0; x < map_a.projector_u.cols; ++x) {
                const double u = map_a.projector_u.at<float>(y, x), v = map_a.projector_v.at<float>(y, x);
                if (!std::isfinite(u) || !std::isfinite(v)) continue;
                int column = 0, row = 0;
                if (!detail::round_to_pixel(u, table.cols, column) || !detail::round_to_pixel(v, table.rows, row)) continue;
                const cv::Vec2i start = table.at<cv::Vec2i>(row, column);
                cv::Point2d in_b;
                if (start[0] < 0 || !locate_code(map_b, start, u, v, in_b)) continue;
                // Confirm: B's code at the found point agrees with A's.
                int bx = 0, by = 0;
                if (!detail::round_to_pixel(in_b.x, map_b.projector_u.cols, bx) ||
                    !detail::round_to_pixel(in_b.y, map_b.projector_u.rows, by))
                    continue;
                const float bu = map_b.projector_u.at<float>(by, bx), bv = map_b.projector_v.at<float>(by, bx);
                if (!(std::abs(bu - u) < 1.0 + options.max_code_difference_px && std::abs(bv - v) < 1.0 + options.max_code_difference_px))
                    continue;
                const cv::Vec2d na = lens_a.undistort(detail::pixel_to_normalised(calibration_a.camera_matrix, {double(x), double(y)}));
                const cv::Vec2d nb = lens_b.undistort(detail::pixel_to_normalised(calibration_b.camera_matrix, {in_b.x, in_b.y}));
                const cv::Vec3d ray_a(na[0], na[1], 1.0);
                const cv::Vec3d ray_b = rotation_b_to_a * cv::Vec3d(nb[0], nb[1], 1.0);
                // Closest points of ray_a (from the origin) and ray_b (from centre_b), midpoint.
                const double a = ray_a.dot(ray_a), b = ray_a.dot(ray_b), c = ray_b.dot(ray_b);
                const double d = ray_a.dot(-centre_b_in_a), e = ray_b.dot(-centre_b_in_a);
                const double denominator = a * c - b * b;
                if (std::abs(denominator) < 1e-12) continue;
                const double t = (b * e - c * d) / denominator, s = (a * e - b * d) / denominator;
                const cv::Vec3d point = 0.5 * (t * ray_a + (centre_b_in_a + s * ray_b));
                if (point[2] > 0) view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(point);
            }
    });
    return view;
}

int reject_unconfirmed_points(ScanView& view, const Calibration& calibration_a, const CorrespondenceMap& map_b,
                              const Calibration& calibration_b, const CameraPairOptions& options) {
    require_rows(map_b, "camera B");
    const cv::Matx44d a_to_b = camera_to_camera(calibration_a, calibration_b);
    const cv::Matx33d rotation = a_to_b.get_minor<3, 3>(0, 0);
    const cv::Vec3d translation(a_to_b(0, 3), a_to_b(1, 3), a_to_b(2, 3));
    const detail::LensDistortion lens_b(calibration_b.camera_distortion);
    const detail::LensDistortion projector_lens(calibration_a.projector_distortion);
    std::vector<int> removed_per_row(view.points.rows, 0);
    detail::parallel_rows(view.points.rows, [&](int begin, int end) {
        for (int y = begin; y < end; ++y)
            for (int x = 0; x < view.points.cols; ++x) {
                cv::Vec3f& point = view.points.at<cv::Vec3f>(y, x);
                if (!std::isfinite(point[2])) continue;
                // Where the point is in camera B, and which projector code it should show there.
                const cv::Vec3d in_b = rotation * cv::Vec3d(point) + translation;
                const cv::Vec3d in_projector = calibration_a.R * cv::Vec3d(point) + calibration_a.T;
                bool confirmed = false;
                if (in_b[2] > 0 && in_projector[2] > 0) {
                    const cv::Vec2d pixel = detail::normalised_to_pixel(
                        calibration_b.camera_matrix, lens_b.distort({in_b[0] / in_b[2], in_b[1] / in_b[2]}));
                    const cv::Vec2d expected = detail::normalised_to_pixel(
                        calibration_a.projector_matrix,
                        projector_lens.distort({in_projector[0] / in_projector[2], in_projector[1] / in_projector[2]}));
                    int bx = 0, by = 0;
                    if (detail::round_to_pixel(pixel[0], map_b.projector_u.cols, bx) &&
                        detail::round_to_pixel(pixel[1], map_b.projector_u.rows, by)) {
                        // The nearest pixel is up to half a pixel away: allow B's local code gradient for that.
                        const float bu = map_b.projector_u.at<float>(by, bx), bv = map_b.projector_v.at<float>(by, bx);
                        const double slack = options.max_code_difference_px + 1.0;
                        confirmed = std::abs(bu - expected[0]) < slack && std::abs(bv - expected[1]) < slack;
                    }
                }
                if (!confirmed) {
                    point = cv::Vec3f(kNaN, kNaN, kNaN);
                    if (!view.normals.empty()) view.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(kNaN, kNaN, kNaN);
                    ++removed_per_row[y];
                }
            }
    });
    int removed = 0;
    for (int count : removed_per_row) removed += count;
    return removed;
}

}  // namespace picoscan
