// Clouds and meshes moved and merged: views into one model frame, meshes by a rigid transform.
#include "picoscan/cloud.h"

namespace picoscan {

PointCloud merge_views(const std::vector<ScanView>& views) {
    return merge_view_stream(views.size(), [&](size_t index) { return views[index]; });  // cv::Mat copies share the pixels
}

PointCloud merge_view_stream(size_t view_count, const ViewSource& view_at) {
    PointCloud merged;
    for (size_t index = 0; index < view_count; ++index) {
        const PointCloud cloud = to_point_cloud(view_at(index));  // the whole view lives only in this statement
        merged.points.insert(merged.points.end(), cloud.points.begin(), cloud.points.end());
        merged.normals.insert(merged.normals.end(), cloud.normals.begin(), cloud.normals.end());
        merged.colours.insert(merged.colours.end(), cloud.colours.begin(), cloud.colours.end());
        merged.quality.insert(merged.quality.end(), cloud.quality.begin(), cloud.quality.end());
    }
    // A layer some views lack is dropped for all, so every layer stays one per point.
    auto keep = [&](auto& layer) {
        if (layer.size() != merged.points.size()) layer.clear();
        layer.shrink_to_fit();  // growing by doubling left up to twice the room
    };
    keep(merged.points);
    keep(merged.normals);
    keep(merged.colours);
    keep(merged.quality);
    return merged;
}

Mesh transformed(const Mesh& mesh, const cv::Matx44d& transform) {
    const cv::Matx33d rotation = transform.get_minor<3, 3>(0, 0);
    const cv::Vec3d translation(transform(0, 3), transform(1, 3), transform(2, 3));
    Mesh out = mesh;
    for (cv::Vec3f& v : out.vertices) v = cv::Vec3f(rotation * cv::Vec3d(v) + translation);
    for (cv::Vec3f& n : out.normals) n = cv::Vec3f(rotation * cv::Vec3d(n));
    return out;
}

}  // namespace picoscan
