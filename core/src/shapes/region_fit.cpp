// Least-squares fits of every kind to a picked region, and the choice between them: the simplest
// kind whose residuals are as small as the scan's noise allows (a plane for a flat chamfer, even
// though a cylinder of huge radius fits it a hair better).
#include "picoscan/region_fit.h"

#include "picoscan/error.h"
#include "picoscan/fit.h"
#include "register/point_grid.h"
#include "shape_math.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <sstream>
#include <unordered_map>

namespace picoscan {

using namespace shape_math;

namespace {

double rms_of(const DetectedShape& shape, const std::vector<cv::Vec3d>& points) {
    double squares = 0;
    for (const cv::Vec3d& point : points) squares += std::pow(shape_distance(shape, point), 2);
    return std::sqrt(squares / double(points.size()));
}

cv::Vec3d mean_of(const std::vector<cv::Vec3d>& points) {
    cv::Vec3d sum(0, 0, 0);
    for (const cv::Vec3d& p : points) sum += p;
    return sum / double(points.size());
}

// Smallest principal direction of the given vectors (of their scatter about `centre`).
cv::Vec3d smallest_axis(const std::vector<cv::Vec3d>& vectors, const cv::Vec3d& centre) {
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (const cv::Vec3d& v : vectors) scatter += (v - centre) * (v - centre).t();
    cv::Mat values, axes;
    cv::eigen(cv::Mat(scatter), values, axes);
    return cv::normalize(cv::Vec3d(axes.at<double>(2, 0), axes.at<double>(2, 1), axes.at<double>(2, 2)));
}

// Algebraic circle fit (Kasa) of the points projected on the plane square to `axis`.
void circle_start(DetectedShape& shape, const std::vector<cv::Vec3d>& points, const cv::Vec3d& axis) {
    const auto [u, v] = perpendicular_basis(axis);
    const cv::Vec3d centre = mean_of(points);
    cv::Mat a(int(points.size()), 3, CV_64F), b(int(points.size()), 1, CV_64F);
    for (size_t i = 0; i < points.size(); ++i) {
        const double x = (points[i] - centre).dot(u), y = (points[i] - centre).dot(v);
        a.at<double>(int(i), 0) = x, a.at<double>(int(i), 1) = y, a.at<double>(int(i), 2) = 1;
        b.at<double>(int(i)) = x * x + y * y;
    }
    cv::Mat solution;
    cv::solve(a, b, solution, cv::DECOMP_SVD);
    const double cx = solution.at<double>(0) / 2, cy = solution.at<double>(1) / 2;
    shape.point = centre + cx * u + cy * v;
    shape.direction = axis;
    shape.radius_mm = std::sqrt(std::max(solution.at<double>(2) + cx * cx + cy * cy, 0.0));
}

cv::Vec3d square_to(const cv::Vec3d& direction, const cv::Vec3d& reference) {
    const cv::Vec3d projected = direction - direction.dot(reference) * reference;
    if (cv::norm(projected) < 1e-9) return perpendicular_basis(reference).first;
    return cv::normalize(projected);
}

// Cylinders and cones: the axis point moves to the region's lowest extent along the axis.
void measure_length(DetectedShape& shape, const std::vector<cv::Vec3d>& points) {
    double low = std::numeric_limits<double>::max(), high = std::numeric_limits<double>::lowest();
    for (const cv::Vec3d& point : points) {
        const double along = (point - shape.point).dot(shape.direction);
        low = std::min(low, along), high = std::max(high, along);
    }
    shape.length_mm = high - low;
    if (shape.kind == ShapeKind::Cylinder) shape.point += low * shape.direction;
}

bool takes(ShapeKind kind, FitConstraint constraint) {
    switch (constraint) {
        case FitConstraint::Free: return true;
        case FitConstraint::Parallel: return kind != ShapeKind::Sphere;
        case FitConstraint::Perpendicular: return kind == ShapeKind::Plane || kind == ShapeKind::Cylinder;
        case FitConstraint::Coaxial: return kind != ShapeKind::Plane;
    }
    return false;
}

Freedom freedom_for(const RegionFitOptions& options) {
    Freedom freedom;
    switch (options.constraint) {
        case FitConstraint::Free: break;
        case FitConstraint::Parallel: freedom.direction = false; break;
        case FitConstraint::Perpendicular: freedom.keep_perpendicular_to = options.reference_direction; break;
        case FitConstraint::Coaxial:
            freedom.direction = false;
            freedom.position = false;
            freedom.along_axis_only = true;
            break;
    }
    return freedom;
}

class Fitter {
public:
    // `step` is called at each least-squares iteration (a cancel point: it may throw).
    Fitter(const std::vector<cv::Vec3d>& points, const std::vector<cv::Vec3d>& normals, const RegionFitOptions& options,
           const StepCheck& step)
        : points_(points), normals_(normals), options_(options), reference_(cv::normalize(options.reference_direction)),
          step_(step) {}

    DetectedShape plane() const {
        DetectedShape shape;
        shape.kind = ShapeKind::Plane;
        shape.point = mean_of(points_);
        if (options_.constraint == FitConstraint::Parallel) {
            shape.direction = reference_;
        } else if (options_.constraint == FitConstraint::Perpendicular) {
            // The normal is the smallest spread direction among those square to the reference.
            const auto [u, v] = perpendicular_basis(reference_);
            cv::Matx22d scatter = cv::Matx22d::zeros();
            for (const cv::Vec3d& p : points_) {
                const cv::Vec2d q((p - shape.point).dot(u), (p - shape.point).dot(v));
                scatter += q * q.t();
            }
            cv::Mat values, axes;
            cv::eigen(cv::Mat(scatter), values, axes);
            shape.direction = cv::normalize(axes.at<double>(1, 0) * u + axes.at<double>(1, 1) * v);
        } else {
            shape.direction = smallest_axis(points_, shape.point);
        }
        orient(shape);
        return shape;
    }

    DetectedShape sphere() const {
        DetectedShape shape;
        shape.kind = ShapeKind::Sphere;
        if (options_.constraint == FitConstraint::Coaxial) {
            // Centre on the reference axis, at the region's mean position along it.
            shape.direction = reference_;
            shape.point = options_.reference_point + (mean_of(points_) - options_.reference_point).dot(reference_) * reference_;
            double sum = 0;
            for (const cv::Vec3d& p : points_) sum += cv::norm(p - shape.point);
            shape.radius_mm = sum / double(points_.size());
        } else {
            std::vector<cv::Vec3f> floats(points_.begin(), points_.end());
            const SphereFit fit = fit_sphere(floats);
            shape.point = fit.centre;
            shape.radius_mm = fit.radius_mm;
        }
        refine_sphere(shape, points_, freedom_for(options_), step_);
        return shape;
    }

    DetectedShape cylinder() const {
        DetectedShape shape = cylinder_start();
        refine_cylinder(shape, points_, freedom_for(options_), step_);
        return shape;
    }

    // The axis from the normals (square to all of them, for a cylinder; the axis of their cone,
    // for a cone), the centre and radius from a circle through the points projected along it.
    DetectedShape cylinder_start() const {
        DetectedShape shape;
        shape.kind = ShapeKind::Cylinder;
        circle_start(shape, points_, constrained_axis(normals_.empty() ? largest_axis() : smallest_axis(normals_, cv::Vec3d(0, 0, 0))));
        if (options_.constraint == FitConstraint::Coaxial) {
            shape.point = options_.reference_point;
            double sum = 0;
            for (const cv::Vec3d& p : points_) sum += radial_distance(p, shape.point, shape.direction);
            shape.radius_mm = sum / double(points_.size());
        }
        return shape;
    }

    // A cone's normals keep one component along its axis: the direction in which they do not
    // vary (about their mean) is the axis. The centre comes from a circle fit along it.
    DetectedShape cone_start() const {
        DetectedShape shape;
        cv::Vec3d mean(0, 0, 0);
        for (const cv::Vec3d& n : normals_) mean += n;
        const cv::Vec3d axis = smallest_axis(normals_, mean / double(normals_.size()));
        circle_start(shape, points_, constrained_axis(axis));
        if (options_.constraint == FitConstraint::Coaxial) shape.point = options_.reference_point;  // refined with the axis held
        return shape;
    }

    // Starts from a cylinder's axis (the normals' axis when there are normals: a cylinder refined
    // on a cone's points tilts): the radius's slope along it gives the half angle.
    // Returns false when the cone is narrower than min_cone_half_angle_deg (a cylinder).
    bool cone(const DetectedShape& cylinder, DetectedShape& shape) const {
        const cv::Vec3d axis = cylinder.direction;
        double st = 0, sr = 0, stt = 0, str = 0;
        for (const cv::Vec3d& p : points_) {
            const double t = (p - cylinder.point).dot(axis), r = radial_distance(p, cylinder.point, axis);
            st += t, sr += r, stt += t * t, str += t * r;
        }
        const double n = double(points_.size()), slope = (n * str - st * sr) / (n * stt - st * st);
        const double intercept = (sr - slope * st) / n;
        if (!(std::abs(std::atan(slope)) * 180 / kPi >= options_.min_cone_half_angle_deg / 2)) return false;
        shape.kind = ShapeKind::Cone;
        shape.direction = slope > 0 ? axis : -axis;
        shape.point = cylinder.point - (intercept / slope) * axis;
        shape.half_angle_deg = std::atan(std::abs(slope)) * 180 / kPi;
        refine_cone(shape, points_, freedom_for(options_), step_);
        if ((mean_of(points_) - shape.point).dot(shape.direction) < 0) shape.direction = -shape.direction;
        return shape.half_angle_deg >= options_.min_cone_half_angle_deg;
    }

private:
    cv::Vec3d constrained_axis(const cv::Vec3d& axis) const {
        if (options_.constraint == FitConstraint::Parallel || options_.constraint == FitConstraint::Coaxial) return reference_;
        if (options_.constraint == FitConstraint::Perpendicular) return square_to(axis, reference_);
        return axis;
    }
    cv::Vec3d largest_axis() const {
        cv::Matx33d scatter = cv::Matx33d::zeros();
        const cv::Vec3d centre = mean_of(points_);
        for (const cv::Vec3d& p : points_) scatter += (p - centre) * (p - centre).t();
        cv::Mat values, axes;
        cv::eigen(cv::Mat(scatter), values, axes);
        return cv::normalize(cv::Vec3d(axes.at<double>(0, 0), axes.at<double>(0, 1), axes.at<double>(0, 2)));
    }
    void orient(DetectedShape& plane) const {  // like the points' normals (towards the camera / outwards)
        cv::Vec3d sum(0, 0, 0);
        for (const cv::Vec3d& n : normals_) sum += n;
        if (sum.dot(plane.direction) < 0) plane.direction = -plane.direction;
    }

    const std::vector<cv::Vec3d>& points_;
    const std::vector<cv::Vec3d>& normals_;
    const RegionFitOptions& options_;
    cv::Vec3d reference_;
    const StepCheck& step_;
};

}  // namespace

std::string to_string(FitConstraint constraint) {
    switch (constraint) {
        case FitConstraint::Free: return "free";
        case FitConstraint::Parallel: return "parallel";
        case FitConstraint::Perpendicular: return "perpendicular";
        case FitConstraint::Coaxial: return "coaxial";
    }
    return "unknown";
}

namespace {

// The point nearest the seed and the points in the ball (or box) around it.
struct PickedBall {
    int nearest = -1;
    std::vector<int> ball;
};

PickedBall pick_ball(const PointCloud& cloud, const cv::Vec3d& seed, const RegionSelection& selection,
                     const ProgressCallback& progress) {
    // Growing over a large radius looks at millions of points: a cancel point every 65 536 of them.
    size_t looked_at = 0;
    const double work = 2.0 * double(cloud.points.size()) + 1;  // the nearest point, then the ball
    const auto look = [&] {
        if (progress && ++looked_at % 65536 == 0 && !progress(std::min(1.0, double(looked_at) / work), "selecting the region"))
            throw Error("cancelled", "selecting the region was stopped");
    };
    if (cloud.points.empty()) throw Error("seed", "the cloud has no points to pick");
    if (!(selection.radius_mm > 0)) throw Error("radius_mm", "must be positive");
    if (selection.grow && !(selection.max_gap_mm > 0)) throw Error("max_gap_mm", "must be positive");
    const cv::Vec3d& box = selection.box_half_size_mm;
    if (!(box[0] >= 0 && box[1] >= 0 && box[2] >= 0) || ((box[0] > 0 || box[1] > 0 || box[2] > 0) && !(box[0] > 0 && box[1] > 0 && box[2] > 0)))
        throw Error("box_half_size_mm", "give all three half sizes (positive), or none");
    if (box[0] > 0) {
        const cv::Matx33d product = selection.box_axes * selection.box_axes.t();
        if (cv::norm(product - cv::Matx33d::eye(), cv::NORM_INF) > 1e-6)
            throw Error("box_axes", "the box's axes must be unit and square to each other");
    }
    if (selection.grow && cloud.normals.size() != cloud.points.size())
        throw Error("cloud", "growing a region needs a normal per point");
    int nearest = -1;
    double nearest_distance = std::numeric_limits<double>::max();
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        look();
        const double d = cv::norm(cv::Vec3d(cloud.points[i]) - seed);
        if (d < nearest_distance) nearest_distance = d, nearest = int(i);
    }
    const cv::Vec3d centre(cloud.points[nearest]);
    const cv::Vec3d& half = selection.box_half_size_mm;
    const bool in_box = half[0] > 0 && half[1] > 0 && half[2] > 0;
    const auto inside = [&](const cv::Vec3d& p) {
        if (!in_box) return cv::norm(p - centre) <= selection.radius_mm;
        const cv::Vec3d local = selection.box_axes * (p - centre);
        return std::abs(local[0]) <= half[0] && std::abs(local[1]) <= half[1] && std::abs(local[2]) <= half[2];
    };
    PickedBall picked;
    picked.nearest = nearest;
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        look();
        if (inside(cv::Vec3d(cloud.points[i]))) picked.ball.push_back(int(i));
    }
    return picked;
}

}  // namespace

std::vector<int> select_region(const PointCloud& cloud, const cv::Vec3d& seed, const RegionSelection& selection,
                               const ProgressCallback& progress) {
    if (selection.grow) return grow_face(cloud, seed, selection, RegionFitOptions{}, progress).region;
    return pick_ball(cloud, seed, selection, progress).ball;
}

std::vector<int> select_in_polygon(const PointCloud& cloud, const cv::Matx44d& cloud_to_screen,
                                   const std::vector<cv::Vec2d>& polygon) {
    if (polygon.size() < 3) throw Error("polygon", "a lasso needs at least 3 corners, has " + std::to_string(polygon.size()));
    for (const cv::Vec2d& corner : polygon)
        if (!std::isfinite(corner[0]) || !std::isfinite(corner[1])) throw Error("polygon", "has a non-finite corner");
    std::vector<int> region;
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        if (!is_finite_point(cloud.points[i])) continue;
        const cv::Vec3f& p = cloud.points[i];
        const cv::Vec4d screen = cloud_to_screen * cv::Vec4d(p[0], p[1], p[2], 1);
        if (!(screen[3] > 0)) continue;
        const double x = screen[0] / screen[3], y = screen[1] / screen[3];
        // Even-odd rule: count the polygon's edges crossing the ray to the right of (x, y).
        bool in = false;
        for (size_t a = 0, b = polygon.size() - 1; a < polygon.size(); b = a++) {
            const cv::Vec2d &pa = polygon[a], &pb = polygon[b];
            if ((pa[1] > y) != (pb[1] > y) && x < pa[0] + (y - pa[1]) * (pb[0] - pa[0]) / (pb[1] - pa[1])) in = !in;
        }
        if (in) region.push_back(int(i));
    }
    return region;
}

RegionFit fit_region(const PointCloud& cloud, const std::vector<int>& region, const RegionFitOptions& options,
                     const ProgressCallback& progress) {
    int stage = 0;
    std::string fitting;
    const auto report_stage = [&](const char* kind) {
        fitting = std::string("fitting ") + kind;
        if (progress && !progress(stage++ / 5.0, fitting)) throw Error("cancelled", "region fit cancelled");
    };
    // Within a kind too: each least-squares iteration of a large region takes a while.
    StepCheck step;
    if (progress)
        step = [&] {
            if (!progress((stage - 0.5) / 5.0, fitting)) throw Error("cancelled", "region fit cancelled");
        };
    if (region.size() < 10) throw Error("region", std::to_string(region.size()) + " points picked, at least 10 are needed");
    if (options.constraint != FitConstraint::Free && !(cv::norm(options.reference_direction) > 0))
        throw Error("reference_direction", "a constraint needs the reference feature's direction");
    if (!(options.noise_mm >= 0) || !(options.accept_factor > 0) || !(options.margin >= 0))
        throw Error("noise_mm", "noise, accept factor and margin must not be negative");
    std::vector<cv::Vec3d> points, normals;
    const bool with_normals = cloud.normals.size() == cloud.points.size();
    for (int index : region) {
        if (index < 0 || index >= int(cloud.points.size()))
            throw Error("region", "point index " + std::to_string(index) + " is out of range");
        if (!is_finite_point(cloud.points[index])) continue;
        points.emplace_back(cloud.points[index]);
        if (with_normals) normals.emplace_back(cloud.normals[index]);
    }
    if (points.size() < 10) throw Error("region", "fewer than 10 measured points picked");

    const Fitter fitter(points, normals, options, step);
    auto allowed = [&](ShapeKind kind, bool enabled) {
        return (options.automatic ? enabled : options.kind == kind) && takes(kind, options.constraint);
    };
    if (!options.automatic && !takes(options.kind, options.constraint))
        throw Error("constraint", "a " + to_string(options.kind) + " cannot be " + to_string(options.constraint) +
                                      " to the reference");
    // Candidates in order of simplicity (parameter count).
    std::vector<DetectedShape> candidates;
    RegionFit result;
    report_stage("a plane");
    if (allowed(ShapeKind::Plane, options.planes)) {
        candidates.push_back(fitter.plane());
        result.plane_rms_mm = rms_of(candidates.back(), points);
    }
    report_stage("a sphere");
    if (allowed(ShapeKind::Sphere, options.spheres)) {
        try {
            candidates.push_back(fitter.sphere());
            result.sphere_rms_mm = rms_of(candidates.back(), points);
        } catch (const Error& error) {  // a flat region: no sphere through it
            if (error.subject() == "cancelled") throw;
        }
    }
    DetectedShape cylinder;
    const bool need_cylinder = allowed(ShapeKind::Cylinder, options.cylinders) || allowed(ShapeKind::Cone, options.cones);
    report_stage("a cylinder");
    if (need_cylinder) cylinder = fitter.cylinder();
    if (allowed(ShapeKind::Cylinder, options.cylinders)) {
        candidates.push_back(cylinder);
        result.cylinder_rms_mm = rms_of(cylinder, points);
    }
    report_stage("a cone");
    if (allowed(ShapeKind::Cone, options.cones)) {
        DetectedShape cone;
        if (fitter.cone(normals.empty() ? cylinder : fitter.cone_start(), cone)) {
            candidates.push_back(cone);
            result.cone_rms_mm = rms_of(cone, points);
        }
    }
    if (candidates.empty())
        throw Error("constraint", "no enabled shape kind can be " + to_string(options.constraint) + " to the reference");
    std::vector<double> rms;
    for (const DetectedShape& candidate : candidates) rms.push_back(rms_of(candidate, points));
    const double best = *std::min_element(rms.begin(), rms.end());
    result.noise_mm = options.noise_mm > 0 ? options.noise_mm : best;
    std::ostringstream report;
    report << "RMS:";
    for (size_t i = 0; i < candidates.size(); ++i) report << " " << to_string(candidates[i].kind) << " " << rms[i] << " mm";
    if (options.noise_mm > 0 && best > options.reject_factor * options.noise_mm) {
        throw Error("region", "no " + std::string(options.automatic ? "plane, sphere, cylinder or cone" : to_string(options.kind)) +
                                  " fits the picked points within " + std::to_string(options.reject_factor) +
                                  " x the noise (" + report.str() + "): pick one surface only");
    }
    const double threshold = std::max(options.accept_factor * result.noise_mm, (1 + options.margin) * best);
    size_t chosen = 0;
    while (rms[chosen] > threshold) ++chosen;
    result.shape = candidates[chosen];
    report << "; " << to_string(result.shape.kind) << " is the simplest within " << threshold << " mm";

    if (options.snap_step_mm > 0 && (result.shape.kind == ShapeKind::Cylinder || result.shape.kind == ShapeKind::Sphere)) {
        const double diameter = 2 * result.shape.radius_mm;
        const double nominal = std::round(diameter / options.snap_step_mm) * options.snap_step_mm;
        result.fitted_radius_mm = result.shape.radius_mm;
        if (nominal > 0 && std::abs(diameter - nominal) <= options.snap_tolerance_mm) {
            DetectedShape snapped = result.shape;
            snapped.radius_mm = nominal / 2;
            Freedom freedom = freedom_for(options);
            freedom.size = false;
            report_stage("the snapped size");
            if (snapped.kind == ShapeKind::Cylinder) refine_cylinder(snapped, points, freedom, step);
            else refine_sphere(snapped, points, freedom, step);
            const double snapped_rms = rms_of(snapped, points);
            if (snapped_rms <= threshold) {
                result.shape = snapped;
                result.snapped = true;
                report << "; diameter " << diameter << " snapped to " << nominal << " mm (RMS " << snapped_rms << " mm)";
            } else {
                report << "; diameter " << diameter << " not snapped to " << nominal << " mm: RMS " << snapped_rms
                       << " mm would exceed " << threshold << " mm";
            }
        } else {
            report << "; diameter " << diameter << " mm is not within " << options.snap_tolerance_mm << " mm of a multiple of "
                   << options.snap_step_mm << " mm: not snapped";
        }
    }
    if (result.shape.kind == ShapeKind::Cylinder || result.shape.kind == ShapeKind::Cone) measure_length(result.shape, points);
    result.shape.rms_mm = rms_of(result.shape, points);
    result.shape.inliers = region;
    result.report = report.str();
    return result;
}


namespace {

// RMS of a quadric height field (z = ax^2 + bxy + cy^2 + dx + ey + f over the points' own plane)
// fitted to a small neighbourhood, corrected for the six fitted parameters: the noise alone,
// whatever the curvature. Negative when the neighbourhood is too small.
double quadric_rms(const std::vector<cv::Vec3d>& points) {
    const int n = int(points.size());
    if (n < 12) return -1;
    const cv::Vec3d centre = mean_of(points);
    const cv::Vec3d normal = smallest_axis(points, centre);
    const auto [u, v] = perpendicular_basis(normal);
    cv::Mat a(n, 6, CV_64F), b(n, 1, CV_64F);
    for (int i = 0; i < n; ++i) {
        const cv::Vec3d d = points[size_t(i)] - centre;
        const double x = d.dot(u), y = d.dot(v);
        const double row[6] = {x * x, x * y, y * y, x, y, 1};
        for (int k = 0; k < 6; ++k) a.at<double>(i, k) = row[k];
        b.at<double>(i) = d.dot(normal);
    }
    cv::Mat solution;
    cv::solve(a, b, solution, cv::DECOMP_SVD);
    const double squares = cv::norm(a * solution - b, cv::NORM_L2SQR);
    return std::sqrt(squares / double(n - 6));
}

double median_noise(const std::vector<cv::Vec3d>& points, const detail::PointGrid& grid) {
    const size_t samples = std::min<size_t>(200, points.size());
    const size_t stride = std::max<size_t>(1, points.size() / samples);
    std::vector<int> found;
    std::vector<cv::Vec3d> near;
    // The neighbourhood: the smallest radius (from 0.25 mm, doubling) whose median holds 24 points.
    double radius = 0.25;
    for (; radius < 4; radius *= 2) {
        std::vector<size_t> counts;
        for (size_t i = 0; i < points.size() && counts.size() < 25; i += stride) {
            grid.within(points[i], radius, found);
            counts.push_back(found.size());
        }
        std::nth_element(counts.begin(), counts.begin() + long(counts.size() / 2), counts.end());
        if (counts[counts.size() / 2] >= 24) break;
    }
    std::vector<double> rms;
    for (size_t i = 0; i < points.size() && rms.size() < samples; i += stride) {
        grid.within(points[i], radius, found);
        near.clear();
        for (int j : found) near.push_back(points[size_t(j)]);
        const double value = quadric_rms(near);
        if (value >= 0) rms.push_back(value);
    }
    if (rms.size() < 5) throw Error("cloud", "too few neighbourhoods of 24 points within 4 mm to estimate the scan's noise");
    std::nth_element(rms.begin(), rms.begin() + long(rms.size() / 2), rms.end());
    return rms[rms.size() / 2];
}

// Unit normal of a shape's surface next to a point (its sign does not matter here).
cv::Vec3d surface_normal(const DetectedShape& shape, const cv::Vec3d& point) {
    if (shape.kind == ShapeKind::Plane) return shape.direction;
    const cv::Vec3d from = point - shape.point;
    if (shape.kind == ShapeKind::Sphere) return cv::norm(from) > 0 ? cv::normalize(from) : shape.direction;
    cv::Vec3d radial = from - from.dot(shape.direction) * shape.direction;
    radial = cv::norm(radial) > 0 ? cv::normalize(radial) : perpendicular_basis(shape.direction).first;
    if (shape.kind == ShapeKind::Cylinder) return radial;
    const double half_angle = shape.half_angle_deg * kPi / 180;
    return std::cos(half_angle) * radial - std::sin(half_angle) * shape.direction;
}

// How far a curved shape's surface bends over the points: the sagitta of the widest angle the
// points span about its axis (cylinder) or centre (sphere).
double bend_over(const DetectedShape& shape, const std::vector<cv::Vec3d>& points) {
    std::vector<cv::Vec3d> radial;
    cv::Vec3d mean(0, 0, 0);
    for (const cv::Vec3d& p : points) {
        cv::Vec3d r = p - shape.point;
        if (shape.kind == ShapeKind::Cylinder) r -= r.dot(shape.direction) * shape.direction;
        if (cv::norm(r) == 0) continue;
        radial.push_back(cv::normalize(r));
        mean += radial.back();
    }
    if (radial.empty() || cv::norm(mean) == 0) return shape.radius_mm;
    mean = cv::normalize(mean);
    double lowest = 1;
    for (const cv::Vec3d& r : radial) lowest = std::min(lowest, r.dot(mean));
    return shape.radius_mm * (1 - std::max(lowest, 0.0));
}

const ShapeKind kKindsSimplestFirst[] = {ShapeKind::Plane, ShapeKind::Sphere, ShapeKind::Cylinder, ShapeKind::Cone};

// One kind's fit with the constraint-free options (regions are grown free; constraints hold in
// the final fit). False when the kind does not fit at all (a sphere through a flat patch).
bool fit_kind(ShapeKind kind, const std::vector<cv::Vec3d>& points, const std::vector<cv::Vec3d>& normals,
              const RegionFitOptions& free, const StepCheck& step, DetectedShape& shape) {
    const Fitter fitter(points, normals, free, step);
    try {
        switch (kind) {
            case ShapeKind::Plane: shape = fitter.plane(); return true;
            case ShapeKind::Sphere: shape = fitter.sphere(); break;
            case ShapeKind::Cylinder: shape = fitter.cylinder(); break;
            case ShapeKind::Cone: {
                const DetectedShape cylinder = normals.empty() ? fitter.cylinder() : fitter.cone_start();
                if (!fitter.cone(cylinder, shape)) return false;
                break;
            }
        }
    } catch (const Error& error) {
        if (error.subject() == "cancelled") throw;
        return false;
    }
    return std::isfinite(shape.radius_mm) && std::isfinite(shape.point[0]) && std::isfinite(shape.direction[0]);
}

}  // namespace

double estimate_noise(const PointCloud& cloud, const cv::Vec3d& centre, double radius_mm) {
    if (!(radius_mm > 0)) throw Error("radius_mm", "must be positive");
    std::vector<cv::Vec3d> points;
    for (const cv::Vec3f& p : cloud.points)
        if (is_finite_point(p) && cv::norm(cv::Vec3d(p) - centre) <= radius_mm) points.emplace_back(p);
    if (points.size() < 24) throw Error("cloud", std::to_string(points.size()) + " points within " + std::to_string(radius_mm) +
                                                     " mm: too few to estimate the scan's noise");
    return median_noise(points, detail::PointGrid(points, 1.0));
}

double estimate_scan_noise(const PointCloud& cloud) {
    std::vector<cv::Vec3d> points;
    points.reserve(cloud.points.size());
    for (const cv::Vec3f& p : cloud.points)
        if (is_finite_point(p)) points.emplace_back(p);
    if (points.size() < 24) throw Error("cloud", std::to_string(points.size()) + " points: too few to estimate the scan's noise");
    return median_noise(points, detail::PointGrid(points, 1.0));
}

GrownFace grow_face(const PointCloud& cloud, const cv::Vec3d& seed, const RegionSelection& selection,
                    const RegionFitOptions& fit, const ProgressCallback& progress) {
    if (!(selection.max_gap_mm > 0)) throw Error("max_gap_mm", "must be positive");
    if (!(selection.seed_radius_mm > 0)) throw Error("seed_radius_mm", "must be positive");
    if (!(selection.max_normal_step_deg > 0 && selection.max_normal_step_deg < 180))
        throw Error("max_normal_step_deg", "must be in (0, 180) degrees");
    if (!(fit.reject_factor > 0)) throw Error("reject_factor", "must be positive");
    if (!cloud.points.empty() && cloud.normals.size() != cloud.points.size())
        throw Error("cloud", "growing a region needs a normal per point");
    const PickedBall picked = pick_ball(cloud, seed, selection, progress ? ProgressCallback([&](double done, const std::string& stage) {
        return progress(0.3 * done, stage);
    }) : ProgressCallback());
    const auto stage = [&](double done, const std::string& name) {
        if (progress && !progress(0.3 + 0.7 * done, name)) throw Error("cancelled", "growing the face was stopped");
    };
    const StepCheck step = progress ? StepCheck([&] { stage(0.3, "growing the face"); }) : StepCheck();

    // The ball's points, the picked one first.
    std::vector<cv::Vec3d> points, normals;
    std::vector<int> index;  // into the cloud
    for (int i : picked.ball) {
        if (!is_finite_point(cloud.points[size_t(i)])) continue;
        if (i == picked.nearest) index.insert(index.begin(), i);
        else index.push_back(i);
    }
    if (index.empty() || index.front() != picked.nearest) throw Error("seed", "no measured point near the picked point");
    for (int i : index) {
        points.emplace_back(cloud.points[size_t(i)]);
        normals.push_back(cv::normalize(cv::Vec3d(cloud.normals[size_t(i)])));
    }
    std::ostringstream where;
    where << std::setprecision(4) << "(" << points[0][0] << ", " << points[0][1] << ", " << points[0][2] << ")";
    if (points.size() < 24)
        throw Error("region", std::to_string(points.size()) + " points within " + std::to_string(selection.radius_mm) +
                                  " mm of the picked point " + where.str() + ": too few to fit");
    // The flood's cube keys hold 2^20 cubes each way from the origin (below): a point beyond
    // them would share its cube with others, and its cube number would not fit an int.
    double farthest = 0;
    for (const cv::Vec3d& p : points) farthest = std::max(farthest, cv::norm(p, cv::NORM_INF));
    if (!(farthest / selection.max_gap_mm < double(1 << 20))) {
        std::ostringstream message;
        message << "of " << selection.max_gap_mm << " mm is too fine for points " << farthest
                << " mm from the origin: the growing reaches 2^20 gaps from it";
        throw Error("max_gap_mm", message.str());
    }
    const detail::PointGrid grid(points, selection.max_gap_mm);
    GrownFace face;
    face.noise_mm = fit.noise_mm > 0 ? fit.noise_mm : median_noise(points, grid);
    const double tolerance = fit.reject_factor * face.noise_mm;  // a ball's fit, a face's bend
    // A point of the face lies farther than 4 sigma from it only once in 16 000.
    const double on_face = std::max(tolerance, 4 * face.noise_mm);
    const double min_cosine = std::cos(selection.max_normal_step_deg * kPi / 180);

    std::vector<ShapeKind> kinds;
    const bool enabled[] = {fit.planes, fit.spheres, fit.cylinders, fit.cones};
    for (int k = 0; k < 4; ++k) {
        const ShapeKind kind = kKindsSimplestFirst[k];
        if ((fit.automatic ? enabled[k] : fit.kind == kind) && takes(kind, fit.constraint)) kinds.push_back(kind);
    }
    if (kinds.empty()) throw Error("constraint", "no enabled shape kind can be " + to_string(fit.constraint) + " to the reference");
    RegionFitOptions free = fit;
    free.constraint = FitConstraint::Free;

    // Fits of up to 1500 of the given points (every n-th: the growing fits only need the shape).
    const auto fit_points = [&](ShapeKind kind, const std::vector<int>& members, DetectedShape& shape) {
        const size_t stride = std::max<size_t>(1, members.size() / 1500);
        std::vector<cv::Vec3d> p, n;
        for (size_t k = 0; k < members.size(); k += stride) {
            p.push_back(points[size_t(members[k])]);
            n.push_back(normals[size_t(members[k])]);
        }
        if (!fit_kind(kind, p, n, free, step, shape)) return -1.0;
        return rms_of(shape, p);
    };

    // The seed: the largest ball at the point (halving) that one kind fits within the tolerance.
    std::vector<int> found;
    std::vector<DetectedShape> starts(kinds.size());
    std::vector<bool> started(kinds.size(), false);
    std::vector<int> seed_ball;
    double seed_radius = selection.seed_radius_mm;
    std::ostringstream tried;
    for (;; seed_radius /= 2) {
        grid.within(points[0], seed_radius, found);
        if (found.size() < 12) {
            std::ostringstream message;
            message << "no " << (fit.automatic ? "plane, sphere, cylinder or cone" : to_string(fit.kind)) << " fits the points around "
                    << where.str() << " within " << fit.reject_factor << " x the noise (" << face.noise_mm << " mm)" << tried.str()
                    << ": the point is on an edge, a corner or a patch too small to fit; pick inside one face";
            throw Error("seed", message.str());
        }
        double best = std::numeric_limits<double>::max();
        for (size_t k = 0; k < kinds.size(); ++k) {
            const double rms = fit_points(kinds[k], found, starts[k]);
            started[k] = rms >= 0;
            if (started[k]) best = std::min(best, rms);
        }
        if (best <= tolerance) {
            seed_ball = found;
            break;
        }
        tried << (tried.tellp() == 0 ? "; best RMS " : ", ") << best << " mm over the " << found.size() << " points within "
              << seed_radius << " mm";
    }
    face.seed_radius_mm = seed_radius;
    stage(0.1, "growing the face");

    // Each kind grown from its start: flood over the points near its surface, refit, again.
    // The face floods from cube to neighbouring cube (of max_gap_mm, the 26 around), taking each
    // cube's points that lie on the shape: every point is looked at once per flood.
    std::unordered_map<uint64_t, int> cube_at;
    std::vector<std::vector<int>> cube_points;
    std::vector<cv::Vec3i> cube_cell;
    std::vector<int> cube_of(points.size());
    // 21 bits an axis: one key per cube within 2^20 cubes of the origin (a scanner's whole
    // reach). A hashed key merged cubes: (-1, -1, z) and (1, 1, z), on the camera's axis, collided.
    const auto cube_key = [](const cv::Vec3i& c) {
        const auto bits = [](int v) { return uint64_t(uint32_t(v) & 0x1FFFFFu); };
        return (bits(c[0]) << 42) | (bits(c[1]) << 21) | bits(c[2]);
    };
    for (size_t j = 0; j < points.size(); ++j) {
        const cv::Vec3i cell(int(std::floor(points[j][0] / selection.max_gap_mm)), int(std::floor(points[j][1] / selection.max_gap_mm)),
                             int(std::floor(points[j][2] / selection.max_gap_mm)));
        const auto [at, added] = cube_at.emplace(cube_key(cell), int(cube_points.size()));
        if (added) cube_points.emplace_back(), cube_cell.push_back(cell);
        cube_points[size_t(at->second)].push_back(int(j));
        cube_of[j] = at->second;
    }
    std::vector<char> member(points.size()), cube_queued(cube_points.size());
    const auto flood = [&](const DetectedShape& shape) {
        std::fill(member.begin(), member.end(), 0);
        std::fill(cube_queued.begin(), cube_queued.end(), 0);
        const auto fits = [&](size_t j) {
            return std::abs(shape_distance(shape, points[j])) <= on_face &&
                   std::abs(normals[j].dot(surface_normal(shape, points[j]))) >= min_cosine;
        };
        // From the cubes of the seed ball's points on the shape (the picked point may be an outlier).
        std::vector<int> queue, region;
        for (int j : seed_ball)
            if (!cube_queued[size_t(cube_of[size_t(j)])] && fits(size_t(j))) {
                cube_queued[size_t(cube_of[size_t(j)])] = 1;
                queue.push_back(cube_of[size_t(j)]);
            }
        for (size_t next = 0; next < queue.size(); ++next) {
            const int cube = queue[next];
            bool any = false;
            for (int j : cube_points[size_t(cube)])
                if (fits(size_t(j))) region.push_back(j), any = true;
            if (!any) continue;
            for (int dx = -1; dx <= 1; ++dx)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dz = -1; dz <= 1; ++dz) {
                        const auto found_cube = cube_at.find(cube_key(cube_cell[size_t(cube)] + cv::Vec3i(dx, dy, dz)));
                        if (found_cube == cube_at.end() || cube_queued[size_t(found_cube->second)]) continue;
                        cube_queued[size_t(found_cube->second)] = 1;
                        queue.push_back(found_cube->second);
                    }
        }
        std::sort(region.begin(), region.end());
        return region;
    };
    std::vector<std::vector<int>> grown(kinds.size());
    std::vector<DetectedShape> shapes(kinds.size());
    // Grows kind k from `shape` (flood, refit, flood again until it settles); kept when larger.
    std::vector<double> face_rms(kinds.size(), -1);
    const auto grow = [&](size_t k, DetectedShape shape) {
        size_t last = 0;
        for (int round = 0; round < 8; ++round) {
            const std::vector<int> region = flood(shape);
            const size_t size = region.size();
            if (size < 12) break;
            const double rms = fit_points(kinds[k], region, shape);
            if (size > grown[k].size()) grown[k] = region, shapes[k] = shape, face_rms[k] = rms;
            // Settled: the face changed by less than 1 %.
            if (rms < 0 || (size >= last && size - last <= size / 100) || (size < last && last - size <= size / 100)) break;
            last = size;
        }
    };
    for (size_t k = 0; k < kinds.size(); ++k) {
        stage(0.1 + 0.4 * double(k) / double(kinds.size()), "growing a " + to_string(kinds[k]));
        if (started[k]) grow(k, starts[k]);
    }
    // A start on a tiny ball may miss a kind's size (a cylinder from 0.5 mm of the boss's side, by
    // its edge): each kind starts again from its fit on the largest face found so far.
    for (int pass = 0; pass < 3; ++pass) {
        size_t leader = 0;
        for (size_t k = 0; k < kinds.size(); ++k)
            if (grown[k].size() > grown[leader].size()) leader = k;
        const size_t before = grown[leader].size();
        const std::vector<int> largest_face = grown[leader];
        for (size_t k = 0; k < kinds.size(); ++k) {
            stage(0.5 + 0.4 * (pass + double(k) / double(kinds.size())) / 3, "growing a " + to_string(kinds[k]));
            // Only a kind that fits the largest face may grow larger than it.
            DetectedShape shape;
            const double rms = k == leader ? -1 : fit_points(kinds[k], largest_face, shape);
            if (rms >= 0 && rms <= tolerance) grow(k, shape);
        }
        size_t after = 0;
        for (const std::vector<int>& region : grown) after = std::max(after, region.size());
        if (after == before) break;
    }
    // A face of the kind fits it to the noise; one that only bends through several faces within
    // the band (a cylinder round a narrow chamfer and its neighbours) does not.
    std::vector<bool> fits_face(kinds.size());
    bool any_fits = false;
    for (size_t k = 0; k < kinds.size(); ++k)
        any_fits |= fits_face[k] = face_rms[k] >= 0 && face_rms[k] <= fit.accept_factor * face.noise_mm;
    size_t largest = 0;
    for (size_t k = 0; k < kinds.size(); ++k)
        if (fits_face[k] || !any_fits) largest = std::max(largest, grown[k].size());
    size_t chosen = 0;
    while (chosen + 1 < kinds.size() && (grown[chosen].size() < 0.9 * double(largest) || (any_fits && !fits_face[chosen]))) ++chosen;
    face.kind = kinds[chosen];
    std::ostringstream report;
    report << std::setprecision(4) << "noise " << face.noise_mm << " mm (" << (fit.noise_mm > 0 ? "given" : "estimated")
           << "), seed ball " << seed_radius << " mm; grown:";
    for (size_t k = 0; k < kinds.size(); ++k) {
        report << " " << to_string(kinds[k]) << " " << grown[k].size();
        if (face_rms[k] >= 0) report << " (RMS " << face_rms[k] << ")";
    }
    report << " points; " << to_string(face.kind)
           << (kinds.size() > 1 ? " is the simplest holding 90 % of the largest face fitted within " : " fitted within ")
           << fit.accept_factor << " x the noise";
    face.report = report.str();

    const std::vector<int>& region = grown[chosen];
    if (region.size() < 30)
        throw Error("region", "the face grown from the picked point " + where.str() + " has " + std::to_string(region.size()) +
                                  " points, too few to tell its kind and size (at least 30; " + face.report +
                                  "): pick a larger face, or fit a ball or lasso");
    // The picked point is on the face, not on an edge beside it: most points near it lie on the
    // face's shape (by distance: a scanner's normals there are blended over the edge).
    grid.within(points[0], selection.seed_radius_mm / 2, found);
    size_t near_on_face = 0;
    for (int j : found) near_on_face += std::abs(shape_distance(shapes[chosen], points[size_t(j)])) <= on_face;
    if (3 * near_on_face < 2 * found.size()) {
        std::ostringstream message;
        message << std::setprecision(3) << "the picked point " << where.str() << " is on an edge: the " << to_string(face.kind)
                << " grown from it passes through only " << 100.0 * double(near_on_face) / double(found.size()) << " % of the "
                << found.size() << " points within " << selection.seed_radius_mm / 2 << " mm of it (" << face.report
                << "); pick inside one face";
        throw Error("seed", message.str());
    }
    std::vector<cv::Vec3d> face_points;
    for (int j : region) face_points.push_back(points[size_t(j)]);
    const DetectedShape& shape = shapes[chosen];
    if (shape.kind == ShapeKind::Cylinder || shape.kind == ShapeKind::Sphere) {
        const double bend = bend_over(shape, face_points);
        if (bend < tolerance) {
            std::ostringstream message;
            message << "the face grown from the picked point " << where.str() << " bends by only " << bend << " mm across its "
                    << region.size() << " points, within " << fit.reject_factor << " x the noise: a " << to_string(shape.kind)
                    << "'s radius is not determined by them (" << face.report << "); fit a plane, or pick a wider region";
            throw Error("region", message.str());
        }
        // A sphere and a cylinder through the same small patch: nothing tells them apart.
        for (size_t k = 0; k < kinds.size(); ++k)
            if (k != chosen && kinds[k] != ShapeKind::Cone && kinds[k] != ShapeKind::Plane &&
                grown[k].size() >= 0.9 * double(largest)) {
                throw Error("region", "a " + to_string(face.kind) + " and a " + to_string(kinds[k]) +
                                          " both fit the face grown from the picked point " + where.str() + " (" + face.report +
                                          "): it is too small to tell them apart; choose the kind, or pick a wider region");
            }
    }
    stage(1.0, "face grown");
    for (int j : region) face.region.push_back(index[size_t(j)]);
    std::sort(face.region.begin(), face.region.end());
    return face;
}

}  // namespace picoscan
