// Binocular reconstruction: rectify, match equal projector codes along rectified rows, check
// left-right consistency (and the row codes, where projected), triangulate exact rays.
#include "picoscan/stereo.h"

#include "picoscan/error.h"

#include "common/lens.h"
#include "common/parallel.h"
#include "common/progress_reporter.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace picoscan {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr int kMaxRectifiedScale = 3;  // a rectified grid is never more than 3x its image across

// Bilinear sample of a CV_32F image at (x, y); NaN outside or where any of the four
// neighbours is NaN (codes are never interpolated across an undecoded pixel).
inline float sample(const cv::Mat& image, double x, double y) {
    const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    if (x0 < 0 || y0 < 0 || x0 + 1 >= image.cols || y0 + 1 >= image.rows) return kNaN;
    const float fx = float(x - x0), fy = float(y - y0);
    const float* top = image.ptr<float>(y0) + x0;
    const float* bottom = image.ptr<float>(y0 + 1) + x0;
    return (top[0] * (1 - fx) + top[1] * fx) * (1 - fy) + (bottom[0] * (1 - fx) + bottom[1] * fx) * fy;
}

// One camera's rectified grid: where each rectified pixel samples the camera image, as the
// offset of the top-left of its four camera pixels and the bilinear weights (computed once
// per calibration, so resampling a map is four loads and three blends per pixel).
struct RectifiedGrid {
    cv::Matx33d rotation;  // camera frame -> rectified frame
    double cx = 0;         // rectified principal point column (the focal length and cy are shared)
    cv::Mat source_offset; // CV_32S, y0 * width + x0 in the camera image, -1 where none
    cv::Mat source_weight; // CV_32FC2, (x - x0, y - y0)
};

// The rectified image of a CV_32F map (projector_u or projector_v).
cv::Mat resample(const cv::Mat& image, const RectifiedGrid& grid) {
    const cv::Mat continuous = image.isContinuous() ? image : image.clone();
    cv::Mat rectified(grid.source_offset.size(), CV_32F);
    const float* pixels = continuous.ptr<float>();
    const int step = continuous.cols;
    detail::parallel_rows(rectified.rows, [&](int begin, int end) {
        for (int y = begin; y < end; ++y) {
            const int* offsets = grid.source_offset.ptr<int>(y);
            const cv::Vec2f* weights = grid.source_weight.ptr<cv::Vec2f>(y);
            float* out = rectified.ptr<float>(y);
            for (int x = 0; x < rectified.cols; ++x) {
                if (offsets[x] < 0) {
                    out[x] = kNaN;
                    continue;
                }
                const float* top = pixels + offsets[x];
                const float fx = weights[x][0], fy = weights[x][1];
                out[x] = (top[0] * (1 - fx) + top[1] * fx) * (1 - fy) + (top[step] * (1 - fx) + top[step + 1] * fx) * fy;
            }
        }
    });
    return rectified;
}

// For each rectified row, the segments between neighbouring pixels whose codes may be
// interpolated, indexed by code (buckets one projector pixel wide): "where on this row is
// code c" in a few comparisons.
class RowCodeIndex {
public:
    RowCodeIndex(const cv::Mat& codes, double max_step) : codes_(codes), rows_(size_t(codes.rows)) {
        detail::parallel_rows(codes.rows, [&](int begin, int end) {
            for (int y = begin; y < end; ++y) build_row(y, max_step);
        });
    }

    enum class Found { None, Once, Ambiguous };
    // Position on row `y` where the code equals `code`. Segments holding the code that touch
    // each other are one crossing (a plateau of equal codes gives its middle); separate ones
    // make the answer ambiguous.
    Found find(int y, double code, double& position) const {
        if (y < 0 || y >= int(rows_.size())) return Found::None;
        const Row& row = rows_[size_t(y)];
        const double offset = code - row.lowest;
        if (row.bucket_start.empty() || !(offset >= 0) || offset >= double(row.bucket_start.size() - 1)) return Found::None;
        const size_t bucket = size_t(offset);
        const float* values = codes_.ptr<float>(y);
        int first = -1, last = -1;
        for (int index = row.bucket_start[bucket]; index < row.bucket_start[bucket + 1]; ++index) {
            const int x = row.segments[size_t(index)];
            const double a = values[x], b = values[x + 1];
            if (code < std::min(a, b) || code > std::max(a, b)) continue;
            first = first < 0 ? x : std::min(first, x);
            last = std::max(last, x);
        }
        if (first < 0) return Found::None;
        // Every segment from first to last must hold the code for one crossing.
        for (int x = first + 1; x < last; ++x) {
            const double a = values[x], b = values[x + 1];
            if (!(code >= std::min(a, b) && code <= std::max(a, b))) return Found::Ambiguous;
        }
        auto crossing = [&](int x) {
            const double a = values[x], b = values[x + 1];
            return a == b ? x + 0.5 : x + (code - a) / (b - a);
        };
        position = first == last ? crossing(first) : 0.5 * (crossing(first) + crossing(last));
        return Found::Once;
    }

private:
    struct Row {
        double lowest = 0;
        std::vector<int> bucket_start;  // CSR over buckets
        std::vector<int> segments;      // left pixel x of each segment, per bucket
    };

    void build_row(int y, double max_step) {
        const float* values = codes_.ptr<float>(y);
        Row& row = rows_[size_t(y)];
        double lowest = std::numeric_limits<double>::infinity(), highest = -lowest;
        auto usable = [&](int x) {
            const float a = values[x], b = values[x + 1];
            return std::isfinite(a) && std::isfinite(b) && std::abs(a - b) <= max_step;
        };
        for (int x = 0; x + 1 < codes_.cols; ++x)
            if (usable(x)) {
                lowest = std::min(lowest, double(std::min(values[x], values[x + 1])));
                highest = std::max(highest, double(std::max(values[x], values[x + 1])));
            }
        if (!(highest >= lowest)) return;
        row.lowest = std::floor(lowest);
        const size_t buckets = size_t(highest - row.lowest) + 1;
        row.bucket_start.assign(buckets + 1, 0);
        auto for_each_bucket = [&](int x, auto&& body) {
            const size_t from = size_t(std::min(values[x], values[x + 1]) - row.lowest);
            const size_t to = size_t(std::max(values[x], values[x + 1]) - row.lowest);
            for (size_t bucket = from; bucket <= to; ++bucket) body(bucket);
        };
        for (int x = 0; x + 1 < codes_.cols; ++x)
            if (usable(x)) for_each_bucket(x, [&](size_t bucket) { ++row.bucket_start[bucket + 1]; });
        for (size_t bucket = 0; bucket < buckets; ++bucket) row.bucket_start[bucket + 1] += row.bucket_start[bucket];
        row.segments.resize(size_t(row.bucket_start.back()));
        std::vector<int> fill(row.bucket_start.begin(), row.bucket_start.end() - 1);
        for (int x = 0; x + 1 < codes_.cols; ++x)
            if (usable(x)) for_each_bucket(x, [&](size_t bucket) { row.segments[size_t(fill[bucket]++)] = x; });
    }

    const cv::Mat& codes_;
    std::vector<Row> rows_;
};

// Position on the rectified row through y (between two grid rows) where the code equals
// `code`: the crossings on both neighbouring rows, interpolated.
RowCodeIndex::Found find_between_rows(const RowCodeIndex& index, double y, double code, double max_row_difference,
                                      double& position) {
    const int y0 = int(std::floor(y));
    const double t = y - y0;
    double above = 0, below = 0;
    const auto found_above = index.find(y0, code, above);
    const auto found_below = index.find(y0 + 1, code, below);
    if (found_above == RowCodeIndex::Found::Ambiguous || found_below == RowCodeIndex::Found::Ambiguous)
        return RowCodeIndex::Found::Ambiguous;
    if (found_above != RowCodeIndex::Found::Once || found_below != RowCodeIndex::Found::Once) return RowCodeIndex::Found::None;
    if (std::abs(above - below) > max_row_difference) return RowCodeIndex::Found::None;  // a depth edge between the rows
    position = (1 - t) * above + t * below;
    return RowCodeIndex::Found::Once;
}

// The crossing of `code` nearest to `near` on row y of `codes`, within `window` pixels. As in
// RowCodeIndex::find, neighbouring segments that all hold the code (a plateau of a binary
// code) are one crossing at their middle.
bool nearest_crossing(const cv::Mat& codes, int y, double near, double window, double code, double max_step,
                      double& position) {
    if (y < 0 || y >= codes.rows) return false;
    const float* values = codes.ptr<float>(y);
    auto holds = [&](int x) {
        const double a = values[x], b = values[x + 1];
        return std::abs(a - b) <= max_step && code >= std::min(a, b) && code <= std::max(a, b);  // NaN fails
    };
    auto crossing = [&](int x) {
        const double a = values[x], b = values[x + 1];
        return a == b ? x + 0.5 : x + (code - a) / (b - a);
    };
    const int first = std::max(0, int(std::floor(near - window))), last = std::min(codes.cols - 2, int(std::floor(near + window)));
    int nearest = -1;
    for (int x = first; x <= last; ++x)
        if (holds(x) && (nearest < 0 || std::abs(crossing(x) - near) < std::abs(crossing(nearest) - near))) nearest = x;
    if (nearest < 0) return false;
    int begin = nearest, end = nearest;
    while (begin > 0 && holds(begin - 1)) --begin;
    while (end + 2 < codes.cols && holds(end + 1)) ++end;
    position = 0.5 * (crossing(begin) + crossing(end));
    return true;
}

// The left-right check's way back: where near `near` on the rectified row through y (between
// two grid rows) the code equals `code`. A local search: the forward match already required
// the code to cross the other camera's row once.
bool crossing_near(const cv::Mat& codes, double y, double near, double window, double code, double max_step,
                   double max_row_difference, double& position) {
    const int y0 = int(std::floor(y));
    double above = 0, below = 0;
    if (!nearest_crossing(codes, y0, near, window, code, max_step, above) ||
        !nearest_crossing(codes, y0 + 1, near, window, code, max_step, below) || std::abs(above - below) > max_row_difference)
        return false;
    const double t = y - y0;
    position = (1 - t) * above + t * below;
    return true;
}

cv::Matx33d rows_to_matrix(const cv::Vec3d& x, const cv::Vec3d& y, const cv::Vec3d& z) {
    return {x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]};
}

}  // namespace

// The projector as a third view of the first camera's rays (three-view triangulation).
struct ProjectorView {
    cv::Matx33d R;  // first camera -> projector
    cv::Vec3d T;
    cv::Matx33d matrix;
    detail::LensDistortion lens;

    // The projector pixel (column, row) of a point in the first camera's frame.
    cv::Vec2d pixel(const cv::Vec3d& point) const {
        const cv::Vec3d p = R * point + T;
        return detail::normalised_to_pixel(matrix, lens.distort({p[0] / p[2], p[1] / p[2]}));
    }
};

// Largest median projector column residual (projector pixels) of three-view points: more means
// the camera-projector calibration does not belong to these cameras and captures.
constexpr double kMaxMedianProjectorResidualPx = 1.0;

struct StereoMatcher::Impl {
    StereoCalibration calibration;
    std::optional<ProjectorView> projector;
    double focal = 0, cy = 0;     // rectified intrinsics shared by both cameras
    double baseline = 0;          // along the rectified x axis
    RectifiedGrid left, right;
    cv::Mat left_rays;            // CV_32FC2: undistorted normalised coordinates per left pixel
    cv::Mat left_rectified;       // CV_32FC2: rectified pixel per left pixel
};

StereoMatcher::StereoMatcher(const StereoCalibration& calibration) : impl_(std::make_unique<Impl>()) {
    validate_stereo_calibration(calibration, "stereo calibration");
    Impl& m = *impl_;
    m.calibration = calibration;
    const StereoCalibration& c = calibration;
    const detail::LensDistortion left_lens(c.left_distortion), right_lens(c.right_distortion);

    // The rectified frame: x along the baseline, y across it and the mean viewing direction.
    const cv::Vec3d right_centre = -(c.R.t() * c.T);
    m.baseline = cv::norm(right_centre);
    const cv::Vec3d x_axis = right_centre / m.baseline;
    const cv::Vec3d mean_view = cv::Vec3d(0, 0, 1) + c.R.t() * cv::Vec3d(0, 0, 1);
    cv::Vec3d y_axis = mean_view.cross(x_axis);
    if (cv::norm(y_axis) < 1e-6) throw Error("stereo calibration", "the cameras look along their baseline; they cannot be rectified");
    y_axis = cv::normalize(y_axis);
    m.left.rotation = rows_to_matrix(x_axis, y_axis, x_axis.cross(y_axis));
    m.right.rotation = m.left.rotation * c.R.t();
    m.focal = 0.25 * (c.left_matrix(0, 0) + c.left_matrix(1, 1) + c.right_matrix(0, 0) + c.right_matrix(1, 1));

    // Each image's border in rectified coordinates sets the rectified grids' extents.
    auto rectified_point = [&](const RectifiedGrid& grid, const cv::Matx33d& matrix, const detail::LensDistortion& lens,
                               cv::Vec2d pixel, cv::Vec2d& out) {
        const cv::Vec2d normalised = lens.undistort(detail::pixel_to_normalised(matrix, pixel));
        const cv::Vec3d ray = grid.rotation * cv::Vec3d(normalised[0], normalised[1], 1);
        if (!(ray[2] > 1e-3)) return false;
        out = {m.focal * ray[0] / ray[2], m.focal * ray[1] / ray[2]};
        return true;
    };
    struct Extent { double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300; };
    auto border_extent = [&](const RectifiedGrid& grid, const cv::Matx33d& matrix, const detail::LensDistortion& lens,
                             cv::Size size) {
        Extent extent;
        auto add = [&](double x, double y) {
            cv::Vec2d point;
            if (!rectified_point(grid, matrix, lens, {x, y}, point)) return;
            extent.x0 = std::min(extent.x0, point[0]);
            extent.x1 = std::max(extent.x1, point[0]);
            extent.y0 = std::min(extent.y0, point[1]);
            extent.y1 = std::max(extent.y1, point[1]);
        };
        for (int x = 0; x < size.width; x += 4) add(x, 0), add(x, size.height - 1);
        for (int y = 0; y < size.height; y += 4) add(0, y), add(size.width - 1, y);
        add(size.width - 1, size.height - 1);
        // Never larger than a few times the image: a wide-angle lens's border can run far out.
        const double half_width = kMaxRectifiedScale * size.width / 2.0, half_height = kMaxRectifiedScale * size.height / 2.0;
        const double middle_x = 0.5 * (extent.x0 + extent.x1), middle_y = 0.5 * (extent.y0 + extent.y1);
        extent.x0 = std::max(extent.x0, middle_x - half_width);
        extent.x1 = std::min(extent.x1, middle_x + half_width);
        extent.y0 = std::max(extent.y0, middle_y - half_height);
        extent.y1 = std::min(extent.y1, middle_y + half_height);
        return extent;
    };
    const Extent left_extent = border_extent(m.left, c.left_matrix, left_lens, c.left_size);
    const Extent right_extent = border_extent(m.right, c.right_matrix, right_lens, c.right_size);
    if (!(left_extent.x1 > left_extent.x0) || !(right_extent.x1 > right_extent.x0))
        throw Error("stereo calibration", "a camera looks away from the other's side; the pair cannot be rectified");
    const double y0 = std::min(left_extent.y0, right_extent.y0), y1 = std::max(left_extent.y1, right_extent.y1);
    m.cy = 2 - y0;
    const int rows = int(std::ceil(y1 - y0)) + 4;
    auto make_grid = [&](RectifiedGrid& grid, const Extent& extent, const cv::Matx33d& matrix,
                         const detail::LensDistortion& lens, cv::Size size) {
        grid.cx = 2 - extent.x0;
        const cv::Size grid_size(int(std::ceil(extent.x1 - extent.x0)) + 4, rows);
        grid.source_offset.create(grid_size, CV_32S);
        grid.source_weight.create(grid_size, CV_32FC2);
        const cv::Matx33d back = grid.rotation.t();
        detail::parallel_rows(grid_size.height, [&](int begin, int end) {
            for (int y = begin; y < end; ++y)
                for (int x = 0; x < grid_size.width; ++x) {
                    const cv::Vec3d ray = back * cv::Vec3d((x - grid.cx) / m.focal, (y - m.cy) / m.focal, 1);
                    int offset = -1;
                    cv::Vec2f weight(0, 0);
                    if (ray[2] > 1e-3) {
                        // Float pixel positions, as the bilinear sample of the camera map uses them.
                        const cv::Vec2f pixel(detail::normalised_to_pixel(matrix, lens.distort({ray[0] / ray[2], ray[1] / ray[2]})));
                        const int x0 = int(std::floor(pixel[0])), y0 = int(std::floor(pixel[1]));
                        if (x0 >= 0 && y0 >= 0 && x0 + 1 < size.width && y0 + 1 < size.height) {
                            offset = y0 * size.width + x0;
                            weight = cv::Vec2f(pixel[0] - float(x0), pixel[1] - float(y0));
                        }
                    }
                    grid.source_offset.at<int>(y, x) = offset;
                    grid.source_weight.at<cv::Vec2f>(y, x) = weight;
                }
        });
    };
    make_grid(m.left, left_extent, c.left_matrix, left_lens, c.left_size);
    make_grid(m.right, right_extent, c.right_matrix, right_lens, c.right_size);

    m.left_rays.create(c.left_size, CV_32FC2);
    m.left_rectified.create(c.left_size, CV_32FC2);
    detail::parallel_rows(c.left_size.height, [&](int begin, int end) {
        for (int y = begin; y < end; ++y)
            for (int x = 0; x < c.left_size.width; ++x) {
                const cv::Vec2d normalised = left_lens.undistort(detail::pixel_to_normalised(c.left_matrix, {double(x), double(y)}));
                m.left_rays.at<cv::Vec2f>(y, x) = cv::Vec2f(normalised);
                const cv::Vec3d ray = m.left.rotation * cv::Vec3d(normalised[0], normalised[1], 1);
                m.left_rectified.at<cv::Vec2f>(y, x) =
                    ray[2] > 1e-3 ? cv::Vec2f(float(m.focal * ray[0] / ray[2] + m.left.cx), float(m.focal * ray[1] / ray[2] + m.cy))
                                  : cv::Vec2f(kNaN, kNaN);
            }
    });
}

StereoMatcher::StereoMatcher(const StereoCalibration& calibration, const Calibration& projector)
    : StereoMatcher(calibration) {
    validate_calibration(projector, "projector calibration");
    if (projector.camera_size != calibration.left_size)
        throw Error("projector calibration", "its camera is " + std::to_string(projector.camera_size.width) + "x" +
                                                 std::to_string(projector.camera_size.height) +
                                                 " but the stereo calibration's first camera is " +
                                                 std::to_string(calibration.left_size.width) + "x" +
                                                 std::to_string(calibration.left_size.height) +
                                                 "; it must calibrate the first camera with the projector");
    impl_->projector = ProjectorView{projector.R, projector.T, projector.projector_matrix,
                                     detail::LensDistortion(projector.projector_distortion)};
}

StereoMatcher::~StereoMatcher() = default;
StereoMatcher::StereoMatcher(StereoMatcher&&) noexcept = default;
StereoMatcher& StereoMatcher::operator=(StereoMatcher&&) noexcept = default;

cv::Matx33d StereoMatcher::left_rectification() const { return impl_->left.rotation; }
cv::Matx33d StereoMatcher::right_rectification() const { return impl_->right.rotation; }

StereoReconstruction StereoMatcher::reconstruct(const CorrespondenceMap& left, const CorrespondenceMap& right,
                                                const cv::Mat& colour, const StereoOptions& options,
                                                const ProgressCallback& progress) const {
    const Impl& m = *impl_;
    const StereoCalibration& c = m.calibration;
    auto size_text = [](cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); };
    if (left.projector_u.size() != c.left_size)
        throw Error("stereo calibration", "camera1_size is " + size_text(c.left_size) + " but the first camera's captures are " +
                                              size_text(left.projector_u.size()));
    if (right.projector_u.size() != c.right_size)
        throw Error("stereo calibration", "camera2_size is " + size_text(c.right_size) +
                                              " but the second camera's captures are " + size_text(right.projector_u.size()));
    if (left.projector_u.type() != CV_32F || right.projector_u.type() != CV_32F)
        throw Error("stereo", "both cameras need decoded projector columns");
    if (!colour.empty() && (colour.size() != c.left_size || colour.type() != CV_8UC3))
        throw Error("colour", "colour image must be CV_8UC3 of the first camera's size");
    const bool use_rows = !left.projector_v.empty() && !right.projector_v.empty();

    const cv::Mat left_codes = resample(left.projector_u, m.left);
    const cv::Mat right_codes = resample(right.projector_u, m.right);
    const cv::Mat right_rows = use_rows ? resample(right.projector_v, m.right) : cv::Mat();
    const RowCodeIndex right_index(right_codes, options.max_code_step_px);
    const double back_window = options.max_left_right_difference_px + 2;
    const double max_row_difference = 4.0;  // rectified px between the crossings on two neighbouring rows

    StereoReconstruction result;
    ScanView& view = result.view;
    view.points.create(c.left_size, CV_32FC3);
    view.quality = left.quality;
    view.colours = colour.empty() ? cv::Mat(c.left_size, CV_8UC3, cv::Scalar::all(200)) : colour;
    view.camera_matrix = c.left_matrix;
    view.camera_distortion = c.left_distortion.clone();

    const int height = c.left_size.height, width = c.left_size.width;
    std::vector<StereoStatistics> row_statistics(static_cast<size_t>(height));
    std::vector<std::vector<float>> row_epipolar(static_cast<size_t>(height)), row_projector(static_cast<size_t>(height));
    const cv::Matx33d to_left = m.left.rotation.t();
    // Three views (a camera-projector calibration given): the rectified depth s along the exact
    // left ray that best explains the left pixel's projector codes u (and v) and the right
    // camera's match xr, by Gauss-Newton from the two-ray depth. With code noise of the same
    // size in both cameras, the residuals with unit variance are
    //   e_left  = u - P_u(s)                         (the projector's view of the left code)
    //   e_right = u - P_u(s) - g (xr - x_right(s))   (the right code at xr, g its slope along the row)
    //   e_row   = v - P_v(s)                         (where rows were decoded)
    // where P is the projector's pixel of the point and x_right(s) its rectified right column.
    // The first step solves the linearised least squares over the three views; a second
    // Gauss-Newton step follows. Returns |e_left| at the solution, NaN when not refined.
    auto three_view_depth = [&](const ProjectorView& projector, const cv::Matx33d& rectified_to_left, double a, double b,
                                double u, double v, double xr, double gradient, double& s) {
        if (!std::isfinite(gradient) || std::abs(gradient) < 1e-3) return std::numeric_limits<double>::quiet_NaN();
        const bool with_row = std::isfinite(v);
        auto residuals = [&](double depth, double out[3]) {
            const cv::Vec2d pixel = projector.pixel(rectified_to_left * cv::Vec3d(a * depth, b * depth, depth));
            const double x_right = m.focal * (a - m.baseline / depth) + m.right.cx;
            out[0] = u - pixel[0];
            out[1] = u - pixel[0] - gradient * (xr - x_right);
            out[2] = with_row ? v - pixel[1] : 0.0;
        };
        for (int iteration = 0; iteration < 2; ++iteration) {
            double r[3], ahead[3], behind[3];
            const double h = 1e-4 * s;
            residuals(s, r);
            residuals(s + h, ahead);
            residuals(s - h, behind);
            double jtj = 0, jtr = 0;
            for (int k = 0; k < 3; ++k) {
                const double jacobian = (ahead[k] - behind[k]) / (2 * h);
                jtj += jacobian * jacobian;
                jtr += jacobian * r[k];
            }
            if (!(jtj > 0)) return std::numeric_limits<double>::quiet_NaN();
            s -= jtr / jtj;
        }
        double r[3];
        residuals(s, r);
        return std::abs(r[0]);
    };
    detail::ProgressReporter reporter(progress, "stereo", height);
    detail::parallel_rows(height, [&](int begin, int end) {
        for (int y = begin; y < end && !reporter.cancelled(); ++y) {
            StereoStatistics& counts = row_statistics[size_t(y)];
            cv::Vec3f* points = view.points.ptr<cv::Vec3f>(y);
            const float* codes = left.projector_u.ptr<float>(y);
            const float* row_codes = use_rows ? left.projector_v.ptr<float>(y) : nullptr;
            const cv::Vec2f* rectified = m.left_rectified.ptr<cv::Vec2f>(y);
            const cv::Vec2f* rays = m.left_rays.ptr<cv::Vec2f>(y);
            for (int x = 0; x < width; ++x) {
                points[x] = cv::Vec3f(kNaN, kNaN, kNaN);
                const double code = codes[x];
                if (!std::isfinite(code)) continue;
                ++counts.left_decoded;
                const double xl = rectified[x][0], yl = rectified[x][1];
                if (!std::isfinite(xl)) continue;
                double xr = 0;
                const auto forward = find_between_rows(right_index, yl, code, max_row_difference, xr);
                if (forward == RowCodeIndex::Found::Ambiguous) ++counts.ambiguous;
                if (forward != RowCodeIndex::Found::Once) continue;
                ++counts.matched;
                // Left-right check: from the match, find the right camera's code on the left row.
                const double right_code = sample(right_codes, xr, yl);
                double xl_back = 0;
                if (!std::isfinite(right_code) ||
                    !crossing_near(left_codes, yl, xl, back_window, right_code, options.max_code_step_px,
                                   max_row_difference, xl_back) ||
                    std::abs(xl_back - xl) > options.max_left_right_difference_px)
                    continue;
                ++counts.left_right_consistent;
                // Row codes: how far across the row the right camera sees the left pixel's projector row.
                if (row_codes && std::isfinite(row_codes[x])) {
                    const double right_row = sample(right_rows, xr, yl);
                    const double gradient = (sample(right_rows, xr, yl + 2) - sample(right_rows, xr, yl - 2)) / 4;
                    if (std::isfinite(right_row) && std::isfinite(gradient) && std::abs(gradient) > 1e-3) {
                        const double epipolar_error = std::abs(row_codes[x] - right_row) / std::abs(gradient);
                        row_epipolar[size_t(y)].push_back(float(epipolar_error));
                        if (epipolar_error > options.max_epipolar_error_px) {
                            ++counts.epipolar_rejected;
                            continue;
                        }
                    }
                }
                // Both rays exact (undistorted), in the rectified frame where they share y:
                // left from the origin, right from (baseline, 0, 0).
                const cv::Vec3d left_ray = m.left.rotation * cv::Vec3d(rays[x][0], rays[x][1], 1);
                const double a = left_ray[0] / left_ray[2], b = left_ray[1] / left_ray[2];
                const double a_right = (xr - m.right.cx) / m.focal;
                const double depth = m.baseline / (a - a_right);
                if (!(depth > 0)) {
                    ++counts.behind;
                    continue;
                }
                double refined_depth = depth;
                if (m.projector) {
                    const double gradient = sample(right_codes, xr + 0.5, yl) - sample(right_codes, xr - 0.5, yl);
                    const double row_code = row_codes ? double(row_codes[x]) : std::numeric_limits<double>::quiet_NaN();
                    const double residual = three_view_depth(*m.projector, to_left, a, b, code, row_code, xr, gradient,
                                                             refined_depth);
                    if (std::isfinite(residual)) row_projector[size_t(y)].push_back(float(residual));
                }
                const cv::Vec3d point = to_left * cv::Vec3d(a * refined_depth, b * refined_depth, refined_depth);
                if (!(point[2] >= options.min_depth_mm && point[2] <= options.max_depth_mm)) continue;
                points[x] = cv::Vec3f(point);
                ++counts.valid;
            }
            reporter.advance();
        }
    });
    if (reporter.cancelled()) throw Error("cancelled", "stereo reconstruction cancelled");

    StereoStatistics& total = result.statistics;
    std::vector<float> epipolar, projector_residuals;
    for (int y = 0; y < height; ++y) {
        const StereoStatistics& counts = row_statistics[size_t(y)];
        total.left_decoded += counts.left_decoded;
        total.matched += counts.matched;
        total.ambiguous += counts.ambiguous;
        total.left_right_consistent += counts.left_right_consistent;
        total.epipolar_rejected += counts.epipolar_rejected;
        total.valid += counts.valid;
        total.behind += counts.behind;
        epipolar.insert(epipolar.end(), row_epipolar[size_t(y)].begin(), row_epipolar[size_t(y)].end());
        projector_residuals.insert(projector_residuals.end(), row_projector[size_t(y)].begin(), row_projector[size_t(y)].end());
    }
    if (total.left_decoded == 0) throw Error("stereo", "the first camera decoded no projector columns");
    // Matches behind the cameras: the codes run the other way along the rows than the
    // calibration expects.
    if (total.behind > 100 && total.behind > total.left_right_consistent / 2)
        throw Error("stereo calibration", "does not fit these captures: " + std::to_string(total.behind) + " of " +
                                              std::to_string(total.left_right_consistent) +
                                              " matches lie behind the cameras; are the first and second camera's "
                                              "captures swapped?");
    if (!epipolar.empty()) {
        std::nth_element(epipolar.begin(), epipolar.begin() + long(epipolar.size() / 2), epipolar.end());
        total.median_epipolar_error_px = epipolar[epipolar.size() / 2];
        if (epipolar.size() >= 100 && total.median_epipolar_error_px > options.max_epipolar_error_px) {
            char problem[300];
            std::snprintf(problem, sizeof problem,
                          "does not fit these captures: where the cameras see the same projector column, their projector "
                          "rows are a median %.1f rectified pixels apart across the epipolar line (at most %.1f allowed); "
                          "check that R, T take the first camera to the second and the captures are not swapped",
                          total.median_epipolar_error_px, options.max_epipolar_error_px);
            throw Error("stereo calibration", problem);
        }
    }
    if (!projector_residuals.empty()) {
        total.three_view = int(projector_residuals.size());
        std::nth_element(projector_residuals.begin(), projector_residuals.begin() + long(projector_residuals.size() / 2),
                         projector_residuals.end());
        total.median_projector_residual_px = projector_residuals[projector_residuals.size() / 2];
        if (projector_residuals.size() >= 100 && total.median_projector_residual_px > kMaxMedianProjectorResidualPx) {
            char problem[300];
            std::snprintf(problem, sizeof problem,
                          "does not fit these cameras and captures: the points the two cameras agree on are a median "
                          "%.2f projector pixels from the columns the first camera decoded (at most %.1f allowed); is it "
                          "the first camera's calibration with this projector?",
                          total.median_projector_residual_px, kMaxMedianProjectorResidualPx);
            throw Error("projector calibration", problem);
        }
    }
    estimate_normals(view);
    return result;
}

StereoReconstruction reconstruct_stereo(const CaptureSet& left, const CaptureSet& right, const StereoCalibration& calibration,
                                        const DecodeOptions& decode_options, const StereoOptions& options,
                                        const ProgressCallback& progress) {
    const StereoMatcher matcher(calibration);
    const CorrespondenceMap left_map = decode(left, decode_options, progress);
    const CorrespondenceMap right_map = decode(right, decode_options, progress);
    return matcher.reconstruct(left_map, right_map, left.white_colour, options, progress);
}

}  // namespace picoscan
