#include "picoscan/clean.h"

#include "picoscan/error.h"

#include "common/parallel.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

namespace picoscan {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;

bool valid(const cv::Vec3f& point) { return point[2] == point[2]; }

// Marks points for removal where `reject` says so; returns how many it removed.
template <typename Rule>
int remove_where(ScanView& view, Rule&& reject) {
    std::vector<int> removed(view.points.rows, 0);
    detail::parallel_rows(view.points.rows, [&](int begin, int end) {
        for (int y = begin; y < end; ++y)
            for (int x = 0; x < view.points.cols; ++x)
                if (valid(view.points.at<cv::Vec3f>(y, x)) && reject(x, y)) ++removed[y];
    });
    return std::accumulate(removed.begin(), removed.end(), 0);
}

void erase(ScanView& view, const cv::Mat& doomed) {
    for (int y = 0; y < view.points.rows; ++y)
        for (int x = 0; x < view.points.cols; ++x)
            if (doomed.at<uint8_t>(y, x)) {
                view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(kNaN, kNaN, kNaN);
                if (!view.normals.empty()) view.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(kNaN, kNaN, kNaN);
            }
}

// Removes the points flagged by `reject` (evaluated on the view before any removal).
template <typename Rule>
int apply(ScanView& view, Rule&& reject) {
    cv::Mat doomed(view.points.size(), CV_8U, cv::Scalar(0));
    const int count = remove_where(view, [&](int x, int y) {
        const bool gone = reject(x, y);
        if (gone) doomed.at<uint8_t>(y, x) = 1;
        return gone;
    });
    erase(view, doomed);
    return count;
}

}  // namespace

CleanReport clean_view(ScanView& view, const CleanOptions& options) {
    if (view.points.empty() || view.points.type() != CV_32FC3) throw Error("clean", "the view has no organised points");
    const double camera_focal_px = view.focal_px();
    if (options.window_px < 1 || options.window_px > 10) throw Error("clean", "window_px must be 1..10");
    CleanReport report;
    const cv::Mat& points = view.points;
    const int width = points.cols, height = points.rows, w = options.window_px;
    auto footprint = [&](const cv::Vec3f& point) { return std::abs(point[2]) / camera_focal_px; };

    if (options.min_quality > 0 && !view.quality.empty())
        report.by_quality = apply(view, [&](int x, int y) { return view.quality.at<float>(y, x) < options.min_quality; });

    if (options.max_grazing_deg < 90 && !view.normals.empty()) {
        const double min_cosine = std::cos(options.max_grazing_deg * kPi / 180);
        report.by_grazing = apply(view, [&](int x, int y) {
            const cv::Vec3f normal = view.normals.at<cv::Vec3f>(y, x), point = points.at<cv::Vec3f>(y, x);
            if (!valid(normal)) return false;
            return -normal.dot(point) / std::sqrt(point.dot(point)) < min_cosine;
        });
    }

    if (options.use_working_volume)
        report.by_working_volume = apply(view, [&](int x, int y) {
            const cv::Vec3f p = points.at<cv::Vec3f>(y, x);
            for (int axis = 0; axis < 3; ++axis)
                if (p[axis] < options.volume_min[axis] || p[axis] > options.volume_max[axis]) return true;
            return false;
        });

    // Statistical: distance to the 4th nearest window neighbour, in expected spacings; robust threshold.
    {
        cv::Mat spacing(points.size(), CV_32F, cv::Scalar(kNaN));
        detail::parallel_rows(height, [&](int begin, int end) {
            std::vector<float> distances;
            for (int y = begin; y < end; ++y)
                for (int x = 0; x < width; ++x) {
                    const cv::Vec3f p = points.at<cv::Vec3f>(y, x);
                    if (!valid(p)) continue;
                    distances.clear();
                    for (int dy = -w; dy <= w; ++dy)
                        for (int dx = -w; dx <= w; ++dx) {
                            const int nx = x + dx, ny = y + dy;
                            if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
                            const cv::Vec3f q = points.at<cv::Vec3f>(ny, nx);
                            if (valid(q)) distances.push_back(float(cv::norm(p - q)));
                        }
                    // Expected spacing: one footprint, stretched by 1/cos on surfaces seen obliquely.
                    float unit = float(footprint(p));
                    if (!view.normals.empty() && valid(view.normals.at<cv::Vec3f>(y, x))) {
                        const float cosine = std::abs(view.normals.at<cv::Vec3f>(y, x).dot(p)) / std::sqrt(p.dot(p));
                        unit /= std::max(cosine, 0.1f);
                    }
                    if (distances.size() < 4) {
                        spacing.at<float>(y, x) = std::numeric_limits<float>::infinity();  // nearly alone
                        continue;
                    }
                    std::nth_element(distances.begin(), distances.begin() + 3, distances.end());
                    spacing.at<float>(y, x) = distances[3] / unit;
                }
        });
        std::vector<float> values;
        for (auto it = spacing.begin<float>(); it != spacing.end<float>(); ++it)
            if (std::isfinite(*it)) values.push_back(*it);
        if (!values.empty()) {
            std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
            const float median = values[values.size() / 2];
            std::vector<float> deviations(values.size());
            for (size_t index = 0; index < values.size(); ++index) deviations[index] = std::abs(values[index] - median);
            std::nth_element(deviations.begin(), deviations.begin() + deviations.size() / 2, deviations.end());
            const float robust_sigma = 1.4826f * deviations[deviations.size() / 2];
            const float limit = median + float(options.outlier_sigma) * std::max(robust_sigma, 0.05f * median);
            report.by_statistics = apply(view, [&](int x, int y) { return !(spacing.at<float>(y, x) <= limit); });
        }
    }

    // Radius: too few neighbours close by.
    report.by_radius = apply(view, [&](int x, int y) {
        const cv::Vec3f p = points.at<cv::Vec3f>(y, x);
        const double radius = options.radius_footprints * footprint(p);
        int close = 0;
        for (int dy = -w; dy <= w; ++dy)
            for (int dx = -w; dx <= w; ++dx) {
                const int nx = x + dx, ny = y + dy;
                if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
                const cv::Vec3f q = points.at<cv::Vec3f>(ny, nx);
                if (valid(q) && cv::norm(p - q) < radius) ++close;
            }
        return close < options.min_neighbours;
    });

    // Clusters: flood fill over 4-neighbours closer than 8 footprints.
    {
        cv::Mat label(points.size(), CV_32S, cv::Scalar(-1));
        std::vector<int> sizes;
        std::vector<cv::Point> stack;
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                if (!valid(points.at<cv::Vec3f>(y, x)) || label.at<int>(y, x) >= 0) continue;
                const int id = int(sizes.size());
                int size = 0;
                stack.assign(1, {x, y});
                label.at<int>(y, x) = id;
                while (!stack.empty()) {
                    const cv::Point at = stack.back();
                    stack.pop_back();
                    ++size;
                    const cv::Vec3f p = points.at<cv::Vec3f>(at);
                    const double join = 8 * footprint(p);
                    for (const cv::Point step : {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
                        const cv::Point next = at + step;
                        if (next.x < 0 || next.y < 0 || next.x >= width || next.y >= height || label.at<int>(next) >= 0) continue;
                        const cv::Vec3f q = points.at<cv::Vec3f>(next);
                        if (!valid(q) || cv::norm(p - q) >= join) continue;
                        label.at<int>(next) = id;
                        stack.push_back(next);
                    }
                }
                sizes.push_back(size);
            }
        report.by_cluster = apply(view, [&](int x, int y) { return sizes[size_t(label.at<int>(y, x))] < options.min_cluster_points; });
    }

    report.remaining = view.valid_count();
    return report;
}

int remove_background(ScanView& view, const ScanView& background, double tolerance_mm) {
    if (background.points.size() != view.points.size())
        throw Error("background", "its pixel grid differs from the view's (scan it with the same camera)");
    const float nan = std::numeric_limits<float>::quiet_NaN();
    int removed = 0;
    for (int y = 0; y < view.points.rows; ++y)
        for (int x = 0; x < view.points.cols; ++x) {
            cv::Vec3f& p = view.points.at<cv::Vec3f>(y, x);
            const cv::Vec3f& b = background.points.at<cv::Vec3f>(y, x);
            if (!std::isfinite(p[2]) || !std::isfinite(b[2])) continue;
            // Along one camera ray, depth orders the two: nearer than the background by more
            // than the tolerance means something stands in front of it.
            if (cv::norm(p) < cv::norm(b) - tolerance_mm) continue;
            p = cv::Vec3f(nan, nan, nan);
            if (!view.normals.empty()) view.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(nan, nan, nan);
            ++removed;
        }
    return removed;
}

}  // namespace picoscan
