// The part frame recipe: a scan placed Z up on its turntable's axis or its base plane.
#include "common/text_format.h"
#include "picoscan/error.h"
#include "picoscan/pipeline.h"
#include "picoscan/shapes.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace picoscan {

namespace {

// "Up" seen from a camera: towards it and against its image's y (which points down).
const cv::Vec3d kCameraUp(0, -1, -1);

// Camera x made square to Z, or its y when x is nearly along Z.
cv::Vec3d x_hint_for(const cv::Vec3d& up) {
    return std::abs(up.dot(cv::Vec3d(1, 0, 0))) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
}

PartFrame on_turntable(const PointCloud& cloud, const TurntableAxis& axis) {
    cv::Vec3d up = axis.direction / cv::norm(axis.direction);
    if (up.dot(kCameraUp) < 0) up = -up;
    // The lowest points along the axis (0.2 percentile, so a stray point does not decide) are the table top.
    std::vector<double> heights;
    heights.reserve(cloud.points.size());
    for (const auto& point : cloud.points) heights.push_back((cv::Vec3d(point) - axis.point_mm).dot(up));
    const size_t low = heights.size() / 500;
    std::nth_element(heights.begin(), heights.begin() + long(low), heights.end());
    const double base = heights[low];
    PartFrame result;
    result.frame = frame_from_axis(axis.point_mm + base * up, up, x_hint_for(up));
    result.basis = format("turntable axis (step %.2f deg)", axis.step_deg);
    return result;
}

PartFrame on_base_plane(const PointCloud& cloud, const PartFrameOptions& options, const ProgressCallback& progress) {
    if (cloud.normals.size() != cloud.points.size())
        throw Error("cloud", "has no normals: the base plane cannot be found");
    PointCloud subset;
    const size_t stride = std::max<size_t>(1, cloud.points.size() / size_t(options.max_points));
    for (size_t i = 0; i < cloud.points.size(); i += stride) {
        subset.points.push_back(cloud.points[i]);
        subset.normals.push_back(cloud.normals[i]);
    }
    ShapeDetectionOptions detection;
    detection.planes = true;
    detection.cylinders = detection.spheres = detection.cones = false;
    detection.epsilon_mm = options.plane_epsilon_mm;
    detection.min_points = std::max(3, int(options.min_plane_share * double(subset.points.size())));
    if (subset.points.size() < size_t(detection.min_points))
        throw Error("cloud", "has " + std::to_string(subset.points.size()) + " points: too few to find a base plane");
    const std::vector<DetectedShape> planes = detect_shapes(subset, detection, progress);
    if (planes.empty())
        throw Error("cloud", format("has no plane holding %.0f %% of its points to stand on; place it by datum alignment",
                                    100 * options.min_plane_share));
    const DetectedShape& largest = *std::max_element(planes.begin(), planes.end(), [](const auto& a, const auto& b) {
        return a.inliers.size() < b.inliers.size();
    });
    cv::Vec3d up = largest.direction / cv::norm(largest.direction);  // oriented like the points' normals: to the camera
    // The origin lies under the middle of what stands on the plane (or the plane's own middle).
    cv::Vec3d middle(0, 0, 0);
    size_t above = 0;
    for (const auto& point : subset.points) {
        if ((cv::Vec3d(point) - largest.point).dot(up) > 3 * options.plane_epsilon_mm) {
            middle += cv::Vec3d(point);
            ++above;
        }
    }
    middle = above > 0 ? middle / double(above) : largest.point;
    const cv::Vec3d origin = middle - (middle - largest.point).dot(up) * up;
    PartFrame result;
    result.frame = frame_from_axis(origin, up, x_hint_for(up));
    result.basis = format("base plane (%.0f %% of the points, rms %.3f mm)",
                          100.0 * double(largest.inliers.size()) / double(subset.points.size()), largest.rms_mm);
    return result;
}

}  // namespace

void validate(const PartFrameOptions& options) {
    if (!(options.max_points >= 100)) throw Error("max_points", "must be at least 100");
    if (!(options.plane_epsilon_mm > 0 && options.plane_epsilon_mm <= 100))
        throw Error("plane_epsilon_mm", "must be in (0, 100] mm");
    if (!(options.min_plane_share > 0 && options.min_plane_share < 1)) throw Error("min_plane_share", "must be in (0, 1)");
}

PartFrame part_frame(const PointCloud& cloud, const std::optional<TurntableAxis>& turntable, const PartFrameOptions& options,
                     const ProgressCallback& progress) {
    validate(options);
    if (cloud.points.empty()) throw Error("cloud", "has no points");
    return turntable ? on_turntable(cloud, *turntable) : on_base_plane(cloud, options, progress);
}

}  // namespace picoscan
