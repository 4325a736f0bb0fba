// Triangulation: camera ray ∩ projector column plane, or ray-ray where both codes are known.
#include "picoscan/triangulate.h"

#include "picoscan/error.h"

#include "common/lens.h"
#include "common/parallel.h"
#include "common/progress_reporter.h"

#include <atomic>
#include <cmath>
#include <limits>

namespace picoscan {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr int kProjectorTableMargin = 8;  // codes may fall slightly outside the projector image

// Bilinear lookup in the projector's table of undistorted normalised coordinates.
cv::Vec2d projector_ray_at(const cv::Mat& table, int margin, double u, double v) {
    const double column = u + margin, row = v + margin;
    const int x0 = std::clamp(int(std::floor(column)), 0, table.cols - 2);
    const int y0 = std::clamp(int(std::floor(row)), 0, table.rows - 2);
    const double fx = column - x0, fy = row - y0;
    const cv::Vec2d* top = table.ptr<cv::Vec2d>(y0) + x0;
    const cv::Vec2d* bottom = table.ptr<cv::Vec2d>(y0 + 1) + x0;
    return (top[0] * (1 - fx) + top[1] * fx) * (1 - fy) + (bottom[0] * (1 - fx) + bottom[1] * fx) * fy;
}

void estimate_normals(ScanView& view) {
    const cv::Mat& points = view.points;
    view.normals = cv::Mat(points.size(), CV_32FC3, cv::Scalar::all(kNaN));
    detail::parallel_rows(points.rows, [&](int begin, int end) {
        auto valid = [&](int x, int y) {
            return x >= 0 && y >= 0 && x < points.cols && y < points.rows && std::isfinite(points.at<cv::Vec3f>(y, x)[2]);
        };
        for (int y = begin; y < end; ++y) {
            for (int x = 0; x < points.cols; ++x) {
                if (!valid(x, y)) continue;
                // Central differences where both neighbours exist, one-sided otherwise.
                const int left = valid(x - 1, y) ? x - 1 : x, right = valid(x + 1, y) ? x + 1 : x;
                const int up = valid(x, y - 1) ? y - 1 : y, down = valid(x, y + 1) ? y + 1 : y;
                if (left == right || up == down) continue;
                const cv::Vec3f along_x = points.at<cv::Vec3f>(y, right) - points.at<cv::Vec3f>(y, left);
                const cv::Vec3f along_y = points.at<cv::Vec3f>(down, x) - points.at<cv::Vec3f>(up, x);
                cv::Vec3f normal = along_x.cross(along_y);
                const float length = float(cv::norm(normal));
                if (!(length > 0)) continue;
                normal /= length;
                if (normal.dot(points.at<cv::Vec3f>(y, x)) > 0) normal = -normal;  // face the camera
                view.normals.at<cv::Vec3f>(y, x) = normal;
            }
        }
    });
}

}  // namespace

Triangulator::Triangulator(const Calibration& calibration) : calibration_(calibration) {
    validate_calibration(calibration, "calibration");
    const detail::LensDistortion camera_lens(calibration.camera_distortion);
    const detail::LensDistortion projector_lens(calibration.projector_distortion);

    camera_rays_.create(calibration.camera_size, CV_64FC2);
    detail::parallel_rows(camera_rays_.rows, [&](int begin, int end) {
        for (int y = begin; y < end; ++y)
            for (int x = 0; x < camera_rays_.cols; ++x)
                camera_rays_.at<cv::Vec2d>(y, x) =
                    camera_lens.undistort(detail::pixel_to_normalised(calibration.camera_matrix, {double(x), double(y)}));
    });

    projector_table_margin_ = kProjectorTableMargin;
    const int margin = kProjectorTableMargin;
    projector_rays_.create(calibration.projector_size.height + 2 * margin, calibration.projector_size.width + 2 * margin, CV_64FC2);
    detail::parallel_rows(projector_rays_.rows, [&](int begin, int end) {
        for (int row = begin; row < end; ++row)
            for (int column = 0; column < projector_rays_.cols; ++column)
                projector_rays_.at<cv::Vec2d>(row, column) = projector_lens.undistort(detail::pixel_to_normalised(
                    calibration.projector_matrix, {double(column - margin), double(row - margin)}));
    });
}

ScanView Triangulator::triangulate(const CorrespondenceMap& correspondences, const cv::Mat& colour,
                                   const TriangulateOptions& options, const ProgressCallback& progress) const {
    const cv::Size size = correspondences.projector_u.size();
    if (size != calibration_.camera_size)
        throw Error("calibration", "camera_size is " + std::to_string(calibration_.camera_size.width) + "x" +
                                       std::to_string(calibration_.camera_size.height) + " but the captures are " +
                                       std::to_string(size.width) + "x" + std::to_string(size.height));
    if (!colour.empty() && (colour.size() != size || colour.type() != CV_8UC3))
        throw Error("colour", "colour image must be CV_8UC3 of the camera size");

    const detail::LensDistortion projector_lens(calibration_.projector_distortion);
    const cv::Matx33d& R = calibration_.R;
    const cv::Vec3d T = calibration_.T;
    const cv::Matx33d& projector_matrix = calibration_.projector_matrix;
    const bool projector_distorted = !projector_lens.is_zero();
    const bool use_rows = options.use_rows && !correspondences.projector_v.empty();
    const cv::Matx33d R_inverse = R.t();

    ScanView view;
    view.points.create(size, CV_32FC3);
    view.quality = correspondences.quality.clone();
    view.colours = colour.empty() ? cv::Mat(size, CV_8UC3, cv::Scalar::all(200)) : colour.clone();

    detail::ProgressReporter reporter(progress, "triangulate", size.height);
    detail::parallel_rows(size.height, [&](int begin, int end) {
        for (int y = begin; y < end && !reporter.cancelled(); ++y) {
            const float* projector_u = correspondences.projector_u.ptr<float>(y);
            const float* projector_v = use_rows ? correspondences.projector_v.ptr<float>(y) : nullptr;
            const cv::Vec2d* camera_ray = camera_rays_.ptr<cv::Vec2d>(y);
            cv::Vec3f* point = view.points.ptr<cv::Vec3f>(y);
            double v_estimate = projector_matrix(1, 2);  // warm start: neighbours see nearby projector rows
            for (int x = 0; x < size.width; ++x) {
                point[x] = cv::Vec3f(kNaN, kNaN, kNaN);
                const double u = projector_u[x];
                if (!std::isfinite(u)) continue;
                const cv::Vec3d ray_camera(camera_ray[x][0], camera_ray[x][1], 1.0);
                const cv::Vec3d direction = R * ray_camera;  // camera ray in the projector frame, from T
                double depth = std::numeric_limits<double>::quiet_NaN();

                if (projector_v && std::isfinite(projector_v[x])) {
                    // Ray-ray: least-squares closest points of the two rays.
                    const cv::Vec2d normalised = projector_ray_at(projector_rays_, projector_table_margin_, u, projector_v[x]);
                    const cv::Vec3d projector_ray(normalised[0], normalised[1], 1.0);
                    const double a = direction.dot(direction), b = direction.dot(projector_ray),
                                 c = projector_ray.dot(projector_ray);
                    const double d = direction.dot(T), e = projector_ray.dot(T);
                    const double denominator = a * c - b * b;
                    if (std::abs(denominator) < 1e-12) continue;
                    // The camera ray is exact (a pixel centre), so the point is taken on it, where
                    // it passes closest to the projector ray, rather than midway between the rays.
                    depth = (b * e - c * d) / denominator;
                    if (std::isfinite(depth) && depth > options.min_depth_mm && depth < options.max_depth_mm)
                        point[x] = cv::Vec3f(float(ray_camera[0] * depth), float(ray_camera[1] * depth), float(depth));
                    v_estimate = projector_v[x];
                    continue;
                }

                // Column plane through the projector centre; with lens distortion the iso-u curve
                // bends, so the plane is re-fitted at the projector row the point actually hits.
                const int iterations = projector_distorted ? std::max(1, options.distortion_iterations) : 1;
                for (int iteration = 0; iteration < iterations; ++iteration) {
                    const cv::Vec2d n1 = projector_ray_at(projector_rays_, projector_table_margin_, u, v_estimate);
                    const cv::Vec2d n2 = projector_ray_at(projector_rays_, projector_table_margin_, u, v_estimate + 1.0);
                    const cv::Vec3d plane_normal = cv::Vec3d(n1[0], n1[1], 1.0).cross(cv::Vec3d(n2[0], n2[1], 1.0));
                    const double denominator = plane_normal.dot(direction);
                    if (std::abs(denominator) < 1e-12) {
                        depth = std::numeric_limits<double>::quiet_NaN();
                        break;
                    }
                    depth = -plane_normal.dot(T) / denominator;
                    if (!projector_distorted) break;
                    const cv::Vec3d in_projector = T + depth * direction;
                    if (!(in_projector[2] > 0)) break;
                    const cv::Vec2d distorted = projector_lens.distort({in_projector[0] / in_projector[2], in_projector[1] / in_projector[2]});
                    const double v_new = detail::normalised_to_pixel(projector_matrix, distorted)[1];
                    const bool converged = std::abs(v_new - v_estimate) < 1e-3;
                    v_estimate = std::clamp(v_new, -double(kProjectorTableMargin) + 1,
                                            double(calibration_.projector_size.height + kProjectorTableMargin - 2));
                    if (converged) break;
                }
                if (std::isfinite(depth) && depth > options.min_depth_mm && depth < options.max_depth_mm)
                    point[x] = cv::Vec3f(float(ray_camera[0] * depth), float(ray_camera[1] * depth), float(depth));
            }
            reporter.advance();
        }
    });
    if (reporter.cancelled()) throw Error("cancelled", "triangulation cancelled");
    estimate_normals(view);
    return view;
}

ScanView triangulate(const CorrespondenceMap& correspondences, const Calibration& calibration, const cv::Mat& colour,
                     const TriangulateOptions& options, const ProgressCallback& progress) {
    return Triangulator(calibration).triangulate(correspondences, colour, options, progress);
}

}  // namespace picoscan
