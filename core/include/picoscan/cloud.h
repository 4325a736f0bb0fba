// Point clouds and meshes: plain data passed between the stages.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace picoscan {

// An organised scan: one entry per camera pixel, NaN points where nothing was measured.
struct ScanView {
    cv::Mat points;   // CV_32FC3, mm, camera frame
    cv::Mat normals;  // CV_32FC3, unit, pointing towards the camera
    cv::Mat colours;  // CV_8UC3, BGR from the white frame
    cv::Mat quality;  // CV_32F
    cv::Matx44d pose = cv::Matx44d::eye();  // view -> model transform

    int valid_count() const;
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

// The valid points of a view, transformed by its pose.
PointCloud to_point_cloud(const ScanView& view);

struct GridMeshOptions {
    // Neighbouring pixels are joined only when their 3D distance is below
    // max_edge_factor times the footprint of one pixel at that depth, so depth
    // discontinuities are not bridged.
    double max_edge_factor = 8.0;
    // Join every n-th pixel only (n x n fewer vertices): a lighter mesh for previews and printing.
    int pixel_step = 1;
};

// Triangulates the pixel grid of an organised view. Needs the camera focal length
// (pixels) to know the footprint of a pixel.
Mesh grid_mesh(const ScanView& view, double camera_focal_px, const GridMeshOptions& options = {});

}  // namespace picoscan
