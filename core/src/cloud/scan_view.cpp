// ScanView -> PointCloud: the valid points of an organised view, in the model frame.
#include "cloud/view_check.h"
#include "common/parallel.h"
#include "picoscan/cloud.h"
#include "picoscan/error.h"

#include <cmath>
#include <numeric>
#include <string>
#include <vector>

namespace picoscan {

namespace detail {

ViewLayers check_view(const ScanView& view, const std::string& name) {
    if (view.points.empty()) return {};
    if (view.points.type() != CV_32FC3) throw Error(name, "points must be CV_32FC3");
    auto layer = [&](const cv::Mat& mat, int type, const char* layer_name, const char* type_name) {
        if (mat.empty()) return false;
        if (mat.size() != view.points.size())
            throw Error(name, std::string(layer_name) + " size does not match the points");
        if (mat.type() != type) throw Error(name, std::string(layer_name) + " must be " + type_name);
        return true;
    };
    ViewLayers layers;
    layers.normals = layer(view.normals, CV_32FC3, "normals", "CV_32FC3");
    layers.colours = layer(view.colours, CV_8UC3, "colours", "CV_8UC3");
    layers.quality = layer(view.quality, CV_32F, "quality", "CV_32F");
    return layers;
}

void check_view_reach(const ScanView& view, const std::string& name) {
    check_view(view, name);
    for (int y = 0; y < view.points.rows; ++y) {
        const cv::Vec3f* row = view.points.ptr<cv::Vec3f>(y);
        for (int x = 0; x < view.points.cols; ++x) {
            const cv::Vec3f& p = row[x];
            if (is_finite_point(p) && beyond_reach(p))
                throw Error(name, "point at pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                      ") lies beyond 1 km (1e6 mm) from the origin: not a scan view");
        }
    }
}

}  // namespace detail

int ScanView::valid_count() const {
    if (points.empty()) return 0;
    if (points.type() != CV_32FC3) throw Error("scan view", "points must be CV_32FC3");
    int count = 0;
    for (int y = 0; y < points.rows; ++y) {
        const cv::Vec3f* row = points.ptr<cv::Vec3f>(y);
        for (int x = 0; x < points.cols; ++x) count += is_finite_point(row[x]) ? 1 : 0;
    }
    return count;
}

double ScanView::focal_px() const {
    const double focal = camera_matrix(0, 0);
    if (!(focal > 0) || !std::isfinite(focal))
        throw Error("scan view", "does not know its camera (made before views stored it: reconstruct it again)");
    return focal;
}

PointCloud to_point_cloud(const ScanView& view) {
    const detail::ViewLayers layers = detail::check_view(view);
    PointCloud cloud;
    if (view.points.empty()) return cloud;
    const int rows = view.points.rows, cols = view.points.cols;

    // Count per row first so rows can be filled in parallel at known offsets, keeping
    // the row-major order.
    std::vector<size_t> offsets(static_cast<size_t>(rows) + 1, 0);
    detail::parallel_rows(rows, [&](int begin, int end) {
        for (int y = begin; y < end; ++y) {
            const cv::Vec3f* row = view.points.ptr<cv::Vec3f>(y);
            size_t count = 0;
            for (int x = 0; x < cols; ++x) count += is_finite_point(row[x]) ? 1 : 0;
            offsets[static_cast<size_t>(y) + 1] = count;
        }
    });
    std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
    const size_t total = offsets.back();
    cloud.points.resize(total);
    if (layers.normals) cloud.normals.resize(total);
    if (layers.colours) cloud.colours.resize(total);
    if (layers.quality) cloud.quality.resize(total);

    const cv::Matx33d rotation = view.pose.get_minor<3, 3>(0, 0);
    const cv::Vec3d translation(view.pose(0, 3), view.pose(1, 3), view.pose(2, 3));
    detail::parallel_rows(rows, [&](int begin, int end) {
        for (int y = begin; y < end; ++y) {
            const cv::Vec3f* points = view.points.ptr<cv::Vec3f>(y);
            size_t out = offsets[static_cast<size_t>(y)];
            for (int x = 0; x < cols; ++x) {
                if (!is_finite_point(points[x])) continue;
                const cv::Vec3d p = rotation * cv::Vec3d(points[x]) + translation;
                cloud.points[out] = cv::Vec3f(p);
                if (layers.normals) cloud.normals[out] = cv::Vec3f(rotation * cv::Vec3d(view.normals.at<cv::Vec3f>(y, x)));
                if (layers.colours) {
                    const cv::Vec3b bgr = view.colours.at<cv::Vec3b>(y, x);
                    cloud.colours[out] = cv::Vec3b(bgr[2], bgr[1], bgr[0]);
                }
                if (layers.quality) cloud.quality[out] = view.quality.at<float>(y, x);
                ++out;
            }
        }
    });
    return cloud;
}

}  // namespace picoscan
