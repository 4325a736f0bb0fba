// Point clouds and meshes: plain data passed between the stages.
#pragma once

#include <opencv2/core.hpp>

#include <cmath>
#include <functional>
#include <vector>

namespace picoscan {

// An organised scan: one entry per camera pixel, NaN points where nothing was measured.
struct ScanView {
    cv::Mat points;   // CV_32FC3, mm, camera frame
    cv::Mat normals;  // CV_32FC3, unit, pointing towards the camera
    cv::Mat colours;  // CV_8UC3, BGR from the white frame
    cv::Mat quality;  // CV_32F
    cv::Matx44d pose = cv::Matx44d::eye();  // view -> model transform
    // The camera that saw the view, so later stages (cleaning, grid meshing, registration)
    // know a pixel's footprint and ray without asking for the calibration again.
    cv::Matx33d camera_matrix = cv::Matx33d::zeros();  // zero when unknown
    cv::Mat camera_distortion;                          // OpenCV coefficients, empty for none

    int valid_count() const;
    // The camera's focal length in pixels; throws Error when the view does not know its camera.
    double focal_px() const;
};

struct PointCloud {
    std::vector<cv::Vec3f> points;
    std::vector<cv::Vec3f> normals;  // empty or one per point
    std::vector<cv::Vec3b> colours;  // empty or one per point, RGB
    std::vector<float> quality;      // empty or one per point
};

struct Mesh {
    std::vector<cv::Vec3f> vertices;
    std::vector<cv::Vec3i> faces;    // counter-clockwise seen from outside (or from the camera)
    std::vector<cv::Vec3f> normals;  // empty or one per vertex
    std::vector<cv::Vec3b> colours;  // empty or one per vertex, RGB
    // Empty, or one per vertex: 1 where measured points support the surface, 0 where it was
    // filled in (a closed-over gap, a cap): what the scanner did not see.
    std::vector<uint8_t> measured;
};

// A measured point: every coordinate finite (unmeasured pixels hold NaN).
inline bool is_finite_point(const cv::Vec3f& p) {
    return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

// The valid points of a view, transformed by its pose.
PointCloud to_point_cloud(const ScanView& view);

// Merges views (each transformed by its pose) into one cloud with normals and colours.
PointCloud merge_views(const std::vector<ScanView>& views);

// The same merge, the views asked for one at a time (view_at(0) .. view_at(view_count - 1)),
// each dropped once its valid points are in: only one view is ever held whole, so more views
// can be merged than fit in memory as pixel grids (read from files or made on demand).
using ViewSource = std::function<ScanView(size_t index)>;
PointCloud merge_view_stream(size_t view_count, const ViewSource& view_at);

// The mesh with its vertices (and normals) moved by a rigid transform.
Mesh transformed(const Mesh& mesh, const cv::Matx44d& transform);

struct GridMeshOptions {
    // Neighbouring pixels are joined only when their 3D distance is below
    // max_edge_factor times the footprint of one pixel at that depth, so depth
    // discontinuities are not bridged.
    double max_edge_factor = 8.0;
    // Join every n-th pixel only (n x n fewer vertices): a lighter mesh for previews and printing.
    int pixel_step = 1;
};

// Triangulates the pixel grid of an organised view; the view's camera gives a pixel's footprint.
Mesh grid_mesh(const ScanView& view, const GridMeshOptions& options = {});

// Replaces view.normals with normals from the pixel grid: cross product of the horizontal and
// vertical neighbour differences (central where both neighbours exist), turned towards the
// camera at the origin. NaN where a pixel has no point or no usable neighbour.
void estimate_normals(ScanView& view);

}  // namespace picoscan
