// Triangulation: camera ray ∩ projector column plane, or ray-ray where both codes are known.
#include "picoscan/triangulate.h"

#include "picoscan/error.h"

#include "common/lens.h"
#include "common/memory_budget.h"
#include "common/parallel.h"
#include "common/progress_reporter.h"

#include <cmath>
#include <limits>

namespace picoscan {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr int kTableMargin = 8;  // projector codes may fall slightly outside the projector image

// Bilinear lookup in a per-projector-pixel table (with kTableMargin pixels of margin).
template <typename Value>
inline Value table_at(const cv::Mat& table, double u, double v) {
    const double column = u + kTableMargin, row = v + kTableMargin;
    const int x0 = std::clamp(int(column), 0, table.cols - 2);
    const int y0 = std::clamp(int(row), 0, table.rows - 2);
    const auto fx = typename Value::value_type(column - x0), fy = typename Value::value_type(row - y0);
    const Value* top = table.ptr<Value>(y0) + x0;
    const Value* bottom = table.ptr<Value>(y0 + 1) + x0;
    const auto one = typename Value::value_type(1);
    return (top[0] * (one - fx) + top[1] * fx) * (one - fy) + (bottom[0] * (one - fx) + bottom[1] * fx) * fy;
}

// Pass B of triangulation for one row: camera ray ∩ plane (n, n.T) in the projector frame,
// written so that GCC vectorises it. Points outside [min_depth, max_depth] (and NaN planes)
// become NaN.
void intersect_row(const cv::Vec2f* __restrict camera_ray, const float* __restrict normal_x,
                   const float* __restrict normal_y, const float* __restrict normal_z, const float* __restrict offset,
                   const cv::Matx33f& R, float min_depth, float max_depth, int width, cv::Vec3f* __restrict points) {
    const float r00 = R(0, 0), r01 = R(0, 1), r02 = R(0, 2), r10 = R(1, 0), r11 = R(1, 1), r12 = R(1, 2);
    const float r20 = R(2, 0), r21 = R(2, 1), r22 = R(2, 2);
    const float* ray = &camera_ray[0][0];
    float* point = &points[0][0];
    for (int x = 0; x < width; ++x) {
        const float rx = ray[2 * x], ry = ray[2 * x + 1];
        const float dx = r00 * rx + r01 * ry + r02, dy = r10 * rx + r11 * ry + r12, dz = r20 * rx + r21 * ry + r22;
        const float depth = -offset[x] / (normal_x[x] * dx + normal_y[x] * dy + normal_z[x] * dz);
        const bool inside = depth > min_depth && depth < max_depth;  // false for NaN
        const float kept = inside ? depth : kNaN;
        point[3 * x] = rx * kept;
        point[3 * x + 1] = ry * kept;
        point[3 * x + 2] = kept;
    }
}

}  // namespace

Triangulator::Triangulator(const Calibration& calibration) : calibration_(calibration) {
    validate_calibration(calibration, "calibration");
    // Camera rays (8 bytes a pixel) and projector tables (32 bytes a pixel) are built once;
    // each view then needs about 40 bytes a camera pixel.
    const double camera_pixels = double(calibration.camera_size.width) * calibration.camera_size.height;
    const double projector_pixels = double(calibration.projector_size.width) * calibration.projector_size.height;
    detail::check_memory_budget(48 * camera_pixels + 32 * projector_pixels, "calibration",
                                "the triangulation tables of its camera and projector sizes");
    const detail::LensDistortion camera_lens(calibration.camera_distortion);
    const detail::LensDistortion projector_lens(calibration.projector_distortion);

    camera_rays_.create(calibration.camera_size, CV_32FC2);
    detail::parallel_rows(camera_rays_.rows, [&](int begin, int end) {
        for (int y = begin; y < end; ++y)
            for (int x = 0; x < camera_rays_.cols; ++x)
                camera_rays_.at<cv::Vec2f>(y, x) =
                    camera_lens.undistort(detail::pixel_to_normalised(calibration.camera_matrix, {double(x), double(y)}));
    });

    const cv::Size table_size(calibration.projector_size.width + 2 * kTableMargin,
                              calibration.projector_size.height + 2 * kTableMargin + 1);
    projector_rays_.create(table_size, CV_64FC2);
    detail::parallel_rows(table_size.height, [&](int begin, int end) {
        for (int row = begin; row < end; ++row)
            for (int column = 0; column < table_size.width; ++column)
                projector_rays_.at<cv::Vec2d>(row, column) = projector_lens.undistort(detail::pixel_to_normalised(
                    calibration.projector_matrix, {double(column - kTableMargin), double(row - kTableMargin)}));
    });
    // With lens distortion a projector column is a curve; near row v it is well described by
    // the plane through the projector centre and the rays of (u, v) and (u, v + 1). Each entry
    // holds the unit normal n and n.T, so a camera ray's depth is -(n.T) / (n.R ray).
    column_planes_.create(table_size.height - 1, table_size.width, CV_32FC4);
    detail::parallel_rows(column_planes_.rows, [&](int begin, int end) {
        for (int row = begin; row < end; ++row)
            for (int column = 0; column < table_size.width; ++column) {
                const cv::Vec2d a = projector_rays_.at<cv::Vec2d>(row, column);
                const cv::Vec2d b = projector_rays_.at<cv::Vec2d>(row + 1, column);
                cv::Vec3d normal = cv::Vec3d(a[0], a[1], 1.0).cross(cv::Vec3d(b[0], b[1], 1.0));
                normal /= cv::norm(normal);
                column_planes_.at<cv::Vec4f>(row, column) =
                    cv::Vec4f(float(normal[0]), float(normal[1]), float(normal[2]), float(normal.dot(calibration.T)));
            }
    });
}

ScanView Triangulator::triangulate(const CorrespondenceMap& correspondences, const cv::Mat& colour,
                                   const TriangulateOptions& options, const ProgressCallback& progress) const {
    ScanView view;
    triangulate_into(correspondences, colour, view, options, progress);
    return view;
}

void Triangulator::triangulate_into(const CorrespondenceMap& correspondences, const cv::Mat& colour, ScanView& view,
                                    const TriangulateOptions& options, const ProgressCallback& progress) const {
    const cv::Size size = correspondences.projector_u.size();
    if (size != calibration_.camera_size)
        throw Error("calibration", "camera_size is " + std::to_string(calibration_.camera_size.width) + "x" +
                                       std::to_string(calibration_.camera_size.height) + " but the captures are " +
                                       std::to_string(size.width) + "x" + std::to_string(size.height));
    if (!colour.empty() && (colour.size() != size || colour.type() != CV_8UC3))
        throw Error("colour", "colour image must be CV_8UC3 of the camera size");
    view.camera_matrix = calibration_.camera_matrix;
    view.camera_distortion = calibration_.camera_distortion.clone();

    const detail::LensDistortion projector_lens(calibration_.projector_distortion);
    const cv::Matx33d& R = calibration_.R;
    const cv::Vec3d T = calibration_.T;
    const cv::Matx33d& projector_matrix = calibration_.projector_matrix;
    const bool projector_distorted = !projector_lens.is_zero();
    const bool use_rows = options.use_rows && !correspondences.projector_v.empty();
    const int iterations = projector_distorted ? std::max(1, options.distortion_iterations) : 1;
    const double lowest_row = -kTableMargin + 1.0, highest_row = calibration_.projector_size.height + kTableMargin - 2.0;

    view.points.create(size, CV_32FC3);
    // Quality and colour are shared with the inputs, not copied (cv::Mat reference counting).
    view.quality = correspondences.quality;
    view.colours = colour.empty() ? cv::Mat(size, CV_8UC3, cv::Scalar::all(200)) : colour;

    // Each pixel's point is the camera ray ∩ a plane through the projector centre (projector
    // frame): depth = -(n.T) / (n.(R ray)). Pass A finds the plane per pixel (table lookups,
    // scalar); pass B intersects a whole row at once (vectorised).
    const cv::Matx33f R_float(R);
    detail::ProgressReporter reporter(progress, "triangulate", size.height);
    detail::parallel_rows(size.height, [&](int begin, int end) {
        std::vector<float> normal_x(size.width), normal_y(size.width), normal_z(size.width), offset(size.width);
        for (int y = begin; y < end && !reporter.cancelled(); ++y) {
            const float* projector_u = correspondences.projector_u.ptr<float>(y);
            const float* projector_v = use_rows ? correspondences.projector_v.ptr<float>(y) : nullptr;
            const cv::Vec2f* camera_ray = camera_rays_.ptr<cv::Vec2f>(y);
            double v_estimate = projector_matrix(1, 2);  // warm start: neighbours hit nearby projector rows

            for (int x = 0; x < size.width; ++x) {
                const double u = projector_u[x];
                cv::Vec4f plane(0, 0, 1, kNaN);
                if (std::isfinite(u)) {
                    auto direction = [&] { return R * cv::Vec3d(camera_ray[x][0], camera_ray[x][1], 1.0); };
                    if (projector_v && std::isfinite(projector_v[x])) {
                        // Ray-ray: the camera ray is exact (a pixel centre), so the point is taken
                        // where it passes closest to the projector ray, i.e. on the plane holding
                        // the projector ray and the rays' common perpendicular.
                        const cv::Vec2d normalised = table_at<cv::Vec2d>(projector_rays_, u, projector_v[x]);
                        const cv::Vec3d projector_ray(normalised[0], normalised[1], 1.0);
                        const cv::Vec3d normal = projector_ray.cross(direction().cross(projector_ray));
                        plane = cv::Vec4f(float(normal[0]), float(normal[1]), float(normal[2]), float(normal.dot(T)));
                        v_estimate = projector_v[x];
                    } else {
                        // Column plane, taken at the projector row the point hits. That row
                        // changes slowly along a camera row (the epipolar lines run along the
                        // baseline), and a plane taken a pixel or two off the true row moves u by
                        // only ~1e-4 px for typical lens distortion: the row is re-measured every
                        // few pixels only.
                        plane = table_at<cv::Vec4f>(column_planes_, u, v_estimate);
                        const bool refresh_row =
                            projector_distorted && (x % 8 == 0 || !std::isfinite(projector_u[x > 0 ? x - 1 : 0]));
                        if (refresh_row) {
                            const cv::Vec3d ray_direction = direction();
                            for (int iteration = 1; iteration <= iterations; ++iteration) {
                                const double depth = -double(plane[3]) / (plane[0] * ray_direction[0] + plane[1] * ray_direction[1] +
                                                                          plane[2] * ray_direction[2]);
                                const cv::Vec3d in_projector = T + depth * ray_direction;
                                if (!(in_projector[2] > 0)) break;
                                const cv::Vec2d distorted = projector_lens.distort(
                                    {in_projector[0] / in_projector[2], in_projector[1] / in_projector[2]});
                                const double v_hit = std::clamp(detail::normalised_to_pixel(projector_matrix, distorted)[1],
                                                                lowest_row, highest_row);
                                const bool close_enough = std::abs(v_hit - v_estimate) < 2.0;
                                v_estimate = v_hit;
                                if (close_enough) break;
                                plane = table_at<cv::Vec4f>(column_planes_, u, v_estimate);
                            }
                        }
                    }
                }
                normal_x[x] = plane[0];
                normal_y[x] = plane[1];
                normal_z[x] = plane[2];
                offset[x] = plane[3];
            }
            intersect_row(camera_ray, normal_x.data(), normal_y.data(), normal_z.data(), offset.data(), R_float,
                          float(options.min_depth_mm), float(options.max_depth_mm), size.width,
                          view.points.ptr<cv::Vec3f>(y));
            reporter.advance();
        }
    });
    if (reporter.cancelled()) throw Error("cancelled", "triangulation cancelled");
    estimate_normals(view);
}

ScanView triangulate(const CorrespondenceMap& correspondences, const Calibration& calibration, const cv::Mat& colour,
                     const TriangulateOptions& options, const ProgressCallback& progress) {
    return Triangulator(calibration).triangulate(correspondences, colour, options, progress);
}

}  // namespace picoscan
