// Primitive shapes found in a scanned cloud: planes, cylinders, spheres and cones detected
// with CGAL's Efficient RANSAC (Schnabel et al. 2007), then refined by least squares on
// their inliers, so a measured part can be rebuilt from real CAD primitives.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

enum class ShapeKind { Plane, Cylinder, Sphere, Cone };

struct ShapeDetectionOptions {
    bool planes = true, cylinders = true, spheres = true, cones = true;
    double epsilon_mm = 0.25;          // a point is an inlier when nearer than this to the shape
    double cluster_epsilon_mm = 2.0;   // inliers farther apart than this form separate shapes
    double normal_threshold_deg = 25;  // an inlier's normal must agree with the shape's within this
    int min_points = 500;              // shapes with fewer inliers are not reported
    double probability = 0.01;         // chance of missing the largest shape (smaller: more search)
    bool refine = true;                // least-squares refinement of every shape on its inliers
    // A cone narrower than this is a cylinder seen with noise: it is reported (and refined) as one.
    double min_cone_half_angle_deg = 2.0;
};

// One detected primitive, in the cloud's frame (mm).
struct DetectedShape {
    ShapeKind kind = ShapeKind::Plane;
    // Plane: a point on it (the inliers' centroid) and the unit normal (oriented like the points' normals).
    // Cylinder: a point on the axis (at the inliers' lowest extent along it) and the unit axis.
    // Sphere: the centre (direction unused). Cone: the apex and the unit axis (opening direction).
    cv::Vec3d point;
    cv::Vec3d direction{0, 0, 1};
    double radius_mm = 0;              // cylinder and sphere
    double half_angle_deg = 0;         // cone
    double length_mm = 0;              // cylinder and cone: extent of the inliers along the axis
    double rms_mm = 0;                 // RMS distance of the inliers to the (refined) shape
    std::vector<int> inliers;          // indices into the cloud
};

// Detects shapes, largest first. The cloud needs normals (a ScanView's point towards the camera).
// Throws Error("cloud", ...) without normals or with fewer points than options.min_points.
std::vector<DetectedShape> detect_shapes(const PointCloud& cloud, const ShapeDetectionOptions& options = {},
                                         const ProgressCallback& progress = nullptr);

// Distance of a point to the surface of a detected shape (signed for spheres, cylinders and
// cones: positive outside; signed by the normal for planes).
double shape_distance(const DetectedShape& shape, const cv::Vec3d& point);

std::string to_string(ShapeKind kind);

}  // namespace picoscan
