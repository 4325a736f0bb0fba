// Primitive detection with CGAL's Efficient RANSAC and least-squares refinement on the inliers.
// CGAL is header-heavy: everything that includes it stays in this one translation unit.
#include "picoscan/shapes.h"

#include "picoscan/error.h"
#include "picoscan/fit.h"
#include "shape_math.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Random.h>
#include <CGAL/Shape_detection/Efficient_RANSAC.h>
#include <CGAL/property_map.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iterator>
#include <limits>
#include <tuple>
#include <utility>

namespace picoscan {

using namespace shape_math;

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
// The cloud index travels with each point: Efficient RANSAC reorders its input range.
using PointWithNormal = std::tuple<Kernel::Point_3, Kernel::Vector_3, int>;
using PointsWithNormals = std::vector<PointWithNormal>;
using Traits = CGAL::Shape_detection::Efficient_RANSAC_traits<Kernel, PointsWithNormals,
                                                               CGAL::Nth_of_tuple_property_map<0, PointWithNormal>,
                                                               CGAL::Nth_of_tuple_property_map<1, PointWithNormal>>;
using EfficientRansac = CGAL::Shape_detection::Efficient_RANSAC<Traits>;
using RansacPlane = CGAL::Shape_detection::Plane<Traits>;
using RansacCylinder = CGAL::Shape_detection::Cylinder<Traits>;
using RansacSphere = CGAL::Shape_detection::Sphere<Traits>;
using RansacCone = CGAL::Shape_detection::Cone<Traits>;

// The caller's progress during CGAL's detection, asked at most every 10 ms: CGAL calls its
// callback at every candidate it draws (tens of thousands a second), the shapes below at every
// octree cell they score. Once the caller says stop, it stays stopped.
class DetectionProgress {
  public:
    explicit DetectionProgress(const ProgressCallback& progress) : progress_(progress) {}
    bool keep_going(double fraction) {
        fraction_ = fraction;
        if (stopped_ || !progress_) return !stopped_;
        const auto now = std::chrono::steady_clock::now();
        if (now - asked_ < std::chrono::milliseconds(10)) return true;
        asked_ = now;
        stopped_ = !progress_(0.9 * fraction, "shapes");
        return !stopped_;
    }
    bool keep_going() { return keep_going(fraction_); }
    bool stopped() const { return stopped_; }

  private:
    const ProgressCallback& progress_;
    std::chrono::steady_clock::time_point asked_;
    double fraction_ = 0;
    bool stopped_ = false;
};

// The detection running on this thread (CGAL makes its shapes with their default constructor).
thread_local DetectionProgress* running_detection = nullptr;

// CGAL's shapes that hear Cancel inside CGAL's scoring, which ranks overlapping candidates on the
// whole cloud for seconds without asking its callback: once stopped, every distance is huge, so
// the scoring ends at the octree's root, and CGAL stops cleanly at its next callback.
template <class CgalShape>
class StoppableShape : public CgalShape {
  public:
    Kernel::FT squared_distance(const Kernel::Point_3& point) const override {
        return running_detection && running_detection->stopped() ? kStopped : CgalShape::squared_distance(point);
    }

  protected:
    void squared_distance(const std::vector<std::size_t>& indices, std::vector<Kernel::FT>& distances) const override {
        if (running_detection && !running_detection->keep_going())
            std::fill(distances.begin(), distances.end(), kStopped);
        else
            CgalShape::squared_distance(indices, distances);
    }

  private:
    static constexpr Kernel::FT kStopped = std::numeric_limits<Kernel::FT>::max();
};


cv::Vec3d to_vec(const Kernel::Point_3& p) { return {p.x(), p.y(), p.z()}; }
cv::Vec3d to_vec(const Kernel::Vector_3& v) { return {v.x(), v.y(), v.z()}; }

std::vector<cv::Vec3d> inlier_points(const PointCloud& cloud, const std::vector<int>& inliers) {
    std::vector<cv::Vec3d> points;
    points.reserve(inliers.size());
    for (int index : inliers) points.emplace_back(cloud.points[index]);
    return points;
}

void refine_plane(DetectedShape& shape, const PointCloud& cloud) {
    std::vector<cv::Vec3f> points;
    for (int index : shape.inliers) points.push_back(cloud.points[index]);
    const PlaneFit fit = fit_plane(points);
    const double sign = fit.normal.dot(shape.direction) < 0 ? -1.0 : 1.0;
    shape.direction = sign * fit.normal;
    shape.point = shape.point + (fit.offset_mm * sign - shape.direction.dot(shape.point)) * shape.direction;
}

// Cylinders and cones: axis extent of the inliers; the cylinder's axis point moves to the lowest one.
void measure_length(DetectedShape& shape, const std::vector<cv::Vec3d>& points) {
    double low = std::numeric_limits<double>::max(), high = std::numeric_limits<double>::lowest();
    for (const cv::Vec3d& point : points) {
        const double along = (point - shape.point).dot(shape.direction);
        low = std::min(low, along);
        high = std::max(high, along);
    }
    shape.length_mm = high - low;
    if (shape.kind == ShapeKind::Cylinder) shape.point += low * shape.direction;
}

}  // namespace

std::string to_string(ShapeKind kind) {
    switch (kind) {
        case ShapeKind::Plane: return "plane";
        case ShapeKind::Cylinder: return "cylinder";
        case ShapeKind::Sphere: return "sphere";
        case ShapeKind::Cone: return "cone";
    }
    return "unknown";
}

double shape_distance(const DetectedShape& shape, const cv::Vec3d& point) {
    switch (shape.kind) {
        case ShapeKind::Plane: return (point - shape.point).dot(shape.direction);
        case ShapeKind::Cylinder: return radial_distance(point, shape.point, shape.direction) - shape.radius_mm;
        case ShapeKind::Sphere: return cv::norm(point - shape.point) - shape.radius_mm;
        case ShapeKind::Cone: return cone_distance(point, shape.point, shape.direction, shape.half_angle_deg * kPi / 180);
    }
    return 0;
}

std::vector<DetectedShape> detect_shapes(const PointCloud& cloud, const ShapeDetectionOptions& options,
                                         const ProgressCallback& progress) {
    if (cloud.normals.size() != cloud.points.size())
        throw Error("cloud", "shape detection needs a normal per point (reconstruct a view to get them)");
    if (options.min_points < 3) throw Error("min_points", "must be at least 3");
    if (cloud.points.size() < size_t(options.min_points))
        throw Error("cloud", std::to_string(cloud.points.size()) + " points, fewer than min_points (" +
                                 std::to_string(options.min_points) + ")");
    if (!(options.epsilon_mm > 0) || !(options.cluster_epsilon_mm > 0))
        throw Error("epsilon_mm", "inlier and cluster distances must be positive");
    if (!options.planes && !options.cylinders && !options.spheres && !options.cones)
        throw Error("shapes", "no shape kind selected");

    PointsWithNormals input;
    input.reserve(cloud.points.size());
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        const cv::Vec3f& p = cloud.points[i];
        const cv::Vec3f& n = cloud.normals[i];
        // Points without a usable normal (edges of a view) cannot vote for a shape.
        if (!std::isfinite(p.dot(p) + n.dot(n)) || n.dot(n) < 0.5f) continue;
        input.emplace_back(Kernel::Point_3(p[0], p[1], p[2]), Kernel::Vector_3(n[0], n[1], n[2]), int(i));
    }

    // The same cloud and options give the same shapes.
    CGAL::get_default_random() = CGAL::Random(1);
    EfficientRansac ransac;
    ransac.set_input(input);
    if (options.planes) ransac.add_shape_factory<StoppableShape<RansacPlane>>();
    if (options.cylinders) ransac.add_shape_factory<StoppableShape<RansacCylinder>>();
    if (options.spheres) ransac.add_shape_factory<StoppableShape<RansacSphere>>();
    if (options.cones) ransac.add_shape_factory<StoppableShape<RansacCone>>();
    // CGAL's octrees (0.3-0.7 s for 460 000 points on an idle machine) cannot be stopped inside.
    if (progress && !progress(0.0, "shapes: octrees")) throw Error("cancelled", "shape detection was stopped");
    ransac.preprocess();
    DetectionProgress detection(progress);

    EfficientRansac::Parameters parameters;
    parameters.probability = options.probability;
    parameters.min_points = std::size_t(options.min_points);
    parameters.epsilon = options.epsilon_mm;
    parameters.cluster_epsilon = options.cluster_epsilon_mm;
    parameters.normal_threshold = std::cos(options.normal_threshold_deg * kPi / 180);
    running_detection = &detection;
    struct Finished {
        ~Finished() { running_detection = nullptr; }
    } finished;
    const std::function<bool(double)> callback = [&detection](double fraction) { return detection.keep_going(fraction); };
    if (!ransac.detect(parameters, callback) || detection.stopped())
        throw Error("cancelled", "shape detection was stopped");

    std::vector<DetectedShape> shapes;
    // Refining a shape of many inliers takes a while: a cancel point at each least-squares iteration.
    const double shape_count = std::max<double>(1, double(std::distance(ransac.shapes().begin(), ransac.shapes().end())));
    StepCheck refine_step;
    if (progress)
        refine_step = [&] {
            if (!progress(0.9 + 0.1 * double(shapes.size()) / shape_count, "shapes"))
                throw Error("cancelled", "shape detection was stopped");
        };
    for (const auto& found : ransac.shapes()) {
        DetectedShape shape;
        for (std::size_t index : found->indices_of_assigned_points()) shape.inliers.push_back(std::get<2>(input[index]));
        if (const auto* plane = dynamic_cast<const RansacPlane*>(found.get())) {
            shape.kind = ShapeKind::Plane;
            shape.direction = cv::normalize(to_vec(plane->plane_normal()));
            // Normals of a scan point towards the camera; orient the plane's normal the same way.
            cv::Vec3d mean_normal(0, 0, 0), centroid(0, 0, 0);
            for (int index : shape.inliers) {
                mean_normal += cv::Vec3d(cloud.normals[index]);
                centroid += cv::Vec3d(cloud.points[index]);
            }
            if (mean_normal.dot(shape.direction) < 0) shape.direction = -shape.direction;
            shape.point = centroid / double(shape.inliers.size());
        } else if (const auto* cylinder = dynamic_cast<const RansacCylinder*>(found.get())) {
            shape.kind = ShapeKind::Cylinder;
            shape.point = to_vec(cylinder->axis().point(0));
            shape.direction = cv::normalize(to_vec(cylinder->axis().to_vector()));
            shape.radius_mm = cylinder->radius();
        } else if (const auto* sphere = dynamic_cast<const RansacSphere*>(found.get())) {
            shape.kind = ShapeKind::Sphere;
            shape.point = to_vec(sphere->center());
            shape.radius_mm = sphere->radius();
        } else if (const auto* cone = dynamic_cast<const RansacCone*>(found.get())) {
            shape.kind = ShapeKind::Cone;
            shape.point = to_vec(cone->apex());
            shape.direction = cv::normalize(to_vec(cone->axis()));
            shape.half_angle_deg = cone->angle() * 180 / kPi;
        } else {
            continue;
        }
        const std::vector<cv::Vec3d> points = inlier_points(cloud, shape.inliers);
        if (shape.kind == ShapeKind::Cone && shape.half_angle_deg < options.min_cone_half_angle_deg) {
            if (!options.cylinders) continue;
            shape.kind = ShapeKind::Cylinder;
            double radius_sum = 0;
            for (const cv::Vec3d& point : points) radius_sum += radial_distance(point, shape.point, shape.direction);
            shape.radius_mm = radius_sum / double(points.size());
        }
        if (options.refine) {
            switch (shape.kind) {
                case ShapeKind::Plane: refine_plane(shape, cloud); break;
                case ShapeKind::Cylinder: refine_cylinder(shape, points, {}, refine_step); break;
                case ShapeKind::Sphere: refine_sphere(shape, points, {}, refine_step); break;
                case ShapeKind::Cone: refine_cone(shape, points, {}, refine_step); break;
            }
        }
        // A cone opens along its axis: point it from the apex towards the inliers.
        if (shape.kind == ShapeKind::Cone) {
            cv::Vec3d mean(0, 0, 0);
            for (const cv::Vec3d& point : points) mean += point;
            if ((mean / double(points.size()) - shape.point).dot(shape.direction) < 0) shape.direction = -shape.direction;
        }
        if (shape.kind == ShapeKind::Cylinder || shape.kind == ShapeKind::Cone) measure_length(shape, points);
        double squares = 0;
        for (const cv::Vec3d& point : points) squares += std::pow(shape_distance(shape, point), 2);
        shape.rms_mm = std::sqrt(squares / double(points.size()));
        // A flat patch fits a cylinder, sphere or cone of huge radius as well as a plane (the demo
        // part's chamfer came out as a 22 m cylinder): when a plane fits within 10 % of its RMS, it is a plane.
        if (shape.kind != ShapeKind::Plane && options.planes) {
            std::vector<cv::Vec3f> inliers(points.begin(), points.end());
            const PlaneFit plane = fit_plane(inliers);
            if (plane.rms_mm <= 1.1 * shape.rms_mm) {
                cv::Vec3d mean_normal(0, 0, 0), centroid(0, 0, 0);
                for (int index : shape.inliers) mean_normal += cv::Vec3d(cloud.normals[index]);
                for (const cv::Vec3d& point : points) centroid += point;
                shape = DetectedShape{ShapeKind::Plane, centroid / double(points.size()),
                                      plane.normal.dot(mean_normal) < 0 ? -plane.normal : plane.normal,
                                      0, 0, 0, plane.rms_mm, std::move(shape.inliers)};
            }
        }
        shapes.push_back(std::move(shape));
    }
    std::sort(shapes.begin(), shapes.end(),
              [](const DetectedShape& a, const DetectedShape& b) { return a.inliers.size() > b.inliers.size(); });
    if (progress) progress(1.0, "shapes");
    return shapes;
}

}  // namespace picoscan
