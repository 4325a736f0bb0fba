// Regions of facets between two planar faces that lie on a cylinder square to both (a drilled
// hole, a boss, a shaft) become cylindrical B-rep faces bounded by circles.
#include "solid/cylinder_faces.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <string>

namespace picoscan::detail {

namespace {

constexpr double kPi = 3.14159265358979323846;

// A circle seen along an axis, or a cone's (slope != 0): its radius at height h along the axis
// (from the plane it was seen from) is radius + slope x h.
struct Circle2 {
    cv::Vec2d center;
    double radius = 0, rms = 0;
    cv::Vec3d origin = cv::Vec3d(0, 0, 0);  // circle_along: the centre in 3-D, in the plane it was seen from
    double slope = 0, mean_height = 0;     // a cone: its radius' growth per mm along the axis; the points' mean height
    double radius_at(double height) const { return radius + slope * height; }
    double mean_radius() const { return radius_at(mean_height); }
    double half_angle_deg() const { return std::atan(std::abs(slope)) * 180 / kPi; }
    // The RMS distance from the surface (the fit's radial residuals, square to a cone's slant line).
    double surface_rms() const { return rms / std::sqrt(1 + slope * slope); }
};

// A cylinder is taken as round when its vertices' RMS distance from it is at most max_rms_factor
// x the noise, or this share of its radius when that is more: a smooth (Poisson) mesh's planes
// are flat to a micrometre and its noise estimate says nothing of how round its walls are.
constexpr double kRoundness = 0.002;
constexpr double kSquareToAxis = 0.26;  // sin(15 degrees)
constexpr double kSameAxis = 0.996;     // cos(5 degrees)
// The facets where a wall meets its ends (rounded by a smooth mesh) may change the volume by at
// most this share of the mesh's when the cylinder and the planes are continued over them.
constexpr double kRingVolumeShare = 1e-4;
// Cones made, by half-angle: narrower is a cylinder with noise (as shapes.h's min_cone_half_angle_deg);
// wider than the steep walls reach (normals within 25 degrees of the axis are the planes').
constexpr double kMinConeDeg = 2, kMaxConeDeg = 64;
// At most this share of a wall's area may have its normals elsewhere round the axis than a
// cylinder's (bunched_normals: a scanned cylinder's up to about 0.1, a prism's of 12 to 24 sides
// 0.2 to 0.8 once each side spans a few facets).
constexpr double kMaxBunchedNormals = 0.2;
// A chamfer ring's cone: the facets whose normals tilt from square to the axis within this of the
// median tilt of those tilted more than 15 degrees (the rest, a smooth mesh's rounded crease, are
// continued over as a cylinder's rounded ends are).
constexpr double kRingSpreadDeg = 10;
// At most this share of the variance of a cylinder's vertices' distances from its axis may follow
// the pattern of a prism's flat sides when that pattern follows them better than a wave of as many
// lobes by this chi-square (polygon_pattern: scanned cylinders' share up to about 0.05, a noise-free
// one's 0.1 with its sides no deeper than the noise, their chi-square -31 to 4; a 32-sided prism of
// radius 6 mm, its sides 0.029 mm deep, 0.74 at 5 um of noise, 0.4 at 10, 0.24 at 15, 0.15 at 20,
// chi-square 31 to 374 from 5 to 15 um; a round wall lobed 3 to 8 times, 5 to 10 um deep, -100 to -660).
constexpr double kMaxPolygonShare = 0.15, kMinCreases = 25;

// Least-squares circle through 2-D points: the algebraic fit (Kasa) as the start, then Gauss-Newton
// on the points' distances from the circle.
Circle2 fit_circle(const std::vector<cv::Vec2d>& points) {
    cv::Matx33d normal = cv::Matx33d::zeros();
    cv::Vec3d right(0, 0, 0);
    for (const cv::Vec2d& p : points) {
        const cv::Vec3d row(2 * p[0], 2 * p[1], 1);
        normal += row * row.t();
        right += row * p.dot(p);
    }
    cv::Vec3d solution;
    if (!cv::solve(normal, right, solution, cv::DECOMP_SVD)) return {};
    Circle2 circle;
    circle.center = {solution[0], solution[1]};
    circle.radius = std::sqrt(std::max(0.0, solution[2] + solution[0] * solution[0] + solution[1] * solution[1]));
    for (int iteration = 0; iteration < 20; ++iteration) {
        cv::Matx33d jtj = cv::Matx33d::zeros();
        cv::Vec3d jtr(0, 0, 0);
        for (const cv::Vec2d& p : points) {
            const cv::Vec2d offset = p - circle.center;
            const double distance = cv::norm(offset);
            if (distance == 0) continue;
            const cv::Vec3d gradient(-offset[0] / distance, -offset[1] / distance, -1);
            jtj += gradient * gradient.t();
            jtr += gradient * (distance - circle.radius);
        }
        cv::Vec3d step;
        if (!cv::solve(jtj, -jtr, step, cv::DECOMP_CHOLESKY)) break;
        circle.center += cv::Vec2d(step[0], step[1]);
        circle.radius += step[2];
        if (cv::norm(step) < 1e-12 * (1 + circle.radius)) break;
    }
    double sum = 0;
    for (const cv::Vec2d& p : points) sum += std::pow(cv::norm(p - circle.center) - circle.radius, 2);
    circle.rms = std::sqrt(sum / double(points.size()));
    return circle;
}

// Least-squares cone about an axis through 2-D points seen along it, at their heights along it: the
// circle as the start (its centre is the cone's axis for rings about one axis), the radius a line in
// the height, then Gauss-Newton on the points' radial distances from the cone.
Circle2 fit_cone(const std::vector<cv::Vec2d>& points, const std::vector<double>& heights) {
    Circle2 cone = fit_circle(points);
    if (!(cone.radius > 0) || points.size() < 4) return cone;
    double sum_h = 0, sum_hh = 0, sum_d = 0, sum_hd = 0;
    for (size_t i = 0; i < points.size(); ++i) {
        const double d = cv::norm(points[i] - cone.center), h = heights[i];
        sum_h += h, sum_hh += h * h, sum_d += d, sum_hd += h * d;
    }
    const double n = double(points.size()), spread = n * sum_hh - sum_h * sum_h;
    if (!(spread > 0)) return cone;  // all at one height: a circle
    cone.slope = (n * sum_hd - sum_h * sum_d) / spread;
    cone.radius = (sum_d - cone.slope * sum_h) / n;
    cone.mean_height = sum_h / n;
    for (int iteration = 0; iteration < 30; ++iteration) {
        cv::Matx44d jtj = cv::Matx44d::zeros();
        cv::Vec4d jtr(0, 0, 0, 0);
        for (size_t i = 0; i < points.size(); ++i) {
            const cv::Vec2d offset = points[i] - cone.center;
            const double distance = cv::norm(offset);
            if (distance == 0) continue;
            const cv::Vec4d gradient(-offset[0] / distance, -offset[1] / distance, -1, -heights[i]);
            jtj += gradient * gradient.t();
            jtr += gradient * (distance - cone.radius_at(heights[i]));
        }
        cv::Vec4d step;
        if (!cv::solve(jtj, -jtr, step, cv::DECOMP_CHOLESKY)) break;
        cone.center += cv::Vec2d(step[0], step[1]);
        cone.radius += step[2];
        cone.slope += step[3];
        if (cv::norm(step) < 1e-12 * (1 + std::abs(cone.radius))) break;
    }
    double sum = 0;
    for (size_t i = 0; i < points.size(); ++i) sum += std::pow(cv::norm(points[i] - cone.center) - cone.radius_at(heights[i]), 2);
    cone.rms = std::sqrt(sum / n);
    return cone;
}

std::string point_text(const cv::Vec3d& p) {
    char text[96];
    std::snprintf(text, sizeof text, "(%.3f, %.3f, %.3f)", p[0], p[1], p[2]);
    return text;
}

// Any unit vector square to `axis`.
cv::Vec3d square_to(const cv::Vec3d& axis) {
    const cv::Vec3d helper = std::abs(axis[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
    return cv::normalize(helper - helper.dot(axis) * axis);
}

// The vertices of some faces' facets, each once.
std::vector<int> vertices_of(const PlanarFaceModel& model, const std::vector<size_t>& faces) {
    std::vector<int> vertices;
    for (size_t f : faces)
        for (const cv::Vec3i& triangle : model.faces[f].triangles)
            for (int k = 0; k < 3; ++k) vertices.push_back(triangle[k]);
    std::sort(vertices.begin(), vertices.end());
    vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
    return vertices;
}

// The circle the vertices lie nearest, seen along the axis (unit) from a point of the plane square to it.
Circle2 circle_along(const PlanarFaceModel& model, const std::vector<int>& vertices, const cv::Vec3d& from, const cv::Vec3d& axis) {
    const cv::Vec3d x_axis = square_to(axis), y_axis = axis.cross(x_axis);
    std::vector<cv::Vec2d> seen;
    for (int v : vertices) {
        const cv::Vec3d p = model.vertices[size_t(v)] - from;
        seen.emplace_back(p.dot(x_axis), p.dot(y_axis));
    }
    Circle2 circle = fit_circle(seen);
    circle.origin = from + circle.center[0] * x_axis + circle.center[1] * y_axis;
    return circle;
}

// The cone about an axis parallel to `axis` (unit) the vertices lie nearest (at `positions`), its heights from `from`.
Circle2 cone_along(const std::vector<cv::Vec3d>& positions, const std::vector<int>& vertices, const cv::Vec3d& from, const cv::Vec3d& axis) {
    const cv::Vec3d x_axis = square_to(axis), y_axis = axis.cross(x_axis);
    std::vector<cv::Vec2d> seen;
    std::vector<double> heights;
    for (int v : vertices) {
        const cv::Vec3d p = positions[size_t(v)] - from;
        seen.emplace_back(p.dot(x_axis), p.dot(y_axis));
        heights.push_back(p.dot(axis));
    }
    Circle2 cone = fit_cone(seen, heights);
    cone.origin = from + cone.center[0] * x_axis + cone.center[1] * y_axis;
    return cone;
}

Circle2 cone_along(const PlanarFaceModel& model, const std::vector<int>& vertices, const cv::Vec3d& from, const cv::Vec3d& axis) {
    return cone_along(model.vertices, vertices, from, axis);
}

// How far a point is from a circle's cylinder or cone about `axis` (unit), square to its surface.
double off_cone(const Circle2& cone, const cv::Vec3d& axis, const cv::Vec3d& p) {
    const cv::Vec3d offset = p - cone.origin;
    const double height = offset.dot(axis);
    return std::abs(cv::norm(offset - height * axis) - cone.radius_at(height)) / std::sqrt(1 + cone.slope * cone.slope);
}

// Whether the vertices go all round the circle's axis: no gap between them wider than 45 degrees.
bool all_round(const PlanarFaceModel& model, const std::vector<int>& vertices, const Circle2& circle, const cv::Vec3d& axis) {
    const cv::Vec3d x_axis = square_to(axis), y_axis = axis.cross(x_axis);
    std::vector<double> angles;
    for (int v : vertices) {
        const cv::Vec3d p = model.vertices[size_t(v)] - circle.origin;
        angles.push_back(std::atan2(p.dot(y_axis), p.dot(x_axis)));
    }
    if (angles.empty()) return false;
    std::sort(angles.begin(), angles.end());
    double widest = angles.front() + 2 * kPi - angles.back();
    for (size_t k = 1; k < angles.size(); ++k) widest = std::max(widest, angles[k] - angles[k - 1]);
    return widest < kPi / 4;
}

double mean_edge(const PlanarFaceModel& model, const std::vector<size_t>& faces) {
    double sum = 0;
    size_t count = 0;
    for (size_t f : faces)
        for (const cv::Vec3i& t : model.faces[f].triangles)
            for (int k = 0; k < 3; ++k, ++count) sum += cv::norm(model.vertices[size_t(t[k])] - model.vertices[size_t(t[(k + 1) % 3])]);
    return count ? sum / double(count) : 0;
}

// How much of a wall's facet area has its normal pointing about the axis elsewhere than where the
// facet lies: the total variation distance between the histograms of the facets' area over the
// azimuth of their centres and over the azimuth of their normals. A cylinder's or cone's facets
// face away from the axis wherever they are: both histograms even, the distance near 0 (each facet
// a little off by the noise and the width of its mesh column, which the bins are wider than). A
// prism's flat sides each keep one normal: its normals bunch into one bin per side while its
// facets spread over the side's bins, the distance 1 - 1 / (bins per side). (The corners of a
// regular n-gon prism lie on a circle and its sides within R (1 - cos(180 / n)) of it: 0.9 % of
// the radius for 24 sides, within what the roundness test allows.)
double bunched_normals(const PlanarFaceModel& model, const std::vector<size_t>& faces, const cv::Vec3d& centre,
                       const cv::Vec3d& axis, double radius_mm) {
    const std::vector<cv::Vec3d>& positions = model.mesh_vertices.empty() ? model.vertices : model.mesh_vertices;
    const cv::Vec3d x_axis = square_to(axis), y_axis = axis.cross(x_axis);
    std::vector<double> normal_angle, centre_angle, area, normal_noise;
    double edge_sum = 0;
    for (size_t f : faces)
        for (const cv::Vec3i& t : model.faces[f].triangles) {
            const cv::Vec3d corner[3] = {positions[size_t(t[0])], positions[size_t(t[1])], positions[size_t(t[2])]};
            const cv::Vec3d normal = (corner[1] - corner[0]).cross(corner[2] - corner[0]), middle = (corner[0] + corner[1] + corner[2]) / 3.0 - centre;
            const double twice_area = cv::norm(normal);
            if (!(twice_area > 0)) continue;
            // The tilt of its normal from noise of sigma on its corners: sigma^2 / 2 x the sum of 1 / altitude^2 about the axis.
            double inverse_altitudes = 0;
            for (int k = 0; k < 3; ++k) {
                const double side = cv::norm(corner[(k + 1) % 3] - corner[(k + 2) % 3]);
                edge_sum += side;
                inverse_altitudes += std::pow(side / twice_area, 2);
            }
            normal_noise.push_back(model.noise_mm * std::sqrt(inverse_altitudes / 2));
            normal_angle.push_back(std::atan2(normal.dot(y_axis), normal.dot(x_axis)));
            centre_angle.push_back(std::atan2(middle.dot(y_axis), middle.dot(x_axis)));
            area.push_back(twice_area / 2);
        }
    if (area.empty() || !(radius_mm > 0)) return 0;
    const double mean_edge = edge_sum / double(3 * area.size());
    std::nth_element(normal_noise.begin(), normal_noise.begin() + std::ptrdiff_t(normal_noise.size() / 2), normal_noise.end());
    // Bins wider than a facet seen from the axis and than twice its normal's noise.
    const double width = std::max(1.5 * mean_edge / radius_mm, 2 * normal_noise[normal_noise.size() / 2]);
    const size_t bins = size_t(std::max(8.0, std::floor(2 * kPi / width)));
    auto bin = [&](double angle) { return std::min(bins - 1, size_t((angle + kPi) / (2 * kPi) * double(bins))); };
    // A hole's facets face the axis: their normals turned round, as a boss's.
    double facing = 0;
    for (size_t k = 0; k < area.size(); ++k) facing += area[k] * std::cos(normal_angle[k] - centre_angle[k]);
    const double turn = facing < 0 ? kPi : 0;
    std::vector<double> by_centre(bins, 0), by_normal(bins, 0);
    double total = 0;
    for (size_t k = 0; k < area.size(); ++k) {
        by_centre[bin(centre_angle[k])] += area[k];
        by_normal[bin(std::remainder(normal_angle[k] + turn, 2 * kPi))] += area[k];
        total += area[k];
    }
    double distance = 0;
    for (size_t b = 0; b < bins; ++b) distance += std::abs(by_centre[b] - by_normal[b]);
    return 0.5 * distance / total;
}

// A prism of n flat sides, its corners on a circle of radius R, lies at R cos(180 / n) / cos(psi)
// from the axis, psi the azimuth from the middle of the nearest side: a parabola in the azimuth that
// repeats n times round, as deep as the sides' sagitta R (1 - cos(180 / n)), with a crease at each
// corner. A cylinder's vertices lie off its circle by noise, which no such pattern follows; a round
// wall's lobes (n of them) follow it too, but smoothly: a wave cos(n x azimuth) follows them better.
// The pattern and the wave that best follow the vertices' radial residuals from the circle (n from 3
// to 128 and to half the azimuths sampled, turned by any angle: least squares on the residuals' means
// in 1024 bins of azimuth, 32 turns per side), the shares of the residuals' variance they explain,
// how deep the pattern's sides are, and how much better than the wave it follows them, over the
// variance the pattern leaves per vertex (the chi-square of that one more degree of freedom).
struct PolygonPattern {
    int sides = 0;
    double explained = 0, wave_explained = 0, depth_mm = 0, creases = 0;
};

PolygonPattern polygon_pattern(const PlanarFaceModel& model, const std::vector<size_t>& faces, const Circle2& circle, const cv::Vec3d& axis) {
    const std::vector<cv::Vec3d>& positions = model.mesh_vertices.empty() ? model.vertices : model.mesh_vertices;
    const cv::Vec3d x_axis = square_to(axis), y_axis = axis.cross(x_axis);
    constexpr int kBins = 1024, kTurns = 32, kMostSides = 128;
    std::vector<double> bin_sum(kBins, 0), bin_count(kBins, 0);
    double sum = 0, sum_squares = 0, count = 0;
    for (int v : vertices_of(model, faces)) {
        const cv::Vec3d p = positions[size_t(v)] - circle.origin;
        const double x = p.dot(x_axis), y = p.dot(y_axis), residual = std::hypot(x, y) - circle.radius;
        const int b = std::min(kBins - 1, int((std::atan2(y, x) + kPi) / (2 * kPi) * kBins));
        bin_sum[size_t(b)] += residual, bin_count[size_t(b)] += 1;
        sum += residual, sum_squares += residual * residual, count += 1;
    }
    PolygonPattern best;
    const double variance_sum = sum_squares - sum * sum / std::max(count, 1.0);  // of the residuals about their mean
    if (!(variance_sum > 0)) return best;
    // A mesh sampled at a few azimuths (a ring of 126 vertices) sees a pattern of more than half as
    // many sides as a few lobes (123 sides as 3).
    const int sampled = int(std::count_if(bin_count.begin(), bin_count.end(), [](double c) { return c > 0; }));
    // The share of the bins' means' variance a shape g (over the bins' azimuths) explains: mean = a g + c, a > 0.
    auto explained_by = [&](auto&& shape) {
        double w = 0, wg = 0, wgg = 0, wm = 0, wgm = 0;
        for (int b = 0; b < kBins; ++b) {
            if (bin_count[size_t(b)] == 0) continue;
            const double g = shape(-kPi + (b + 0.5) * 2 * kPi / kBins), n_b = bin_count[size_t(b)], mean = bin_sum[size_t(b)] / n_b;
            w += n_b, wg += n_b * g, wgg += n_b * g * g, wm += n_b * mean, wgm += n_b * g * mean;
        }
        const double spread = wgg - wg * wg / w, covariance = wgm - wg * wm / w;
        return std::make_pair(spread > 0 && covariance > 0 ? covariance * covariance / spread : 0.0, spread > 0 ? covariance / spread : 0.0);
    };
    double best_sum = 0, best_wave_sum = 0;
    for (int n = 3; n <= std::min(kMostSides, sampled / 2); ++n) {
        const double side = 2 * kPi / n;
        for (int turn = 0; turn < kTurns; ++turn) {
            const double start = side * turn / kTurns;  // a corner's azimuth
            const auto [pattern_sum, a] = explained_by([&](double azimuth) {
                return std::cos(side / 2) / std::cos(std::fmod(azimuth - start + 4 * kPi, side) - side / 2);
            });
            const double wave_sum = explained_by([&](double azimuth) { return std::cos(n * (azimuth - start)); }).first;
            best_wave_sum = std::max(best_wave_sum, wave_sum);
            if (pattern_sum > best_sum) {
                best_sum = pattern_sum;
                best.sides = n;
                best.depth_mm = a * (1 - std::cos(side / 2));
            }
        }
    }
    best.explained = best_sum / variance_sum;
    best.wave_explained = best_wave_sum / variance_sum;
    best.creases = (best_sum - best_wave_sum) / std::max((variance_sum - best_sum) / count, 1e-300);
    return best;
}

struct Tolerances {
    double distance = 0, rms = 0;  // a vertex's distance, the vertices' RMS distance (mm)
};

Tolerances tolerances(const PlanarFaceModel& model, const PlanarFaceOptions& options, double radius_mm) {
    const double noise = std::max(model.noise_mm, kRoundness * radius_mm);
    return {options.distance_factor * noise, options.max_rms_factor * noise};
}

// The distance along the axis (through origin, unit) from origin to where it meets a face's plane.
double level_of(const BrepFace& plane, const cv::Vec3d& origin, const cv::Vec3d& axis) {
    return (plane.origin - origin).dot(plane.normal) / axis.dot(plane.normal);
}

// Where a cylinder's ends are along its axis, and which way each plane must run its circle for
// the shell to be consistent (add_cylinder_faces writes them so; cylinder_regions checks that the
// planes' loops already run that way).
struct Loops {
    size_t low = 0;            // which of planes[] is at the lower level
    double low_level = 0, length = 0;
    int plane_sign[2] = {0, 0};  // the circle's direction in each plane's wire (+1: as the circle runs)
};

Loops loops_of(const PlanarFaceModel& model, const CylinderRegion& region) {
    Loops loops;
    double levels[2];
    for (int i = 0; i < 2; ++i) levels[i] = level_of(model.faces[region.planes[i]], region.origin, region.axis);
    loops.low = levels[0] <= levels[1] ? 0 : 1;
    loops.low_level = levels[loops.low];
    loops.length = levels[1 - loops.low] - levels[loops.low];
    // Seen from outside the solid the cylinder's wire runs the low circle forwards, the high one
    // backwards (a hole's face is reversed: the other way); each plane runs its circle the other way.
    const int low_in_cylinder = region.hole ? -1 : 1;
    loops.plane_sign[loops.low] = -low_in_cylinder;
    loops.plane_sign[1 - loops.low] = low_in_cylinder;
    return loops;
}

// How far a point is from a region's wall (its cylinder or cone, beyond a bend the other one), square to it.
double off_wall(const CylinderRegion& region, const cv::Vec3d& p) {
    const cv::Vec3d offset = p - region.origin;
    const double height = offset.dot(region.axis), slope = region.slope_at(height);
    return std::abs(cv::norm(offset - height * region.axis) - region.radius_at(height)) / std::sqrt(1 + slope * slope);
}

// How far a facet lies from a surface continued over it (`off`: a point's distance from it), at its
// corners, the middles of its sides and its centre (a chamfer's facets have their corners on the
// cylinder and the plane, and cut the corner between), and the volume between the two: its area
// times the mean distance at the middles of its sides (the rule exact for quadratics).
struct FacetOff {
    double farthest, volume;
};
template <class Distance>
FacetOff facet_off(const PlanarFaceModel& model, const cv::Vec3i& facet, Distance off) {
    const cv::Vec3d &p = model.vertices[size_t(facet[0])], &q = model.vertices[size_t(facet[1])], &r = model.vertices[size_t(facet[2])];
    const double sides[3] = {off((p + q) / 2), off((q + r) / 2), off((r + p) / 2)};
    double farthest = std::max({sides[0], sides[1], sides[2]});
    for (const cv::Vec3d& at : {p, q, r, (p + q + r) / 3}) farthest = std::max(farthest, off(at));
    return {farthest, 0.5 * cv::norm((q - p).cross(r - p)) * (sides[0] + sides[1] + sides[2]) / 3};
}

// A chamfer ring's cone, its facets in cone_faces, about the axis of the cylinder already fitted to
// `region`'s wall (its facets square to the axis in near_faces): the radius a straight
// line in the height about that axis (least squares), then where the two meet, the circle both faces
// end at. Makes `region` bent and answers "" when the cone is one (half-angle, RMS and its facets'
// sides as for a cone between two planes, its own free fit's axis within the distance limit of the
// cylinder's), the circle lies between the cylinder's facets and the cone's (within the distance
// limit across the cone) and clear of both planes, and the facets between (a smooth mesh's rounded
// crease) lie within `ring` of the two faces or the planes square to the axis, changing the volume
// by at most kRingVolumeShare; otherwise why not.
std::string bend_onto(const PlanarFaceModel& model, CylinderRegion& region, const std::vector<size_t>& near_faces,
                      const std::vector<size_t>& cone_faces, const std::vector<size_t>& square_planes, double ring,
                      const Tolerances& limits, bool check_bunching) {
    char text[400];
    if (region.slope != 0 || near_faces.empty()) return "its wall is not a cylinder (a ring beyond a cone is not made)";
    // The scan's own vertices (the mesh's, before any was moved onto a plane: a chamfer's strips
    // may have been merged into planes, flat within the noise).
    std::vector<cv::Vec3d> positions(model.vertices);
    std::copy(model.mesh_vertices.begin(), model.mesh_vertices.end(), positions.begin());
    const std::vector<int> cone_vertices = vertices_of(model, cone_faces);
    const cv::Vec3d from = model.faces[region.planes[0]].origin;
    const Circle2 own = cone_along(positions, cone_vertices, from, region.axis);
    const double apart = cv::norm(own.origin - region.origin);
    if (!(apart <= limits.distance)) {
        std::snprintf(text, sizeof text, "its cone's own axis is %.4f mm from its cylinder's (at most %.4f mm)", apart, limits.distance);
        return text;
    }
    double sum_h = 0, sum_hh = 0, sum_d = 0, sum_hd = 0;
    std::vector<cv::Vec2d> height_distance;
    for (int v : cone_vertices) {
        const cv::Vec3d offset = positions[size_t(v)] - region.origin;
        const double h = offset.dot(region.axis), d = cv::norm(offset - h * region.axis);
        sum_h += h, sum_hh += h * h, sum_d += d, sum_hd += h * d;
        height_distance.emplace_back(h, d);
    }
    const double n = double(cone_vertices.size()), spread = n * sum_hh - sum_h * sum_h;
    if (!(spread > 0)) return "its cone's facets lie at one height";
    const double slope = (n * sum_hd - sum_h * sum_d) / spread, radius0 = (sum_d - slope * sum_h) / n;
    double sum = 0;
    for (const cv::Vec2d& hd : height_distance) sum += std::pow(hd[1] - radius0 - slope * hd[0], 2);
    const double rms = std::sqrt(sum / n) / std::sqrt(1 + slope * slope);
    const double half_angle = std::atan(std::abs(slope)) * 180 / kPi;
    CylinderRegion bent = region;
    bent.bent = true;
    bent.far_slope = slope;
    // The middles of its facets' sides, less the sagitta a chord of the true cone has there (its
    // facets are small against its radius, as a chamfer's are: that sagitta is most of what a
    // pyramid's flat faces would add).
    const cv::Vec3d x_axis = square_to(region.axis), y_axis = region.axis.cross(x_axis);
    auto azimuth = [&](const cv::Vec3d& p) { return std::atan2((p - region.origin).dot(y_axis), (p - region.origin).dot(x_axis)); };
    double side_off = 0;
    for (size_t f : cone_faces)
        for (const cv::Vec3i& t : model.faces[f].triangles)
            for (int k = 0; k < 3; ++k) {
                const cv::Vec3d &a = positions[size_t(t[k])], &b = positions[size_t(t[(k + 1) % 3])];
                const cv::Vec3d middle = 0.5 * (a + b) - region.origin;
                const double h = middle.dot(region.axis), radius = radius0 + slope * h;
                const double sagitta = radius * (1 - std::cos(0.5 * std::remainder(azimuth(b) - azimuth(a), 2 * kPi)));
                side_off = std::max(side_off, std::abs(cv::norm(middle - h * region.axis) - radius + sagitta) / std::sqrt(1 + slope * slope));
            }
    if (!(half_angle >= kMinConeDeg && half_angle <= kMaxConeDeg && rms <= limits.rms && side_off <= limits.distance)) {
        std::snprintf(text, sizeof text, "its ring is not a cone about the cylinder's axis (half-angle %.2f degrees, %g to %g made; "
                      "RMS %.4f mm, sides of its facets up to %.4f mm from its chords, at most %.4f and %.4f mm)",
                      half_angle, kMinConeDeg, kMaxConeDeg, rms, side_off, limits.rms, limits.distance);
        return text;
    }
    if (check_bunching) {
        const double bunched = bunched_normals(model, cone_faces, region.origin, region.axis, radius0 + slope * own.mean_height);
        if (bunched > kMaxBunchedNormals) {
            std::snprintf(text, sizeof text, "its ring's facets' normals bunch into a few directions round the axis (%.0f %% of its area "
                          "faces elsewhere than a cone's would, at most %.0f %%): a pyramid", 100 * bunched, 100 * kMaxBunchedNormals);
            return text;
        }
    }
    // The circle where the two meet, and how far the facets of each reach towards the other.
    bent.bend_level = (region.radius_mm - radius0) / slope;
    double near_mean = 0, cone_mean = sum_h / n;
    const std::vector<int> near_vertices = vertices_of(model, near_faces);
    for (int v : near_vertices) near_mean += (model.vertices[size_t(v)] - region.origin).dot(region.axis) / double(near_vertices.size());
    const double towards = cone_mean > near_mean ? 1 : -1;  // from the cylinder to the cone along the axis
    double near_reach = -1e300, cone_reach = 1e300;       // the farthest towards the other, as towards x height
    for (int v : near_vertices) near_reach = std::max(near_reach, towards * (model.vertices[size_t(v)] - region.origin).dot(region.axis));
    for (const cv::Vec2d& hd : height_distance) cone_reach = std::min(cone_reach, towards * hd[0]);
    const double far_level = level_of(model.faces[region.planes[1]], region.origin, region.axis);
    const double bend = towards * bent.bend_level, along_cone = limits.distance / std::sin(std::atan(std::abs(slope)));
    if (!(near_reach <= bend + along_cone && bend <= cone_reach + along_cone && bend > limits.distance &&
          towards * far_level - bend > limits.distance)) {
        std::snprintf(text, sizeof text, "the circle where they meet (%.4f mm along the axis from the cylinder's plane, radius %.4f mm) "
                      "is not between the cylinder's facets (to %.4f mm) and the cone's (from %.4f mm; %.4f mm across the cone allowed) "
                      "and apart from the planes (the other at %.4f mm)", bend, region.radius_mm,
                      near_reach, cone_reach, along_cone, towards * far_level);
        return text;
    }
    // The facets neither on the cylinder nor on the cone: the two faces and the planes are continued over them.
    std::vector<size_t> crease;
    std::set_difference(region.faces.begin(), region.faces.end(), cone_faces.begin(), cone_faces.end(), std::back_inserter(crease));
    std::vector<size_t> near_sorted(near_faces);
    std::sort(near_sorted.begin(), near_sorted.end());
    crease.erase(std::remove_if(crease.begin(), crease.end(), [&](size_t f) { return std::binary_search(near_sorted.begin(), near_sorted.end(), f); }),
                 crease.end());
    auto off_surface = [&](const cv::Vec3d& p) {
        double off = off_wall(bent, p);
        for (size_t h : square_planes) off = std::min(off, std::abs((p - model.faces[h].origin).dot(cv::normalize(model.faces[h].normal))));
        return off;
    };
    size_t crease_facets = 0;
    double volume = 0, farthest = 0;
    for (size_t f : crease)
        for (const cv::Vec3i& t : model.faces[f].triangles) {
            const FacetOff off = facet_off(model, t, off_surface);
            farthest = std::max(farthest, off.farthest);
            volume += off.volume;
            ++crease_facets;
        }
    if (!(farthest <= ring) || volume > kRingVolumeShare * model.mesh_volume_mm3) {
        std::snprintf(text, sizeof text, "the %zu facets between its faces and planes are up to %.4f mm from them (at most %.4f mm) and "
                      "would change the volume by up to %.3g mm3 (at most %.3g mm3)", crease_facets, farthest, ring, volume,
                      kRingVolumeShare * model.mesh_volume_mm3);
        return text;
    }
    bent.rms_mm = std::max(region.rms_mm, rms);
    bent.end_facets = crease_facets;
    bent.end_mm = farthest;
    bent.end_volume_mm3 = volume;
    region = bent;
    return "";
}

}  // namespace

std::vector<CylinderRegion> cylinder_regions(const PlanarFaceModel& model, const PlanarFaceOptions& options,
                                             const std::vector<char>& eligible, std::vector<std::string>& notes) {
    const size_t face_count = model.faces.size();
    auto allowed = [&](size_t f) { return model.faces[f].radius_mm == 0 && (eligible.empty() || eligible[f]); };
    auto one_facet = [&](size_t f) { return !model.faces[f].merged && model.faces[f].triangles.size() == 1 && allowed(f); };
    std::vector<std::vector<size_t>> faces_of_edge(model.edges.size());
    for (size_t f = 0; f < face_count; ++f)
        for (const auto& wire : model.faces[f].wires)
            for (int e : wire) faces_of_edge[size_t(std::abs(e) - 1)].push_back(f);
    auto neighbours = [&](size_t f) {
        std::vector<size_t> around;
        for (const auto& wire : model.faces[f].wires)
            for (int e : wire)
                for (size_t g : faces_of_edge[size_t(std::abs(e) - 1)])
                    if (g != f) around.push_back(g);
        return around;
    };

    std::vector<CylinderRegion> regions;
    std::vector<char> taken(face_count, 0);  // in a region found already (made or refused)
    std::vector<cv::Vec3d> axes_tried;
    for (size_t axis_face = 0; axis_face < face_count; ++axis_face) {
        if (!model.faces[axis_face].merged) continue;
        // A cylinder's ends are square to it: each planar face's normal is an axis to try, once
        // within 5 degrees (the walls are found the same; each is fitted along its own end's normal).
        const cv::Vec3d axis = cv::normalize(model.faces[axis_face].normal);
        if (std::any_of(axes_tried.begin(), axes_tried.end(), [&](const cv::Vec3d& a) { return std::abs(a.dot(axis)) > kSameAxis; }))
            continue;
        axes_tried.push_back(axis);
        auto along = [&](size_t f) { return std::abs(cv::normalize(model.faces[f].normal).dot(axis)); };
        // Its wall: one-facet faces and planar strips (a finely divided wall is flat within the
        // noise in strips) whose normals are within 60 degrees of square to the axis. The rounded
        // or sharpened edges where a smooth (Poisson) mesh's wall meets its ends tilt further and
        // keep the walls of one mesh apart. Steeper walls (steep: within 25 degrees of the planes'
        // tilt) can only be cones.
        bool steep = false;
        auto wall = [&](size_t f) {
            const bool tilt = steep ? along(f) >= 0.5 && along(f) < 0.9 : along(f) < 0.5;
            return !taken[f] && allowed(f) && (one_facet(f) || model.faces[f].merged) && tilt;
        };
        std::vector<char> in_wall(face_count, 0);
        std::vector<size_t> square_planes;
        for (size_t f = 0; f < face_count; ++f)
            if (model.faces[f].merged && along(f) > 0.9) square_planes.push_back(f);
        // A chamfer ring: a wall (`from`: its facets and those next to it) that does not end in two
        // planar faces square to the axis may go on into a cone before it meets one (a chamfered or
        // countersunk hole's mouth, a chamfered boss's top edge). The faces that reach from it to such
        // planes, through any faces but those of other walls: when they meet exactly two and nothing
        // else, `ends` (the wall's own plane first: the one the tilted facets are away from) and their
        // faces, with the cone's among them (tilted within kRingSpreadDeg of the median tilt of those
        // not within 15 degrees of square to the axis). Empty `ends`: no such ring.
        struct Ring {
            std::vector<size_t> faces, cone_faces, ends;
        };
        auto ring_beyond = [&](const std::vector<size_t>& from) {
            Ring ring;
            ring.faces = from;
            std::vector<char> seen_face(face_count, 0);
            for (size_t f : from) seen_face[f] = 1;
            size_t other_faces = 0;
            for (size_t next = 0; next < ring.faces.size(); ++next)
                for (size_t g : neighbours(ring.faces[next])) {
                    if (seen_face[g]) continue;
                    seen_face[g] = 1;
                    if (model.faces[g].merged && along(g) > 0.9) ring.ends.push_back(g);
                    else if (!taken[g] && allowed(g)) ring.faces.push_back(g);
                    else ++other_faces;
                }
            if (ring.ends.size() != 2 || other_faces > 0) return Ring{};
            std::sort(ring.faces.begin(), ring.faces.end());
            // The tilt of each face's normal from square to the axis, signed (a hole's chamfered mouth
            // and its rounded foot tilt opposite ways), by area (the median of those tilted more than 15 degrees).
            const cv::Vec3d first_normal = cv::normalize(model.faces[ring.ends[0]].normal);
            auto tilt_of = [&](size_t f) { return std::asin(std::clamp(cv::normalize(model.faces[f].normal).dot(first_normal), -1.0, 1.0)) * 180 / kPi; };
            std::vector<std::pair<double, double>> tilts;
            double tilted_area = 0;
            for (size_t f : ring.faces) {
                if (along(f) < kSquareToAxis) continue;
                double area = 0;
                for (const cv::Vec3i& t : model.faces[f].triangles)
                    area += 0.5 * cv::norm((model.vertices[size_t(t[1])] - model.vertices[size_t(t[0])])
                                               .cross(model.vertices[size_t(t[2])] - model.vertices[size_t(t[0])]));
                tilts.emplace_back(tilt_of(f), area);
                tilted_area += area;
            }
            std::sort(tilts.begin(), tilts.end());
            double median = 0, below = 0;
            for (const auto& [tilt, area] : tilts)
                if ((below += area) >= tilted_area / 2) {
                    median = tilt;
                    break;
                }
            // Of those tilted as the median, the ones joined to each other over the most area (a sliver's
            // normal, tipped by the noise, may tilt as a cone's anywhere).
            std::vector<char> tilted_as_cone(face_count, 0);
            for (size_t f : ring.faces)
                tilted_as_cone[f] = along(f) >= kSquareToAxis && std::abs(tilt_of(f) - median) <= kRingSpreadDeg;
            double largest = 0;
            for (size_t start : ring.faces) {
                if (!tilted_as_cone[start]) continue;
                std::vector<size_t> joined{start};
                tilted_as_cone[start] = 0;
                double area = 0;
                for (size_t next = 0; next < joined.size(); ++next) {
                    for (const cv::Vec3i& t : model.faces[joined[next]].triangles)
                        area += cv::norm((model.vertices[size_t(t[1])] - model.vertices[size_t(t[0])])
                                             .cross(model.vertices[size_t(t[2])] - model.vertices[size_t(t[0])]));
                    for (size_t g : neighbours(joined[next]))
                        if (tilted_as_cone[g]) {
                            tilted_as_cone[g] = 0;
                            joined.push_back(g);
                        }
                }
                if (area > largest) largest = area, ring.cone_faces = joined;
            }
            std::sort(ring.cone_faces.begin(), ring.cone_faces.end());
            if (ring.cone_faces.empty()) return Ring{};
            // The wall's own plane: the one on the far side of the wall from the cone.
            const cv::Vec3d& origin = model.faces[ring.ends[0]].origin;
            auto mean_level = [&](const std::vector<size_t>& faces) {
                const std::vector<int> vertices = vertices_of(model, faces);
                double sum = 0;
                for (int v : vertices) sum += (model.vertices[size_t(v)] - origin).dot(first_normal);
                return sum / double(vertices.size());
            };
            const double towards_cone = mean_level(ring.cone_faces) - mean_level(from);
            const double second_level = level_of(model.faces[ring.ends[1]], origin, first_normal);
            if ((towards_cone > 0) != (second_level >= 0)) std::swap(ring.ends[0], ring.ends[1]);
            return ring;
        };
        // First the walls within 60 degrees of square to the axis (cylinders, cones up to 30 degrees), then
        // those steeper (cones up to 64 degrees: a countersink, a chamfer), which no cylinder's wall holds.
        for (const bool steep_walls : {false, true}) {
            steep = steep_walls;
            for (size_t start = 0; start < face_count; ++start) {
                if (in_wall[start] || !one_facet(start) || !wall(start)) continue;
                std::vector<size_t> members{start};
                in_wall[start] = 1;
                for (size_t next = 0; next < members.size(); ++next)
                    for (size_t g : neighbours(members[next]))
                        if (!in_wall[g] && wall(g)) {
                            in_wall[g] = 1;
                            members.push_back(g);
                        }
                size_t wall_facets = 0;
                for (size_t f : members) wall_facets += model.faces[f].triangles.size();
                if (int(wall_facets) < options.min_facets) continue;
                const std::vector<int> wall_vertices = vertices_of(model, members);
                const cv::Vec3d& from = model.faces[axis_face].origin;
                auto near = [](const Circle2& c) { return c.mean_radius() > 0 && c.rms < 0.05 * c.mean_radius(); };
                // Far from any circle (or, failing that, cone) or not around it (the walls of a box with a
                // rounded edge, a flat strip): not a candidate, not reported.
                Circle2 seen = steep ? Circle2{} : circle_along(model, wall_vertices, from, axis);
                if (!near(seen)) seen = cone_along(model, wall_vertices, from, axis);
                if (!near(seen) || !all_round(model, wall_vertices, seen, axis)) continue;
                const Tolerances limits = tolerances(model, options, seen.mean_radius());
                // Where a smooth (Poisson) mesh rounds or bevels the wall's ends: the facets next to it
                // that lie within `ring` of its cylinder (two of the wall's mean edges, or the distance
                // limit) go with it, and the planes at its ends are continued to the circles instead.
                const double ring = std::max(limits.distance, 2 * mean_edge(model, members));
                const size_t wall_count = members.size();
                // How far a point is from the ideal surface there: the cylinder (cone) or a plane square to it.
                auto off_surface = [&](const cv::Vec3d& p) {
                    double off = off_cone(seen, axis, p);
                    for (size_t h : square_planes)
                        off = std::min(off, std::abs((p - model.faces[h].origin).dot(cv::normalize(model.faces[h].normal))));
                    return off;
                };
                // What the facets next to the wall that go with it (within `ring` of the cylinder or of a
                // plane square to it: the cylinder and the plane are continued over them) change the
                // volume by.
                double ring_volume = 0, ring_farthest = 0;
                for (size_t next = 0; next < members.size(); ++next)
                    for (size_t g : neighbours(members[next])) {
                        if (in_wall[g] || taken[g] || !one_facet(g)) continue;
                        const FacetOff off = facet_off(model, model.faces[g].triangles[0], off_surface);
                        if (!(off.farthest <= ring)) continue;
                        ring_volume += off.volume;
                        ring_farthest = std::max(ring_farthest, off.farthest);
                        in_wall[g] = 1;
                        members.push_back(g);
                    }
                const std::vector<size_t> wall_faces(members.begin(), members.begin() + std::ptrdiff_t(wall_count));
                // When its facets square to the axis (within 15 degrees) make a cylinder, its facets tilted
                // further (a smooth mesh's rounded ends; a shallow chamfer ring, which would otherwise be
                // taken into the cylinder unseen) are held to the same: within `ring` of that cylinder or
                // of a plane square to it, their volume counted with those next to it.
                size_t tilted_facets = 0;
                double tilted_farthest = 0;
                if (!steep) {
                    std::vector<size_t> square_wall, tilted_wall;
                    for (size_t f : wall_faces) (along(f) < kSquareToAxis ? square_wall : tilted_wall).push_back(f);
                    const Circle2 square_fit = square_wall.empty() || tilted_wall.empty() ? Circle2{}
                                                                                          : circle_along(model, vertices_of(model, square_wall), from, axis);
                    auto off_fit = [&](const cv::Vec3d& at) {
                        double off = off_cone(square_fit, axis, at);
                        for (size_t h : square_planes)
                            off = std::min(off, std::abs((at - model.faces[h].origin).dot(cv::normalize(model.faces[h].normal))));
                        return off;
                    };
                    if (square_fit.radius > 0 && square_fit.rms <= limits.rms)
                        for (size_t f : tilted_wall)
                            for (const cv::Vec3i& t : model.faces[f].triangles) {
                                const FacetOff off = facet_off(model, t, off_fit);
                                ring_volume += off.volume;
                                tilted_farthest = std::max(tilted_farthest, off.farthest);
                                ++tilted_facets;
                            }
                }
                size_t facets = 0;
                for (size_t f : members) facets += model.faces[f].triangles.size();
                std::vector<size_t> ends;
                size_t other_faces = 0;  // faces next to it neither an end nor its own
                // Its own: not in_wall, which also holds the walls (and their rings) tried before on this
                // axis; one of those beside it would be left between it and its planes, joined to nothing.
                std::vector<size_t> own(members);
                std::sort(own.begin(), own.end());
                for (size_t f : members)
                    for (size_t g : neighbours(f)) {
                        if (std::binary_search(own.begin(), own.end(), g) || std::find(ends.begin(), ends.end(), g) != ends.end())
                            continue;
                        if (model.faces[g].merged && along(g) > 0.9) ends.push_back(g);
                        else ++other_faces;
                    }
                for (size_t f : members) taken[f] = 1;

                CylinderRegion region;
                region.faces = members;
                std::sort(region.faces.begin(), region.faces.end());
                char text[480];
                if (seen.slope == 0)
                    std::snprintf(text, sizeof text, "%zu facets near a cylinder of radius %.3f mm about the axis through %s along %s",
                                  facets, seen.radius, point_text(seen.origin).c_str(), point_text(axis).c_str());
                else
                    std::snprintf(text, sizeof text, "%zu facets near a cone of half-angle %.2f degrees, mean radius %.3f mm, about "
                                  "the axis through %s along %s", facets, seen.half_angle_deg(), seen.mean_radius(),
                                  point_text(seen.origin).c_str(), point_text(axis).c_str());
                std::string name = text;
                auto refuse = [&](const std::string& why) { notes.push_back(name + " stay as they were: " + why); };
                std::string ends_problem;
                if (tilted_farthest > ring) {
                    std::snprintf(text, sizeof text,
                                  "%zu facets of its wall tilted more than 15 degrees from its axis are up to %.4f mm from the cylinder "
                                  "of the rest and its planes (at most %.4f mm): a cone or chamfer on it", tilted_facets, tilted_farthest, ring);
                    ends_problem = text;
                } else if (ends.size() != 2 || other_faces > 0) {
                    std::snprintf(text, sizeof text,
                                  "its wall does not end in two planar faces square to it (it meets %zu such planes and %zu other "
                                  "faces: a cone or chamfer, a plane cut obliquely, a flat on it, or triangles beyond it)",
                                  ends.size(), other_faces);
                    ends_problem = text;
                } else if (ring_volume > kRingVolumeShare * model.mesh_volume_mm3) {
                    std::snprintf(text, sizeof text,
                                  "the %zu facets where its wall meets its ends are too far from the cylinder and the planes continued "
                                  "to it: the volume would change by up to %.3g mm3 (at most %.2g %% of the mesh's, %.3g mm3)",
                                  members.size() - wall_count + tilted_facets, ring_volume, 100 * kRingVolumeShare, kRingVolumeShare * model.mesh_volume_mm3);
                    ends_problem = text;
                }
                // Not so, but a chamfer ring beyond it: the wall's cylinder is fitted below as any, then the ring's cone.
                Ring chamfer;
                if (!ends_problem.empty()) {
                    if (!steep) chamfer = ring_beyond(members);
                    if (chamfer.ends.empty()) {
                        refuse(ends_problem);
                        continue;
                    }
                    for (size_t f : chamfer.faces) taken[f] = 1;
                    region.faces = chamfer.faces;
                    ends = chamfer.ends;
                    facets = 0;
                    for (size_t f : chamfer.faces) facets += model.faces[f].triangles.size();
                }
                region.planes[0] = ends[0];
                region.planes[1] = ends[1];
                region.end_facets = members.size() - wall_count;
                region.end_mm = ring_farthest;
                region.end_volume_mm3 = ring_volume;
                name = std::to_string(facets) + " facets between the planes at " + point_text(model.faces[ends[0]].origin) + " and " +
                       point_text(model.faces[ends[1]].origin);
                auto in_region = [&](size_t f) { return std::binary_search(region.faces.begin(), region.faces.end(), f); };

                // The cylinder square to the first plane: a circle through the wall's vertices seen along its normal.
                const BrepFace& first = model.faces[region.planes[0]];
                region.axis = cv::normalize(first.normal);
                region.x_axis = square_to(region.axis);
                // Fitted to the facets within 15 degrees of square to the axis: a smooth mesh's wall
                // bends into the rounded edges at its ends.
                std::vector<size_t> square_facets;
                for (size_t f : wall_faces)
                    if (along(f) < kSquareToAxis) square_facets.push_back(f);
                const double distance_limit = limits.distance, rms_limit = limits.rms;
                Circle2 circle = steep ? Circle2{} : circle_along(model, vertices_of(model, square_facets), first.origin, region.axis);
                if (steep || !(circle.rms <= rms_limit)) {
                    // Not a cylinder: a cone coaxial with it, fitted to the whole wall, when its half-angle is
                    // one (as Fit primitives, a narrower cone is a cylinder with noise), its vertices as near it
                    // as a cylinder's must be, and its facets not flat across it (the middles of their sides
                    // as near as their corners: a pyramid's faces have their corners on a cone).
                    const Circle2 cone = cone_along(model, vertices_of(model, wall_faces), first.origin, region.axis);
                    double side_off = 0;
                    for (size_t f : wall_faces)
                        for (const cv::Vec3i& t : model.faces[f].triangles)
                            for (int k = 0; k < 3; ++k)
                                side_off = std::max(side_off, off_cone(cone, region.axis, 0.5 * (model.vertices[size_t(t[k])] +
                                                                                               model.vertices[size_t(t[(k + 1) % 3])])));
                    const bool is_cone = cone.half_angle_deg() >= kMinConeDeg && cone.half_angle_deg() <= kMaxConeDeg &&
                                         cone.surface_rms() <= rms_limit && side_off <= distance_limit;
                    if (!is_cone) {
                        char cone_text[200] = "";
                        if (cone.mean_radius() > 0)
                            std::snprintf(cone_text, sizeof cone_text, "(half-angle %.2f degrees, %g to %g made; RMS %.4f mm, sides of its "
                                          "facets up to %.4f mm from it, at most %.4f)", cone.half_angle_deg(), kMinConeDeg,
                                          kMaxConeDeg, cone.surface_rms(), side_off, distance_limit);
                        if (steep || !(circle.radius > 0))  // no facets of its wall square to the axis: no cylinder to fit
                            std::snprintf(text, sizeof text, "not a cone square to its planes %s", cone_text);
                        else
                            std::snprintf(text, sizeof text,
                                          "not a cylinder square to its planes (RMS %.4f mm from the best one, radius %.4f mm; at most "
                                          "%.4f mm: %.2g x the noise or %.2g %% of the radius); nor a cone %s", circle.rms, circle.radius, rms_limit,
                                          options.max_rms_factor, 100 * options.max_rms_factor * kRoundness, cone_text);
                        refuse(text);
                        continue;
                    }
                    circle = cone;
                }
                // A prism of many flat sides (its corners on the circle) fits a cylinder within the
                // roundness allowed; its facets' normals bunch into one direction per side. Tested on
                // the scan's own vertices; the second search (eligible: among the facets found before,
                // their vertices since moved onto planes) only finds those again.
                const double bunched = !eligible.empty() ? 0.0 : bunched_normals(model, circle.slope == 0 ? square_facets : wall_faces,
                                                                                 circle.origin, region.axis, circle.mean_radius());
                if (bunched > kMaxBunchedNormals) {
                    std::snprintf(text, sizeof text,
                                  "its facets' normals bunch into a few directions round the axis (%.0f %% of its area faces elsewhere "
                                  "than a %s's would, at most %.0f %%): flat sides with creases between them, a prism or pyramid",
                                  100 * bunched, circle.slope == 0 ? "cylinder" : "cone", 100 * kMaxBunchedNormals);
                    refuse(text);
                    continue;
                }
                // A prism of many small sides (1.2 mm sides of a 32-sided prism of radius 6 mm) bunches
                // its normals less than the noise spreads them, but its vertices' distances from the axis
                // follow its sides. Tested as the normals are.
                const PolygonPattern pattern = circle.slope != 0 || !eligible.empty() ? PolygonPattern{}
                                                                                      : polygon_pattern(model, square_facets, circle, region.axis);
                if (pattern.explained >= kMaxPolygonShare && pattern.depth_mm > model.noise_mm && pattern.creases >= kMinCreases) {
                    std::snprintf(text, sizeof text,
                                  "its vertices' distances from the axis follow a prism of %d flat sides, %.4f mm deep, creased at its "
                                  "corners (the pattern holds %.0f %% of their variance about the cylinder, a smooth wave of as many lobes "
                                  "%.0f %%; at most %.0f %% when deeper than the noise, %.4f mm, and ahead of the wave by a chi-square "
                                  "of %.0f, at least %.0f)",
                                  pattern.sides, pattern.depth_mm, 100 * pattern.explained, 100 * pattern.wave_explained,
                                  100 * kMaxPolygonShare, model.noise_mm, pattern.creases, kMinCreases);
                    refuse(text);
                    continue;
                }
                region.radius_mm = circle.radius;
                region.slope = circle.slope;
                region.rms_mm = circle.surface_rms();
                region.origin = circle.origin;
                if (!chamfer.ends.empty()) {
                    const std::string why = bend_onto(model, region, square_facets, chamfer.cone_faces, square_planes, ring, limits, eligible.empty());
                    if (!why.empty()) {
                        refuse("its wall goes on into a ring that is not made a cone meeting it: " + why);
                        continue;
                    }
                }

                // Each plane must meet the region along one whole loop of its own.
                bool whole_loops = true;
                for (int i = 0; i < 2 && whole_loops; ++i) {
                    const BrepFace& plane = model.faces[region.planes[i]];
                    size_t loops_met = 0;
                    for (size_t w = 0; w < plane.wires.size(); ++w) {
                        size_t shared = 0;
                        for (int e : plane.wires[w]) {
                            const auto& along = faces_of_edge[size_t(std::abs(e) - 1)];
                            shared += std::any_of(along.begin(), along.end(), in_region) ? 1 : 0;
                        }
                        if (shared == 0) continue;
                        ++loops_met;
                        if (shared != plane.wires[w].size()) whole_loops = false;
                        region.wires[i] = w;
                    }
                    if (loops_met != 1) whole_loops = false;
                }
                if (!whole_loops) {
                    refuse("they do not meet each plane along one whole loop of it");
                    continue;
                }
                // The circle replaces a loop of a plane: it must keep clear of the plane's other loops
                // (their vertices not within twice the merge distance of it), or the face would cross itself.
                std::string crossing;
                for (int i = 0; i < 2 && crossing.empty(); ++i) {
                    const BrepFace& plane = model.faces[region.planes[i]];
                    for (size_t w = 0; w < plane.wires.size() && crossing.empty(); ++w) {
                        if (w == region.wires[i]) continue;
                        for (int e : plane.wires[w]) {
                            const BrepEdge& edge = model.edges[size_t(std::abs(e) - 1)];
                            for (int v : edge.chain.empty() ? std::vector<int>{edge.start, edge.end} : edge.chain) {
                                const cv::Vec3d offset = model.vertices[size_t(v)] - region.origin;
                                const double height = offset.dot(region.axis), from_axis = cv::norm(offset - height * region.axis);
                                if (std::abs(from_axis - region.radius_at(height)) <= 2 * distance_limit)
                                    crossing = point_text(model.vertices[size_t(v)]);
                            }
                        }
                    }
                }
                if (!crossing.empty()) {
                    refuse("its circle would touch another boundary of its plane near " + crossing + " mm");
                    continue;
                }
                const BrepFace& second = model.faces[region.planes[1]];
                const double tilt = cv::norm(region.axis.cross(cv::normalize(second.normal)));
                const double second_radius = region.radius_at(level_of(second, region.origin, region.axis));
                if (std::max(region.radius_mm, second_radius) * tilt > distance_limit) {
                    std::snprintf(text, sizeof text, "its planes are %.3f degrees from parallel: a circle on one is %.4f mm off the other "
                                  "(at most %.4f mm)", std::asin(std::min(1.0, tilt)) * 180 / kPi,
                                  std::max(region.radius_mm, second_radius) * tilt, distance_limit);
                    refuse(text);
                    continue;
                }

                // A hole when the facets face the axis.
                double outwards = 0;
                for (size_t f : members)
                    for (const cv::Vec3i& t : model.faces[f].triangles) {
                        const cv::Vec3d &a = model.vertices[size_t(t[0])], &b = model.vertices[size_t(t[1])], &c = model.vertices[size_t(t[2])];
                        const cv::Vec3d area = (b - a).cross(c - a), centre = (a + b + c) / 3.0 - region.origin;
                        outwards += area.dot(centre - centre.dot(region.axis) * region.axis);
                    }
                region.hole = outwards < 0;
                const Loops loops = loops_of(model, region);
                if (!(loops.length > distance_limit)) {
                    refuse("its planes are not apart along the axis");
                    continue;
                }
                if (!(std::min(region.radius_at(loops.low_level), region.radius_at(loops.low_level + loops.length)) > distance_limit)) {
                    refuse("its cone reaches its apex between its planes");
                    continue;
                }
                // Each plane's loop must run the way its circle will: around its face's outside counter-
                // clockwise (seen from outside), around a hole clockwise.
                bool consistent = true;
                for (int i = 0; i < 2; ++i) {
                    const BrepFace& plane = model.faces[region.planes[i]];
                    cv::Vec3d area(0, 0, 0);
                    for (int e : plane.wires[region.wires[i]]) {
                        const BrepEdge& edge = model.edges[size_t(std::abs(e) - 1)];
                        const cv::Vec3d &a = model.vertices[size_t(e > 0 ? edge.start : edge.end)],
                                        &b = model.vertices[size_t(e > 0 ? edge.end : edge.start)];
                        area += a.cross(b);
                    }
                    const bool loop_counter_clockwise = area.dot(plane.normal) > 0;
                    const bool circle_counter_clockwise = region.axis.dot(plane.normal) > 0;
                    const int sign = loop_counter_clockwise == circle_counter_clockwise ? 1 : -1;
                    consistent = consistent && sign == loops.plane_sign[i];
                }
                if (!consistent) {
                    refuse("its loops on the planes run the wrong way for a cylinder between them");
                    continue;
                }
                regions.push_back(region);
            }
        }
    }
    // A wall along no planar face's normal (its ends are not planar faces: the planar merge left
    // them triangles, or they are not flat) was not looked at above. Each piece of the surface left
    // (the faces of no wall found above) whose facets within 15 degrees of square to one of the main
    // directions of its facets' normals lie near a cylinder about it, all round it, is said in `notes`.
    if (!eligible.empty()) return regions;
    // Whether a face's normal is known to within 15 degrees: a planar face's, or a facet's whose
    // shortest altitude is 2 sigma / sin(15 degrees) or more (not the narrow facets at a point).
    auto normal_known = [&](size_t f) {
        if (model.faces[f].merged) return true;
        const cv::Vec3i& t = model.faces[f].triangles[0];
        const cv::Vec3d &a = model.vertices[size_t(t[0])], &b = model.vertices[size_t(t[1])], &c = model.vertices[size_t(t[2])];
        const double longest = std::max({cv::norm(b - a), cv::norm(c - b), cv::norm(a - c)});
        return longest > 0 && cv::norm((b - a).cross(c - a)) / longest * kSquareToAxis >= 2 * model.noise_mm;
    };
    std::vector<char> seen_face(face_count, 0);
    for (size_t start = 0; start < face_count; ++start) {
        if (seen_face[start] || taken[start] || !one_facet(start)) continue;
        std::vector<size_t> piece{start};
        seen_face[start] = 1;
        for (size_t next = 0; next < piece.size(); ++next)
            for (size_t g : neighbours(piece[next]))
                if (!seen_face[g] && !taken[g] && allowed(g)) {
                    seen_face[g] = 1;
                    piece.push_back(g);
                }
        size_t facets = 0;
        cv::Matx33d spread = cv::Matx33d::zeros();
        for (size_t f : piece)
            for (const cv::Vec3i& t : model.faces[f].triangles) {
                const cv::Vec3d &a = model.vertices[size_t(t[0])], &b = model.vertices[size_t(t[1])], &c = model.vertices[size_t(t[2])];
                const cv::Vec3d area = (b - a).cross(c - a);
                const double twice_area = cv::norm(area);
                if (twice_area > 0) spread += (area * area.t()) * (0.5 / twice_area);
                ++facets;
            }
        if (int(facets) < options.min_facets) continue;
        cv::Mat values, directions;
        cv::eigen(cv::Mat(spread), values, directions);
        for (int k = 0; k < 3; ++k) {
            const cv::Vec3d axis = cv::normalize(cv::Vec3d(directions.at<double>(k, 0), directions.at<double>(k, 1), directions.at<double>(k, 2)));
            std::vector<size_t> wall_faces;
            size_t wall_facets = 0;
            for (size_t f : piece)
                if (std::abs(cv::normalize(model.faces[f].normal).dot(axis)) < kSquareToAxis && normal_known(f)) {
                    wall_faces.push_back(f);
                    wall_facets += model.faces[f].triangles.size();
                }
            if (int(wall_facets) < options.min_facets) continue;
            const std::vector<int> wall_vertices = vertices_of(model, wall_faces);
            const Circle2 circle = circle_along(model, wall_vertices, model.vertices[size_t(wall_vertices[0])], axis);
            if (!(circle.radius > 0) || !(circle.rms < 0.05 * circle.radius) || !all_round(model, wall_vertices, circle, axis)) continue;
            char text[400];
            std::snprintf(text, sizeof text, "%zu facets near a cylinder of radius %.3f mm (RMS %.4f mm) about the axis through %s along %s "
                          "stay as they were: no planar face square to its axis (the planar merge left its ends as triangles, "
                          "or they are not flat)", wall_facets, circle.radius, circle.rms, point_text(circle.origin).c_str(),
                          point_text(axis).c_str());
            notes.push_back(text);
            break;
        }
    }
    return regions;
}

void add_cylinder_faces(PlanarFaceModel& model, const std::vector<CylinderRegion>& regions) {
    std::vector<char> replaced(model.faces.size(), 0);
    std::vector<BrepFace> cylinders;
    for (const CylinderRegion& region : regions) {
        const Loops loops = loops_of(model, region);
        // The circles along the axis, low to high: one on each plane and, bent, the one the two faces share.
        std::vector<double> levels{loops.low_level, loops.low_level + loops.length};
        if (region.bent) levels.insert(levels.begin() + 1, region.bend_level);
        std::vector<int> circle_edges, circle_vertices;
        for (size_t k = 0; k < levels.size(); ++k) {
            const cv::Vec3d centre = region.origin + levels[k] * region.axis;
            const double radius = region.radius_at(levels[k]);
            const int vertex = int(model.vertices.size());
            model.vertices.push_back(centre + radius * region.x_axis);
            BrepEdge circle;
            circle.start = circle.end = vertex;
            circle.radius_mm = radius;
            circle.center = centre;
            circle.axis = region.axis;
            circle.x_axis = region.x_axis;
            if (k == 0 || k + 1 == levels.size()) {
                // On a plane, in the plane square to the axis; its tolerance covers the plane it is in
                // (tilted from that by at most the limit cylinder_regions allows).
                const size_t end = k == 0 ? loops.low : 1 - loops.low;
                const BrepFace& plane = model.faces[region.planes[end]];
                const double off_plane = std::abs((centre - plane.origin).dot(plane.normal)) +
                                         radius * cv::norm(region.axis.cross(cv::normalize(plane.normal)));
                circle.tolerance_mm = off_plane * 1.01 + 1e-7;
                model.edges.push_back(circle);
                model.faces[region.planes[end]].wires[region.wires[end]] = {loops.plane_sign[end] * int(model.edges.size())};
                model.faces[region.planes[end]].triangles.clear();
            } else {
                model.edges.push_back(circle);  // on both faces' surfaces, where they meet
            }
            circle_edges.push_back(int(model.edges.size()));
            circle_vertices.push_back(vertex);
            model.vertex_tolerance_mm.push_back(std::max(1e-7, circle.tolerance_mm));
        }
        // One face between each two circles (the wall's facets counted on the piece their centres are in).
        for (size_t k = 0; k + 1 < levels.size(); ++k) {
            model.edges.push_back({circle_vertices[k], circle_vertices[k + 1], 1e-7, {}});
            const int seam = int(model.edges.size());
            const double middle = 0.5 * (levels[k] + levels[k + 1]), slope = region.slope_at(middle);
            BrepFace face;
            face.origin = region.origin + levels[k] * region.axis;
            face.normal = region.axis;
            face.facet_count = 0;
            for (size_t f : region.faces)
                for (const cv::Vec3i& t : model.faces[f].triangles) {
                    const double level = ((model.vertices[size_t(t[0])] + model.vertices[size_t(t[1])] + model.vertices[size_t(t[2])]) / 3.0 -
                                          region.origin).dot(region.axis);
                    face.facet_count += region.beyond_bend(level) == region.beyond_bend(middle) ? 1 : 0;
                }
            face.rms_mm = region.rms_mm;
            face.radius_mm = region.radius_at(levels[k]);
            face.semi_angle_rad = std::atan(slope);
            face.x_axis = region.x_axis;
            face.reversed = region.hole;
            face.wires = {{circle_edges[k], seam, -circle_edges[k + 1], -seam}};
            cylinders.push_back(face);
            if (slope != 0) {
                ++model.cone_faces;
                model.cone_facets += size_t(face.facet_count);
            } else {
                ++model.cylinder_faces;
                model.cylinder_facets += size_t(face.facet_count);
            }
        }
        for (size_t f : region.faces) {
            if (model.faces[f].merged) {  // a strip of its wall
                --model.merged_faces;
                model.merged_facets -= size_t(model.faces[f].facet_count);
            }
            replaced[f] = 1;
        }
        model.cylinder_end_facets += region.end_facets;
        model.cylinder_end_mm = std::max(model.cylinder_end_mm, region.end_mm);
        model.cylinder_end_volume_mm3 += region.end_volume_mm3;
    }
    std::vector<BrepFace> faces;
    for (size_t f = 0; f < model.faces.size(); ++f)
        if (!replaced[f]) faces.push_back(std::move(model.faces[f]));
    faces.insert(faces.end(), cylinders.begin(), cylinders.end());
    model.faces = std::move(faces);

    // Only the edges some face still runs along stay.
    std::vector<int> renumbered(model.edges.size(), 0);
    for (const BrepFace& face : model.faces)
        for (const auto& wire : face.wires)
            for (int e : wire) renumbered[size_t(std::abs(e) - 1)] = 1;
    std::vector<BrepEdge> edges;
    for (size_t e = 0; e < model.edges.size(); ++e)
        if (renumbered[e]) {
            edges.push_back(std::move(model.edges[e]));
            renumbered[e] = int(edges.size());
        }
    model.edges = std::move(edges);
    for (BrepFace& face : model.faces)
        for (auto& wire : face.wires)
            for (int& e : wire) e = e > 0 ? renumbered[size_t(e - 1)] : -renumbered[size_t(-e - 1)];
}

}  // namespace picoscan::detail
