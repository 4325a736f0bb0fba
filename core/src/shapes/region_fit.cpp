// Least-squares fits of every kind to a picked region, and the choice between them: the simplest
// kind whose residuals are as small as the scan's noise allows (a plane for a flat chamfer, even
// though a cylinder of huge radius fits it a hair better).
#include "picoscan/region_fit.h"

#include "picoscan/error.h"
#include "picoscan/fit.h"
#include "shape_math.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
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

std::vector<int> select_region(const PointCloud& cloud, const cv::Vec3d& seed, const RegionSelection& selection,
                               const ProgressCallback& progress) {
    // Growing over a large radius looks at millions of points: a cancel point every 65 536 of them.
    size_t looked_at = 0;
    const double work = 2.0 * double(cloud.points.size()) + 1;  // the nearest point, the ball, then growing
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
    std::vector<int> ball;
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        look();
        if (inside(cv::Vec3d(cloud.points[i]))) ball.push_back(int(i));
    }
    if (!selection.grow) return ball;

    // Grow over the surface: neighbours within the gap whose normals turn less than the step.
    const double cell = selection.max_gap_mm;
    auto key_of = [&](const cv::Vec3f& p, int dx, int dy, int dz) {
        const int64_t x = int64_t(std::floor(p[0] / cell)) + dx, y = int64_t(std::floor(p[1] / cell)) + dy,
                      z = int64_t(std::floor(p[2] / cell)) + dz;
        return (x * 73856093) ^ (y * 19349663) ^ (z * 83492791);
    };
    std::unordered_map<int64_t, std::vector<int>> grid;
    for (int i : ball) grid[key_of(cloud.points[i], 0, 0, 0)].push_back(i);
    const double min_cosine = std::cos(selection.max_normal_step_deg * kPi / 180);
    std::unordered_map<int, char> reached{{nearest, 1}};
    std::vector<int> region{nearest};
    for (size_t next = 0; next < region.size(); ++next) {
        look();
        const int i = region[next];
        const cv::Vec3f& p = cloud.points[i];
        const cv::Vec3f n = cv::normalize(cloud.normals[i]);
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                    const auto found = grid.find(key_of(p, dx, dy, dz));
                    if (found == grid.end()) continue;
                    for (int j : found->second) {
                        if (reached.count(j) || cv::norm(cloud.points[j] - p) > cell) continue;
                        if (double(n.dot(cv::normalize(cloud.normals[j]))) < min_cosine) continue;
                        reached[j] = 1;
                        region.push_back(j);
                    }
                }
    }
    std::sort(region.begin(), region.end());
    return region;
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

}  // namespace picoscan
