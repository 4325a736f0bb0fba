#include "picoscan/preview.h"

#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/simulate.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace picoscan {

cv::Mat render_preview(const ScanView& view) {
    const cv::Mat& points = view.points;
    std::vector<float> depths;
    depths.reserve(points.total() / 4);
    for (int y = 0; y < points.rows; ++y)
        for (int x = 0; x < points.cols; ++x)
            if (std::isfinite(points.at<cv::Vec3f>(y, x)[2])) depths.push_back(points.at<cv::Vec3f>(y, x)[2]);
    cv::Mat preview(points.size(), CV_8UC3, cv::Scalar(40, 40, 40));
    if (depths.empty()) return preview;
    // Robust depth range: the 2nd..98th percentiles, so a few stray points do not wash out the colours.
    std::sort(depths.begin(), depths.end());
    const float near = depths[depths.size() * 2 / 100], far = depths[depths.size() * 98 / 100];
    const float span = std::max(far - near, 1e-3f);

    cv::Mat depth_levels(points.size(), CV_8U, cv::Scalar(0));
    for (int y = 0; y < points.rows; ++y)
        for (int x = 0; x < points.cols; ++x) {
            const float z = points.at<cv::Vec3f>(y, x)[2];
            if (std::isfinite(z)) depth_levels.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(255 * (far - z) / span);
        }
    cv::Mat colours;
    cv::applyColorMap(depth_levels, colours, cv::COLORMAP_VIRIDIS);

    const cv::Vec3f light = cv::normalize(cv::Vec3f(-0.4f, -0.5f, -1.0f));  // from above-left of the camera
    for (int y = 0; y < points.rows; ++y)
        for (int x = 0; x < points.cols; ++x) {
            if (!std::isfinite(points.at<cv::Vec3f>(y, x)[2])) continue;
            const cv::Vec3f normal = view.normals.empty() ? cv::Vec3f(0, 0, -1) : view.normals.at<cv::Vec3f>(y, x);
            const float lambert = std::isfinite(normal[0]) ? std::max(0.0f, normal.dot(light)) : 0.5f;
            const float brightness = 0.25f + 0.75f * lambert;
            const cv::Vec3b colour = colours.at<cv::Vec3b>(y, x);
            preview.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uint8_t>(colour[0] * brightness),
                                                    cv::saturate_cast<uint8_t>(colour[1] * brightness),
                                                    cv::saturate_cast<uint8_t>(colour[2] * brightness));
        }
    return preview;
}

void write_preview_png(const ScanView& view, const std::string& path) {
    write_image_file(render_preview(view), path);
}

void write_mesh_preview_png(const Mesh& mesh, const Calibration& camera, const std::string& path) {
    Scene scene;
    scene.meshes.push_back({mesh, 0.8});
    const Simulator simulator(camera, scene);
    ScanView view;
    view.points = simulator.geometry().points;
    view.normals = simulator.geometry().normals;
    cv::Mat seen(view.points.size(), CV_8U, cv::Scalar(0));
    for (int y = 0; y < seen.rows; ++y)
        for (int x = 0; x < seen.cols; ++x) seen.at<uint8_t>(y, x) = std::isfinite(view.points.at<cv::Vec3f>(y, x)[2]) ? 255 : 0;
    cv::Rect box = cv::boundingRect(seen);
    if (box.empty()) throw Error(path, "the mesh is not in the camera's view");
    const int margin = 40;
    box = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
          cv::Rect(0, 0, view.points.cols, view.points.rows);
    write_image_file(render_preview(view)(box), path);
}

}  // namespace picoscan
