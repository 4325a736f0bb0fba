// Sharp edges and corners restored on the Poisson mesh. Poisson's implicit function is smooth,
// so a convex edge comes out rounded and a concave one filled, by about a triangle; moving each
// vertex onto the plane of its nearest points (project_onto_points) restores the faces but
// not the edge itself, since no vertex lies on it. Here the planes are found in the points,
// the mesh is split where it crosses the line two planes meet on (the bisector of the two
// planes decides which side a point belongs to), and the split vertices are put on that line.
#include "mesh/sharpen.h"
#include "register/point_grid.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <opencv2/core.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <numeric>
#include <set>
#include <map>
#include <unordered_map>

namespace picoscan::detail {

namespace {

// A plane, or a cylinder (a hole's wall, a boss).
struct Plane {
    bool cylinder = false;
    cv::Vec3d normal;   // plane: unit, outwards (as the points' normals)
    double offset = 0;  // plane: normal . x on it
    cv::Vec3d axis, centre;  // cylinder: unit axis, a point on it
    double radius = 0;
    int outwards = 1;        // cylinder: +1 when the outside is away from the axis (a boss), -1 (a hole)
    double low = 0, high = 0;  // cylinder: the extent of its points along the axis
    cv::Vec3d radial(const cv::Vec3d& x) const {
        cv::Vec3d r = x - centre;
        r -= axis * axis.dot(r);
        const double length = cv::norm(r);
        return length > 1e-12 ? r * (1.0 / length) : cv::Vec3d(0, 0, 0);
    }
    double distance(const cv::Vec3d& x) const {
        if (!cylinder) return normal.dot(x) - offset;
        cv::Vec3d r = x - centre;
        r -= axis * axis.dot(r);
        return outwards * (cv::norm(r) - radius);
    }
    cv::Vec3d project(const cv::Vec3d& x) const {
        if (!cylinder) return x - distance(x) * normal;
        return centre + axis * axis.dot(x - centre) + radius * radial(x);
    }
    cv::Vec3d normal_at(const cv::Vec3d& x) const { return cylinder ? outwards * radial(x) : normal; }
};

double degrees_between(const cv::Vec3d& a, const cv::Vec3d& b) {
    return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180.0 / CV_PI;
}

// Least-squares plane through points (their normals say which way is out); false when too few.
bool fit_plane(const std::vector<cv::Vec3d>& positions, const std::vector<int>& members, const cv::Vec3d& outwards,
               Plane& plane) {
    if (members.size() < 3) return false;
    cv::Vec3d centre(0, 0, 0);
    for (int i : members) centre += positions[i];
    centre *= 1.0 / double(members.size());
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (int i : members) scatter += (positions[i] - centre) * (positions[i] - centre).t();
    cv::Matx31d values;
    cv::Matx33d vectors;
    cv::eigen(scatter, values, vectors);
    cv::Vec3d normal(vectors(2, 0), vectors(2, 1), vectors(2, 2));
    if (normal.dot(outwards) < 0) normal = -normal;
    plane.normal = normal;
    plane.offset = normal.dot(centre);
    return true;
}

// Planes meeting at an angle of at least this are an edge; below it (and above
// kSamePlaneDeg) the region is ambiguous (a gently bent or curved surface): left alone.
constexpr double kSharpEdgeDeg = 25;
constexpr double kSamePlaneDeg = 5;
// A region is a plane when the median angle between its points' normals and its plane's is
// below this (a curved wall cut into strips is not: its normals fan out across the strip).
constexpr double kFlatRegionDeg = 3;
constexpr double kGrowNormalDeg = 15;
constexpr size_t kLeastRegionPoints = 100;  // a gently curved surface makes small plane-like patches
// Share of the points around a vertex that must lie on its planes for the edge to be sharpened
// (a fillet's points lie between them).
constexpr double kLeastAgreement = 0.9;
// Whether the points around a vertex agree with its model: that share of them on its surfaces,
// or all but one among five or more (a fillet puts many off; of the 8 points beside a hole's
// wall seen only near its top, one stray 0.19 mm off failed the 90 %, and the wall stayed as
// Poisson bulged it, 229 um into the material on the speckled two-placement model).
bool points_agree(size_t on, size_t all) {
    return all > 0 && (double(on) >= kLeastAgreement * double(all) || (all >= 5 && on + 1 >= all));
}
// Points within this of the line where two surfaces meet count as on them: a camera pixel at
// the edge sees both faces, so the points there cut a convex edge (or fill a concave one) by
// up to about 0.45 mm (the half-resolution seed camera: 0.37-0.44 mm from the line where two
// faces meet, 0.1-0.4 mm off each face). A fillet's middle lies 0.41 of its radius from that
// line: fillets of 1.2 mm radius and more stay round.
constexpr double kEdgeBlurMm = 0.5;
// The blur's tail: from kEdgeBlurMm to twice as far from the line, a pixel's footprint still
// takes a little of the other face, and the points there lie off their own face by up to this
// many times the agreement (the speckled two-placement model's block edges: 0.050-0.077 mm off
// at 0.50-0.66 mm from the line, 3-4 of the ~30 points near a vertex, which left the edge's
// vertices with no model and the edge as Poisson rounded it). A fillet of 1.2 mm radius lies
// off its faces by more than that for most of its width within the tail.
constexpr double kBlurTailOff = 2;
// A filled-in vertex goes onto a hole's wall only when its surface faces the hole's axis
// (cosine of 75 degrees: a bulge Poisson made tilts its surface by tens of degrees).
constexpr double kHoleWallFacing = 0.25;

struct Regions {
    std::vector<Plane> planes;
    std::vector<int> label;  // per point: plane index or -1
    double tolerance = 0;    // mm: a point within this of a plane lies on it
};

// A cylinder through points: its axis across the normals (they are all square to it), then a
// circle fitted in the plane across the axis (Kasa's algebraic fit). False when the points are
// not on one (normals not square to one direction, or too far from the circle).
bool fit_cylinder(const std::vector<cv::Vec3d>& positions, const std::vector<cv::Vec3d>& normals,
                  const std::vector<int>& members, double tolerance, Plane& out) {
    cv::Matx33d spread = cv::Matx33d::zeros();
    for (int i : members) spread += normals[i] * normals[i].t();
    cv::Matx31d values;
    cv::Matx33d vectors;
    cv::eigen(spread * (1.0 / double(members.size())), values, vectors);
    // Square to the axis: the smallest spread is nearly none; round it: the normals turn a good
    // way (a strip of a plane is not a cylinder).
    if (values(2) > 0.02 || values(1) < 0.05) return false;
    const cv::Vec3d axis = cv::normalize(cv::Vec3d(vectors(2, 0), vectors(2, 1), vectors(2, 2)));
    const cv::Vec3d u = cv::normalize(axis.cross(std::abs(axis[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0)));
    const cv::Vec3d w = axis.cross(u);
    cv::Matx33d normal_matrix = cv::Matx33d::zeros();
    cv::Vec3d rhs(0, 0, 0);
    const cv::Vec3d origin = positions[members[0]];
    for (int i : members) {
        const cv::Vec3d d = positions[i] - origin;
        const double x = d.dot(u), y = d.dot(w);
        const cv::Vec3d row(x, y, 1);
        normal_matrix += row * row.t();
        rhs += row * (-(x * x + y * y));
    }
    if (std::abs(cv::determinant(normal_matrix)) < 1e-12) return false;
    const cv::Vec3d solution = normal_matrix.solve(rhs, cv::DECOMP_LU);
    const double cx = -solution[0] / 2, cy = -solution[1] / 2, r2 = cx * cx + cy * cy - solution[2];
    if (!(r2 > 0)) return false;
    out = Plane{};
    out.cylinder = true;
    out.axis = axis;
    out.centre = origin + cx * u + cy * w;
    out.radius = std::sqrt(r2);
    out.outwards = 1;
    double facing = 0;
    size_t near = 0;
    // Kasa's fit is biased by noise on a partly seen wall: refined by Gauss-Newton on the
    // distances from the cylinder (its axis tilted, moved and its radius), over the points near it.
    for (int iteration = 0; iteration < 8; ++iteration) {
        const cv::Vec3d a = out.axis;
        const cv::Vec3d e1 = cv::normalize(a.cross(std::abs(a[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0)));
        const cv::Vec3d e2 = a.cross(e1);
        auto moved = [&](const cv::Vec<double, 5>& d) {
            Plane c = out;
            c.axis = cv::normalize(a + d[0] * e1 + d[1] * e2);
            c.centre = out.centre + d[2] * e1 + d[3] * e2;
            c.radius = out.radius + d[4];
            return c;
        };
        cv::Matx<double, 5, 5> jtj = cv::Matx<double, 5, 5>::zeros();
        cv::Vec<double, 5> jtr(0, 0, 0, 0, 0);
        const double step = 1e-6;
        for (int i : members) {
            const double r = out.outwards * out.distance(positions[i]);  // outwards is 1 here
            if (std::abs(r) > 3 * tolerance) continue;
            cv::Vec<double, 5> row;
            for (int k = 0; k < 5; ++k) {
                cv::Vec<double, 5> d(0, 0, 0, 0, 0);
                d[k] = step;
                row[k] = (moved(d).distance(positions[i]) - r) / step;
            }
            jtj += row * row.t();
            jtr += row * r;
        }
        if (std::abs(cv::determinant(jtj)) < 1e-30) break;
        const cv::Vec<double, 5> delta = jtj.solve(-jtr, cv::DECOMP_LU);
        out = moved(delta);
    }
    out.low = 1e30;
    out.high = -1e30;
    for (int i : members) {
        facing += normals[i].dot(out.radial(positions[i]));
        out.outwards = 1;
        if (std::abs(out.distance(positions[i])) < 2 * tolerance) ++near;
        const double along = out.axis.dot(positions[i] - out.centre);
        out.low = std::min(out.low, along);
        out.high = std::max(out.high, along);
    }
    out.outwards = facing >= 0 ? 1 : -1;
    // Most of the points within twice the tolerance (a wall seen at a grazing angle is noisier
    // than a face seen square on).
    return double(near) >= 0.8 * double(members.size());
}

// Curved walls: the points no plane took, grown into smooth regions (neighbours' normals within
// a few degrees of each other), each kept when it is a cylinder; then, as for the planes, the
// points beside it that lie on it join.
void add_cylinders(const std::vector<cv::Vec3d>& positions, const std::vector<cv::Vec3d>& normals, const PointGrid& grid,
                   double radius, Regions& regions) {
    const size_t n = positions.size();
    const double smooth = std::cos(10.0 * CV_PI / 180.0);
    std::vector<int> region(n, -1), near, members;
    for (size_t seed = 0; seed < n; ++seed) {
        if (regions.label[seed] >= 0 || region[seed] >= 0) continue;
        members.clear();
        std::deque<int> queue{static_cast<int>(seed)};
        region[seed] = static_cast<int>(seed);
        while (!queue.empty()) {
            const int i = queue.front();
            queue.pop_front();
            members.push_back(i);
            grid.within(positions[i], radius, near);
            for (int k : near) {
                if (regions.label[k] >= 0 || region[k] >= 0 || normals[k].dot(normals[i]) < smooth) continue;
                region[k] = static_cast<int>(seed);
                queue.push_back(k);
            }
        }
        if (members.size() < 3 * kLeastRegionPoints) continue;
        Plane cylinder;
        if (!fit_cylinder(positions, normals, members, regions.tolerance, cylinder)) continue;
        const int id = static_cast<int>(regions.planes.size());
        regions.planes.push_back(cylinder);
        std::deque<int> grow;
        for (int k : members)
            if (std::abs(cylinder.distance(positions[k])) < regions.tolerance) {
                regions.label[k] = id;
                grow.push_back(k);
            }
        while (!grow.empty()) {
            const int i = grow.front();
            grow.pop_front();
            grid.within(positions[i], radius, near);
            for (int k : near) {
                if (regions.label[k] >= 0 || std::abs(cylinder.distance(positions[k])) > regions.tolerance) continue;
                regions.label[k] = id;
                grow.push_back(k);
                // Its extent: the points that joined it too (a wall's last points before an edge).
                Plane& grown = regions.planes[id];
                const double along = grown.axis.dot(positions[k] - grown.centre);
                grown.low = std::min(grown.low, along);
                grown.high = std::max(grown.high, along);
            }
        }
    }
}

// A face grown as several regions (patches whose growth stopped at noisier points between
// them) is one plane: regions whose planes are within 2 degrees and whose points lie within the
// tolerance of each other's plane are merged, and the plane refitted to all their points.
void merge_coplanar(const std::vector<cv::Vec3d>& positions, Regions& regions) {
    const size_t count = regions.planes.size();
    std::vector<std::vector<int>> members(count);
    for (size_t i = 0; i < positions.size(); ++i)
        if (regions.label[i] >= 0) members[regions.label[i]].push_back(static_cast<int>(i));
    std::vector<cv::Vec3d> centre(count, cv::Vec3d(0, 0, 0));
    for (size_t p = 0; p < count; ++p) {
        for (int i : members[p]) centre[p] += positions[i];
        if (!members[p].empty()) centre[p] *= 1.0 / double(members[p].size());
    }
    std::vector<int> root(count);
    std::iota(root.begin(), root.end(), 0);
    auto find = [&](int p) {
        while (root[p] != p) p = root[p] = root[root[p]];
        return p;
    };
    for (size_t a = 0; a < count; ++a)
        for (size_t b = a + 1; b < count; ++b) {
            const Plane &pa = regions.planes[a], &pb = regions.planes[b];
            if (degrees_between(pa.normal, pb.normal) < 2 && std::abs(pa.distance(centre[b])) < regions.tolerance &&
                std::abs(pb.distance(centre[a])) < regions.tolerance)
                root[find(static_cast<int>(b))] = find(static_cast<int>(a));
        }
    std::vector<int> renumber(count, -1);
    std::vector<Plane> planes;
    std::vector<std::vector<int>> merged;
    for (size_t p = 0; p < count; ++p) {
        const int r = find(static_cast<int>(p));
        if (renumber[r] < 0) {
            renumber[r] = static_cast<int>(planes.size());
            planes.push_back(regions.planes[r]);
            merged.emplace_back();
        }
        renumber[p] = renumber[r];
        merged[renumber[p]].insert(merged[renumber[p]].end(), members[p].begin(), members[p].end());
    }
    for (size_t p = 0; p < planes.size(); ++p) fit_plane(positions, merged[p], planes[p].normal, planes[p]);
    for (int& label : regions.label)
        if (label >= 0) label = renumber[label];
    regions.planes = std::move(planes);
}

// Region growing over the points: from the flattest points outwards, a neighbour joins when its
// normal is within kGrowNormalDeg of the region's and it lies within the tolerance of the
// region's plane (refitted as the region grows). The tolerance comes from the noise of the
// flattest neighbourhoods.
Regions find_planes(const std::vector<cv::Vec3d>& positions, const std::vector<cv::Vec3d>& normals,
                    const PointGrid& grid, double radius) {
    const size_t n = positions.size();
    Regions regions;
    regions.label.assign(n, -1);
    std::vector<double> spread(n, 1.0);
    std::vector<int> near;
    for (size_t i = 0; i < n; ++i) {
        grid.within(positions[i], radius, near);
        if (near.size() < 6) continue;
        double worst = 0;
        for (int k : near) worst = std::max(worst, 1 - normals[i].dot(normals[k]));
        spread[i] = worst;
    }
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return spread[a] < spread[b]; });
    const double flat = 1 - std::cos(kFlatRegionDeg * CV_PI / 180.0);
    // Noise: the rms distance from their own plane of the flattest neighbourhoods.
    std::vector<double> noise;
    for (size_t s = 0; s < n && noise.size() < 200; s += 7) {
        const int i = order[s];
        if (spread[i] > flat) break;
        grid.within(positions[i], radius, near);
        Plane plane;
        if (!fit_plane(positions, near, normals[i], plane)) continue;
        double sum = 0;
        for (int k : near) sum += std::pow(plane.distance(positions[k]), 2);
        noise.push_back(std::sqrt(sum / double(near.size())));
    }
    if (noise.empty()) return regions;
    std::nth_element(noise.begin(), noise.begin() + long(noise.size() / 2), noise.end());
    regions.tolerance = std::clamp(6 * noise[noise.size() / 2], 0.02, 0.12);

    const double grow = std::cos(kGrowNormalDeg * CV_PI / 180.0);
    std::vector<uint8_t> tried(n, 0);
    std::vector<int> members;
    for (int seed : order) {
        if (spread[seed] > flat) break;
        if (regions.label[seed] >= 0 || tried[seed]) continue;
        tried[seed] = 1;
        Plane plane;
        grid.within(positions[seed], radius, near);
        members.clear();
        for (int k : near)
            if (regions.label[k] < 0 && normals[k].dot(normals[seed]) > grow) members.push_back(k);
        if (!fit_plane(positions, members, normals[seed], plane)) continue;
        const int id = static_cast<int>(regions.planes.size());
        members.clear();
        std::deque<int> queue{seed};
        regions.label[seed] = id;
        size_t fitted = 1;
        while (!queue.empty()) {
            const int i = queue.front();
            queue.pop_front();
            members.push_back(i);
            if (members.size() >= 2 * fitted && members.size() >= 20) {
                fit_plane(positions, members, plane.normal, plane);
                fitted = members.size();
            }
            grid.within(positions[i], radius, near);
            for (int k : near) {
                if (regions.label[k] >= 0 || normals[k].dot(plane.normal) < grow ||
                    std::abs(plane.distance(positions[k])) > regions.tolerance)
                    continue;
                regions.label[k] = id;
                queue.push_back(k);
            }
        }
        fit_plane(positions, members, plane.normal, plane);
        std::vector<double> angles;
        angles.reserve(members.size());
        for (int k : members) angles.push_back(degrees_between(normals[k], plane.normal));
        std::nth_element(angles.begin(), angles.begin() + long(angles.size() / 2), angles.end());
        if (members.size() < kLeastRegionPoints || angles[angles.size() / 2] > kFlatRegionDeg) {
            for (int k : members) {
                regions.label[k] = -1;
                tried[k] = 1;
            }
            continue;
        }
        regions.planes.push_back(plane);
    }
    merge_coplanar(positions, regions);
    // Parts of a face the growing did not reach (cut off from its region by a band of noisier
    // points) join it when they lie on its plane and face its way.
    for (size_t i = 0; i < n; ++i) {
        if (regions.label[i] >= 0) continue;
        double nearest = regions.tolerance;
        for (size_t p = 0; p < regions.planes.size(); ++p) {
            const double d = std::abs(regions.planes[p].distance(positions[i]));
            if (d < nearest && normals[i].dot(regions.planes[p].normal) > grow) {
                nearest = d;
                regions.label[i] = static_cast<int>(p);
            }
        }
    }
    // The points beside a region whose normals the edge blended (PCA over neighbours of both
    // faces) but which lie on its plane join it: outwards from the regions, by distance alone,
    // within twice the tolerance (the points at an edge are noisier than a face's middle).
    std::deque<int> queue;
    for (size_t i = 0; i < n; ++i)
        if (regions.label[i] >= 0) queue.push_back(static_cast<int>(i));
    while (!queue.empty()) {
        const int i = queue.front();
        queue.pop_front();
        const Plane& plane = regions.planes[regions.label[i]];
        grid.within(positions[i], 1.5 * radius, near);  // across the thinning's gaps between rows
        for (int k : near) {
            if (regions.label[k] >= 0 || std::abs(plane.distance(positions[k])) > 2 * regions.tolerance) continue;
            regions.label[k] = regions.label[i];
            queue.push_back(k);
        }
    }
    add_cylinders(positions, normals, grid, radius, regions);
    return regions;
}

// The point on the line (or curve) where surfaces a and b meet nearest to x; false when they
// are nearly parallel there.
bool onto_line(const Plane& a, const Plane& b, const cv::Vec3d& x, cv::Vec3d& out) {
    if (!a.cylinder && !b.cylinder) {
        cv::Vec3d direction = a.normal.cross(b.normal);
        if (cv::norm(direction) < 0.2) return false;
        direction = cv::normalize(direction);
        const cv::Matx33d m(a.normal[0], a.normal[1], a.normal[2], b.normal[0], b.normal[1], b.normal[2], direction[0],
                            direction[1], direction[2]);
        out = cv::Vec3d(m.inv() * cv::Vec3d(a.offset, b.offset, direction.dot(x)));
        return true;
    }
    // A cylinder: alternating projections (they converge where the surfaces cross at an angle).
    cv::Vec3d y = x;
    for (int i = 0; i < 40; ++i) y = b.project(a.project(y));
    if (std::abs(a.distance(y)) > 1e-3 || std::abs(b.distance(y)) > 1e-3) return false;
    if (cv::norm(a.normal_at(y).cross(b.normal_at(y))) < 0.2) return false;
    out = y;
    return true;
}

// How far x lies from the line where surfaces a and b meet, from its distances to both (exact
// for planes; a cylinder by its tangent plane at x); infinite when they are nearly parallel.
double from_line(const Plane& a, const Plane& b, const cv::Vec3d& x) {
    const double cosine = a.normal_at(x).dot(b.normal_at(x));
    if (std::abs(cosine) > 0.98) return std::numeric_limits<double>::infinity();
    const double da = a.distance(x), db = b.distance(x);
    return std::sqrt(std::max(0.0, (da * da + db * db - 2 * cosine * da * db) / (1 - cosine * cosine)));
}

// The point where three planes meet; false when they do not meet in one well-defined point.
bool corner_of(const Plane& a, const Plane& b, const Plane& c, cv::Vec3d& out) {
    if (a.cylinder || b.cylinder || c.cylinder) return false;
    const cv::Matx33d m(a.normal[0], a.normal[1], a.normal[2], b.normal[0], b.normal[1], b.normal[2], c.normal[0],
                        c.normal[1], c.normal[2]);
    if (std::abs(cv::determinant(m)) < 0.2) return false;
    out = cv::Vec3d(m.inv() * cv::Vec3d(a.offset, b.offset, c.offset));
    return true;
}

// What the points say around one vertex.
struct VertexPlanes {
    std::array<int, 3> plane{-1, -1, -1};  // the planes near it (the sharp model), first = its own
    int count = 0;
    // For each other plane: the side of it (+1, -1) the own plane's points lie on, 0 when both
    // (an L-shaped face past a corner).
    std::array<int, 3> side{0, 0, 0};
    bool has(int p) const { return std::find(plane.begin(), plane.begin() + count, p) != plane.begin() + count; }
};

// A vertex of a rounded edge onto its own plane. Straight along the plane's normal, the thin
// strip of faces along the edge, nearly square to the plane, folds wherever Poisson's surface
// turns a little past square (its order across the edge is scrambled); along the sum of the
// normals of the plane and of those it meets at an edge (square to the edge), a face
// keeps its way round unless it faces more than 90 degrees away from that direction, and a
// vertex on the bisector goes onto the line from either side.
cv::Vec3d onto_own_plane(const Regions& regions, const VertexPlanes& vp, const cv::Vec3d& x) {
    const Plane& own = regions.planes[vp.plane[0]];
    if (own.cylinder) return own.project(x);
    cv::Vec3d direction = own.normal;
    for (int c = 1; c < vp.count; ++c) {
        const Plane& other = regions.planes[vp.plane[c]];
        const double angle = degrees_between(own.normal, other.normal);
        if (!other.cylinder && angle >= kSharpEdgeDeg && angle < 120) direction += other.normal;  // not a thin wall's far side
    }
    return x - own.distance(x) / own.normal.dot(direction) * direction;
}

constexpr double kOnPlaneMm = 1e-4;
// A vertex pulled back to unfold a face goes this far past where the face lies flat.
constexpr double kUnfoldMarginMm = 0.01;

// The plane a face's three corners all go onto (one of them put on the plane alone, the others
// on it or on its lines and corners), or -1.
int on_one_plane(const cv::Vec3i& face, const Regions& regions, const std::vector<int>& surface_of,
                 const std::vector<cv::Vec3d>& target) {
    int s = -1;
    for (int k = 0; k < 3 && s < 0; ++k) s = surface_of[face[k]];
    if (s < 0 || regions.planes[s].cylinder) return -1;
    for (int k = 0; k < 3; ++k)
        if (std::abs(regions.planes[s].distance(target[face[k]])) > kOnPlaneMm) return -1;
    return s;
}

// Faces whose three corners all go onto one plane but come out turned over in it (a sliver
// along an edge whose corners the projection put in another order across it, or a cut merged
// with its neighbour): pulling their corners back cannot unfold a face that was already folded
// where they came from, and leaves the edge as Poisson rounded it. Their corners that lie on the
// plane alone (not on a line or a corner) are moved within the plane, each to the mean of its
// neighbours on the plane, until no face on the plane is turned over: the surface stays where
// the points put it, only the triangles are untangled.
void untangle_on_planes(const std::vector<cv::Vec3i>& faces, const Regions& regions, const std::vector<cv::Vec3d>& safe,
                        const std::vector<int>& surface_of, double longest_move, std::vector<cv::Vec3d>& target) {
    auto turned_over_on = [&](const cv::Vec3i& face) {
        const int s = on_one_plane(face, regions, surface_of, target);
        if (s < 0) return -1;
        const cv::Vec3d normal = (target[face[1]] - target[face[0]]).cross(target[face[2]] - target[face[0]]);
        return normal.dot(regions.planes[s].normal) < 0 ? s : -1;
    };
    std::vector<std::vector<int>> ring;
    for (int round = 0; round < 20; ++round) {
        std::vector<int> tangled;
        for (const cv::Vec3i& face : faces) {
            const int s = turned_over_on(face);
            for (int k = 0; s >= 0 && k < 3; ++k)
                if (surface_of[face[k]] == s) tangled.push_back(face[k]);
        }
        if (tangled.empty()) return;
        if (ring.empty()) {
            ring.resize(target.size());
            for (const cv::Vec3i& face : faces)
                for (int k = 0; k < 3; ++k) {
                    ring[face[k]].push_back(face[(k + 1) % 3]);
                    ring[face[k]].push_back(face[(k + 2) % 3]);
                }
        }
        for (int v : tangled) {
            const Plane& plane = regions.planes[surface_of[v]];
            cv::Vec3d sum(0, 0, 0);
            int count = 0;
            for (int w : ring[v])
                if (std::abs(plane.distance(target[w])) < kOnPlaneMm) sum += target[w], ++count;
            if (count < 2) continue;
            const cv::Vec3d relaxed = plane.project(sum * (1.0 / count));
            if (cv::norm(relaxed - safe[v]) <= longest_move) target[v] = relaxed;
        }
    }
}

// A hole's wall (a cylinder facing its axis) and the turns about its axis at which its points
// were seen, at any depth: where a wall was seen at that turn it goes on round the hole there
// (a hole round at its mouth and flat further down on the side no view saw keeps its flat).
struct HoleWall {
    int surface = -1;  // index in Regions::planes
    cv::Vec3d e1, e2;  // square to the axis
    static constexpr int kTurns = 36;  // 10 degrees each
    std::array<int, kTurns> seen{};
    int turn_of(const Plane& hole, const cv::Vec3d& x) const {
        const cv::Vec3d r = x - hole.centre;
        const double angle = std::atan2(r.dot(e2), r.dot(e1));
        return std::clamp(int((angle + CV_PI) / (2 * CV_PI) * kTurns), 0, kTurns - 1);
    }
    bool seen_at(const Plane& hole, const cv::Vec3d& x) const { return seen[turn_of(hole, x)] >= 5; }
    bool rebuilt = false;  // its unseen wall triangulated anew on the cylinder (rebuild_hole_walls)
};

std::vector<HoleWall> hole_walls(const Regions& regions, const std::vector<cv::Vec3d>& positions) {
    std::vector<HoleWall> walls;
    for (size_t h = 0; h < regions.planes.size(); ++h) {
        const Plane& hole = regions.planes[h];
        if (!hole.cylinder || hole.outwards > 0) continue;
        HoleWall wall;
        wall.surface = int(h);
        wall.e1 = cv::normalize(hole.axis.cross(std::abs(hole.axis[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0)));
        wall.e2 = hole.axis.cross(wall.e1);
        for (size_t i = 0; i < regions.label.size(); ++i)
            if (regions.label[i] == int(h)) ++wall.seen[wall.turn_of(hole, positions[i])];
        walls.push_back(wall);
    }
    return walls;
}

// Walls of a hole that no view saw (filled in: too few points around the vertex), where
// Poisson narrowed the hole or bulged a pocket out into the material by a millimetre or two.
// The patch of guessed vertices goes where the fitted cylinder has support: at a turn about the
// axis where the wall was seen at some depth (HoleWall), along the axis between its seen
// wall's ends and on to the faces it opens on (within the reach), within half a radius of the
// wall; grown over the mesh from the vertices whose surface faces the axis (the faces the hole
// opens on face along it and are left alone). Moving such vertices onto the cylinder folds a
// pocket, however they are relaxed (its many vertices have a small place there); so the faces
// around them are cut out and the hole left is triangulated anew on the cylinder, between the
// vertices around it (which stay): unrolled by the conformal map (angle about the axis, and
// e^(along / radius) from it: a patch is a polygon, a band all round the hole a ring),
// constrained Delaunay with points about `spacing` apart inside, mapped back.
// The patch is left as Poisson made it when its rim does not unroll into simple loops, or the
// result is not a closed manifold or has more crossing faces than `crossing` (the count of the
// mesh as it comes in, kept up to date here). Returns the vertices made.
using CdtVertex = CGAL::Triangulation_vertex_base_with_info_2<int, Kernel>;  // mesh index, -1 new
using CdtFace = CGAL::Constrained_triangulation_face_base_2<Kernel, CGAL::Triangulation_face_base_with_info_2<int, Kernel>>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, CGAL::Triangulation_data_structure_2<CdtVertex, CdtFace>,
                                                       CGAL::No_constraint_intersection_tag>;

// Each face's nesting: how many constraint loops lie between it and the outside (odd: inside).
void mark_nesting(Cdt& cdt) {
    for (Cdt::Face_handle f : cdt.all_face_handles()) f->info() = -1;
    std::vector<Cdt::Face_handle> seeds{cdt.infinite_face()}, across, stack;
    for (int nesting = 0; !seeds.empty(); ++nesting, seeds.swap(across), across.clear()) {
        for (Cdt::Face_handle seed : seeds)
            if (seed->info() < 0) {
                seed->info() = nesting;
                stack.push_back(seed);
            }
        while (!stack.empty()) {
            const Cdt::Face_handle f = stack.back();
            stack.pop_back();
            for (int i = 0; i < 3; ++i) {
                const Cdt::Face_handle n = f->neighbor(i);
                if (n->info() >= 0) continue;
                if (cdt.is_constrained(Cdt::Edge(f, i))) {
                    across.push_back(n);
                } else {
                    n->info() = nesting;
                    stack.push_back(n);
                }
            }
        }
    }
}

size_t rebuild_hole_walls(Mesh& mesh, const Regions& regions, std::vector<HoleWall>& walls, const PointGrid& grid,
                          double reach, double filled_reach, double spacing, size_t crossing) {
    size_t made = 0;
    for (HoleWall& wall : walls) {
        const size_t vertex_count = mesh.vertices.size();
        std::vector<std::vector<int>> neighbours(vertex_count);
        std::vector<cv::Vec3d> vertex_normal(vertex_count, cv::Vec3d(0, 0, 0));
        for (const cv::Vec3i& face : mesh.faces) {
            const cv::Vec3d a(mesh.vertices[face[0]]), b(mesh.vertices[face[1]]), c(mesh.vertices[face[2]]);
            for (int k = 0; k < 3; ++k) {
                neighbours[face[k]].push_back(face[(k + 1) % 3]);
                vertex_normal[face[k]] += (b - a).cross(c - a);
            }
        }
        std::vector<int> near;
        std::vector<uint8_t> guessed(vertex_count, 0);
        for (size_t v = 0; v < vertex_count; ++v) {
            grid.within(cv::Vec3d(mesh.vertices[v]), filled_reach, near);
            guessed[v] = near.size() < 3;
            if (cv::norm(vertex_normal[v]) > 0) vertex_normal[v] = cv::normalize(vertex_normal[v]);
        }
        const Plane& hole = regions.planes[wall.surface];
        const double along_axis = std::cos(20.0 * CV_PI / 180.0);
        auto in_tube = [&](size_t v) {  // within half a radius of the wall, and of its seen ends
            const cv::Vec3d x(mesh.vertices[v]);
            const double along = hole.axis.dot(x - hole.centre);
            return along >= hole.low - reach && along <= hole.high + reach &&
                   std::abs(hole.distance(x)) <= std::max(reach, 0.5 * hole.radius);
        };
        auto candidate = [&](size_t v) {
            const cv::Vec3d x(mesh.vertices[v]);
            return guessed[v] && in_tube(v) && hole.distance(x) <= 0.5 * hole.radius && wall.seen_at(hole, x) &&
                   std::abs(vertex_normal[v].dot(hole.axis)) <= along_axis;
        };
        // The patch, grown over the mesh.
        std::vector<uint8_t> in_patch(vertex_count, 0);
        for (size_t seed = 0; seed < vertex_count; ++seed) {
            if (in_patch[seed] || !candidate(seed) ||
                vertex_normal[seed].dot(hole.normal_at(cv::Vec3d(mesh.vertices[seed]))) < kHoleWallFacing)
                continue;
            std::vector<int> queue{int(seed)};
            in_patch[seed] = 1;
            while (!queue.empty()) {
                const int v = queue.back();
                queue.pop_back();
                for (int w : neighbours[v])
                    if (!in_patch[w] && candidate(size_t(w))) {
                        in_patch[w] = 1;
                        queue.push_back(w);
                    }
            }
        }
        // Unrolled: angle about the axis, and the radius of the circle it goes on grows with
        // the distance along the axis (conformal: the triangles keep their shape).
        const double lowest = hole.low - reach;
        auto unrolled = [&](const cv::Vec3d& x) {
            const cv::Vec3d r = x - hole.centre;
            const double angle = std::atan2(r.dot(wall.e2), r.dot(wall.e1));
            const double scale = std::exp((hole.axis.dot(r) - lowest) / hole.radius);
            return Kernel::Point_2(scale * std::cos(angle), scale * std::sin(angle));
        };
        auto rolled = [&](const Kernel::Point_2& p) {
            const double along = lowest + hole.radius * std::log(std::hypot(p.x(), p.y()));
            const double angle = std::atan2(p.y(), p.x());
            return hole.centre + hole.axis * along + hole.radius * (std::cos(angle) * wall.e1 + std::sin(angle) * wall.e2);
        };
        // The faces cut out (those with a vertex in the patch), and their rim: the edges (a ->
        // b) of a cut face whose other face stays. The pieces of the faces that stay that the
        // patch encloses (guessed, or within the wall's reach: a pocket's far end, a face or two
        // left between the patch's vertices) join it; and where Poisson's guess overhangs, so
        // that the rim crosses itself unrolled, the guessed vertices of the crossing edges join
        // it; then the rim is found again.
        std::vector<cv::Vec3i> kept, cut;
        std::map<int, int> rim_next;  // a -> b along the rim
        bool simple = false;
        for (int attempt = 0; attempt < 8 && !simple; ++attempt) {
            kept.clear();
            cut.clear();
            rim_next.clear();
            for (const cv::Vec3i& face : mesh.faces)
                (in_patch[face[0]] || in_patch[face[1]] || in_patch[face[2]] ? cut : kept).push_back(face);
            // The pieces of the kept faces, joined across their edges.
            std::vector<int> root(kept.size());
            std::iota(root.begin(), root.end(), 0);
            auto find = [&](int f) {
                while (root[f] != f) f = root[f] = root[root[f]];
                return f;
            };
            std::map<std::pair<int, int>, int> face_of_edge;  // a -> b: its kept face
            for (size_t f = 0; f < kept.size(); ++f)
                for (int k = 0; k < 3; ++k) face_of_edge[{kept[f][k], kept[f][(k + 1) % 3]}] = int(f);
            for (const auto& [edge, f] : face_of_edge) {
                const auto other = face_of_edge.find({edge.second, edge.first});
                if (other != face_of_edge.end()) root[find(f)] = find(other->second);
            }
            std::vector<uint8_t> reaches_out(kept.size(), 0);  // the piece has a measured vertex beyond the wall's reach
            for (size_t f = 0; f < kept.size(); ++f)
                for (int k = 0; k < 3; ++k)
                    if (!guessed[kept[f][k]]) reaches_out[find(int(f))] = 1;
            bool joined = false;
            for (size_t f = 0; f < kept.size(); ++f)
                if (!reaches_out[find(int(f))])
                    for (int k = 0; k < 3; ++k) in_patch[kept[f][k]] = joined = true;
            if (joined) continue;
            simple = true;
            for (const cv::Vec3i& face : cut)
                for (int k = 0; k < 3; ++k) {
                    const int a = face[k], b = face[(k + 1) % 3];
                    if (face_of_edge.count({b, a})) simple = simple && rim_next.emplace(a, b).second;
                }
            if (!simple) break;  // the rim touches itself at a vertex
            const std::vector<std::pair<int, int>> edges(rim_next.begin(), rim_next.end());
            std::vector<Kernel::Segment_2> unrolled_edges;
            for (const auto& [a, b] : edges)
                unrolled_edges.emplace_back(unrolled(cv::Vec3d(mesh.vertices[a])), unrolled(cv::Vec3d(mesh.vertices[b])));
            for (size_t i = 0; i < edges.size(); ++i)
                for (size_t j = i + 1; j < edges.size(); ++j) {
                    const auto [a, b] = edges[i];
                    const auto [c, d] = edges[j];
                    if (a == c || a == d || b == c || b == d || !CGAL::do_intersect(unrolled_edges[i], unrolled_edges[j])) continue;
                    simple = false;
                    for (int v : {a, b, c, d})
                        if (guessed[v] && !in_patch[v]) in_patch[v] = joined = true;
                }
            if (!joined) break;
        }
        if (!simple || rim_next.empty()) continue;
        Cdt cdt;
        std::map<int, Cdt::Vertex_handle> handle;
        try {
            for (const auto& [a, b] : rim_next)
                for (int v : {a, b})
                    if (!handle.count(v)) {
                        handle[v] = cdt.insert(unrolled(cv::Vec3d(mesh.vertices[v])));
                        handle[v]->info() = v;
                    }
            if (cdt.number_of_vertices() != handle.size()) continue;  // two rim vertices on one point
            for (const auto& [a, b] : rim_next) cdt.insert_constraint(handle[a], handle[b]);
        } catch (const Cdt::Intersection_of_constraints_exception&) {
            continue;  // the rim crosses itself unrolled
        }
        mark_nesting(cdt);
        // Points inside, on a grid over the cylinder, not within half the spacing of the rim.
        std::vector<cv::Vec3d> rim_on_wall;
        double bottom = 1e30, top = -1e30;
        for (const auto& [a, b] : rim_next) {
            rim_on_wall.push_back(hole.project(cv::Vec3d(mesh.vertices[a])));
            const double along = hole.axis.dot(cv::Vec3d(mesh.vertices[a]) - hole.centre);
            bottom = std::min(bottom, along);
            top = std::max(top, along);
        }
        const int turns = std::max(8, int(std::ceil(2 * CV_PI * hole.radius / spacing)));
        std::vector<Kernel::Point_2> inside;
        for (double along = bottom + 0.5 * spacing; along < top; along += spacing)
            for (int t = 0; t < turns; ++t) {
                const double angle = 2 * CV_PI * (t + 0.5 * (int(std::lround((along - bottom) / spacing)) % 2)) / turns;
                const cv::Vec3d x = hole.centre + hole.axis * along +
                                    hole.radius * (std::cos(angle) * wall.e1 + std::sin(angle) * wall.e2);
                const Kernel::Point_2 p = unrolled(x);
                const Cdt::Face_handle f = cdt.locate(p);
                if (cdt.is_infinite(f) || f->info() % 2 == 0) continue;
                bool clear = true;
                for (const cv::Vec3d& r : rim_on_wall) clear = clear && cv::norm(r - x) > 0.5 * spacing;
                if (clear) inside.push_back(p);
            }
        for (const Kernel::Point_2& p : inside) cdt.insert(p)->info() = -1;
        mark_nesting(cdt);
        // The new faces, turned the way the rim runs in the faces cut out.
        Mesh rebuilt;
        rebuilt.vertices = mesh.vertices;
        rebuilt.faces = kept;
        std::vector<cv::Vec3i> added;
        int turned = 0;  // +1: as unrolled, -1: reversed
        for (Cdt::Face_handle f : cdt.finite_face_handles()) {
            if (f->info() % 2 == 0) continue;
            cv::Vec3i face;
            for (int k = 0; k < 3; ++k) {
                Cdt::Vertex_handle v = f->vertex(k);
                if (v->info() < 0) {
                    v->info() = int(rebuilt.vertices.size());
                    rebuilt.vertices.push_back(cv::Vec3f(rolled(v->point())));
                }
                face[k] = v->info();
            }
            for (int k = 0; k < 3 && turned == 0; ++k) {
                const auto found = rim_next.find(face[k]);
                if (found == rim_next.end()) continue;
                if (found->second == face[(k + 1) % 3]) turned = 1;
                else if (found->second == face[(k + 2) % 3]) turned = -1;
            }
            added.push_back(face);
        }
        for (cv::Vec3i& face : added) {
            if (turned < 0) std::swap(face[1], face[2]);
            rebuilt.faces.push_back(face);
        }
        // Closed and manifold: each directed edge once, and its reverse there too.
        std::map<std::pair<int, int>, int> directed;
        for (const cv::Vec3i& face : rebuilt.faces)
            for (int k = 0; k < 3; ++k) ++directed[{face[k], face[(k + 1) % 3]}];
        bool closed = turned != 0;
        for (const auto& [edge, count] : directed) closed = closed && count == 1 && directed.count({edge.second, edge.first});
        if (!closed) continue;
        const size_t crossing_rebuilt = self_intersecting_faces(rebuilt).size();
        if (crossing_rebuilt > crossing) continue;
        crossing = crossing_rebuilt;
        made += rebuilt.vertices.size() - mesh.vertices.size();
        wall.rebuilt = true;
        mesh = std::move(rebuilt);
    }
    return made;
}

// The fallback for a wall whose rebuild was refused (rebuild_hole_walls): filled-in vertices
// of a hole's wall that no view saw, where Poisson narrowed the hole or bulged it out into the
// material by a millimetre. Such a vertex goes onto the hole's fitted cylinder only where the cylinder has support: between
// the ends of its seen wall along the axis, at a turn about the axis where the wall was seen
// at some depth (HoleWall), within half a radius of the wall. The patch is grown over the
// mesh from the vertices whose surface faces the axis (the faces a hole opens on face along
// it and are left alone), then relaxed on the cylinder (each vertex to the mean of its
// neighbours, put back on it) so that a bulge projected onto it does not fold: its vertices
// are invented, only their surface is fitted.
size_t fill_hole_walls(const Mesh& mesh, const Regions& regions, const std::vector<HoleWall>& walls, const PointGrid& grid,
                       const std::vector<VertexPlanes>& model, const std::vector<cv::Vec3d>& vertex_normal,
                       double reach, double filled_reach, std::vector<cv::Vec3d>& target, std::vector<int>& surface_of) {
    const size_t vertex_count = mesh.vertices.size();
    std::vector<std::vector<int>> neighbours(vertex_count);
    for (const cv::Vec3i& face : mesh.faces)
        for (int k = 0; k < 3; ++k) {
            neighbours[face[k]].push_back(face[(k + 1) % 3]);
            neighbours[face[k]].push_back(face[(k + 2) % 3]);
        }
    for (std::vector<int>& list : neighbours) {
        std::sort(list.begin(), list.end());
        list.erase(std::unique(list.begin(), list.end()), list.end());
    }
    const double along_axis = std::cos(20.0 * CV_PI / 180.0);
    std::vector<int> near;
    size_t moved = 0;
    for (const HoleWall& wall : walls) {
        if (wall.rebuilt) continue;
        const int h = wall.surface;
        const Plane& hole = regions.planes[h];
        auto candidate = [&](size_t v) {
            if (model[v].count != 0 || surface_of[v] >= 0) return false;
            const cv::Vec3d x(mesh.vertices[v]);
            const double along = hole.axis.dot(x - hole.centre);
            const double from_axis = cv::norm((x - hole.centre) - hole.axis * along);
            if (along < hole.low || along > hole.high || from_axis < 0.5 * hole.radius ||
                from_axis > hole.radius + std::max(reach, 0.5 * hole.radius) || !wall.seen_at(hole, x) ||
                std::abs(vertex_normal[v].dot(hole.axis)) > along_axis)
                return false;
            grid.within(x, filled_reach, near);
            return near.size() < 3;
        };
        std::vector<uint8_t> in_patch(vertex_count, 0);
        std::vector<int> patch;
        for (size_t seed = 0; seed < vertex_count; ++seed) {
            if (in_patch[seed] || vertex_normal[seed].dot(hole.normal_at(cv::Vec3d(mesh.vertices[seed]))) < kHoleWallFacing ||
                !candidate(seed))
                continue;
            std::deque<int> queue{int(seed)};
            in_patch[seed] = 1;
            while (!queue.empty()) {
                const int v = queue.front();
                queue.pop_front();
                patch.push_back(v);
                for (int w : neighbours[v])
                    if (!in_patch[w] && candidate(size_t(w))) {
                        in_patch[w] = 1;
                        queue.push_back(w);
                    }
            }
        }
        for (int v : patch) {
            target[v] = hole.project(target[v]);
            surface_of[v] = h;
        }
        for (int iteration = 0; iteration < 1000; ++iteration)
            for (int v : patch) {
                cv::Vec3d mean(0, 0, 0);
                for (int w : neighbours[v]) mean += target[w];
                target[v] = hole.project(mean * (1.0 / double(neighbours[v].size())));
            }
        moved += patch.size();
    }
    return moved;
}

// One pass of sharpen_edges. Two cuts of a face on one line close together become one vertex,
// unless one of them is in `kept_apart` (a cut vertex's index, as the pass numbers them).
SharpenReport sharpen_edges_pass(Mesh& mesh, const std::vector<PointWithNormal>& points, double spacing_mm,
                                 const std::set<int>& kept_apart) {
    SharpenReport report;
    if (mesh.vertices.empty() || points.size() < kLeastRegionPoints || !(spacing_mm > 0)) return report;
    std::vector<cv::Vec3d> positions, normals;
    positions.reserve(points.size());
    normals.reserve(points.size());
    for (const PointWithNormal& p : points) {
        positions.emplace_back(p.first.x(), p.first.y(), p.first.z());
        normals.emplace_back(p.second.x(), p.second.y(), p.second.z());
    }
    const double grow_radius = 2 * spacing_mm;
    // The planes within this of a vertex make its model: Poisson rounds an edge by about a
    // triangle (the spacing), and the points' normals are blended for about as far again.
    const double reach = std::max(2.5 * spacing_mm, 1.0);
    const PointGrid grid(positions, std::max(grow_radius, reach));
    const Regions regions = find_planes(positions, normals, grid, grow_radius);
    report.planes = regions.planes.size();
    if (regions.planes.size() < 2) return report;
    const double agree = 2 * regions.tolerance;
    std::vector<HoleWall> walls = hole_walls(regions, positions);
    // A vertex with fewer than 3 points this near is filled in (as mesh_cloud marks it).
    const double filled_reach = std::max(2 * spacing_mm, 0.5);
    // A vertex further than this from where its planes put it is left alone (not an edge Poisson rounded).
    const double longest_move = std::max(1.5 * spacing_mm, 0.6);
    const Mesh unsharpened = mesh;
    const size_t crossing_before = self_intersecting_faces(mesh).size();
    report.hole_vertices = rebuild_hole_walls(mesh, regions, walls, grid, reach, filled_reach, spacing_mm, crossing_before);

    // 1. Each vertex's planes, and whether the points around it lie on them.
    const size_t vertex_count = mesh.vertices.size();
    std::vector<VertexPlanes> model(vertex_count);
    std::vector<int> near;
    for (size_t v = 0; v < vertex_count; ++v) {
        const cv::Vec3d x(mesh.vertices[v]);
        grid.within(x, reach, near);
        std::array<int, 8> ids{}, counts{};
        int found = 0;
        bool crowded = false;
        for (int k : near) {
            const int id = regions.label[k];
            if (id < 0) continue;
            int slot = 0;
            while (slot < found && ids[slot] != id) ++slot;
            if (slot == found) {
                if (found == 8) {
                    crowded = true;
                    continue;
                }
                ids[found] = id;
                counts[found++] = 0;
            }
            ++counts[slot];
        }
        if (crowded) continue;
        // A hole's wall no view saw down to the face it opens on: the wall goes on to that face
        // where it was seen at this turn, so that the rim is an edge between them and not
        // Poisson's rounding (the face's points then decide, as at any edge).
        for (const HoleWall& wall : walls) {
            const Plane& hole = regions.planes[wall.surface];
            const double along = hole.axis.dot(x - hole.centre);
            if (std::abs(hole.distance(x)) > reach || along < hole.low - reach || along > hole.high + reach ||
                !wall.seen_at(hole, x))
                continue;
            int slot = 0;
            while (slot < found && ids[slot] != wall.surface) ++slot;
            if (slot == found) {
                if (found == 8) continue;
                ids[found] = wall.surface;
                counts[found++] = 0;
            }
            counts[slot] = std::max(counts[slot], 3);
        }
        // Nearly coincident planes are one face (a face grown as two regions): keep the larger.
        std::vector<int> planes;
        for (int s = 0; s < found; ++s) {
            if (counts[s] < 3) continue;
            planes.push_back(s);
        }
        std::sort(planes.begin(), planes.end(), [&](int a, int b) { return counts[a] > counts[b]; });
        std::vector<int> kept;
        bool ambiguous = false;
        for (int s : planes) {
            const Plane& p = regions.planes[ids[s]];
            bool duplicate = false;
            for (int t : kept) {
                const double angle = degrees_between(p.normal_at(x), regions.planes[ids[t]].normal_at(x));
                if (angle < kSamePlaneDeg) duplicate = true;
                else if (angle < kSharpEdgeDeg) ambiguous = true;
            }
            if (!duplicate) kept.push_back(s);
        }
        if (ambiguous || kept.empty() || kept.size() > 3) continue;
        // Planes with only a point or two this near (past a corner, beyond the blur of its
        // edges): too few to model the vertex by, but their points are surface, not a fillet.
        std::vector<int> glimpsed;
        for (int s = 0; s < found; ++s) {
            if (counts[s] >= 3) continue;
            bool apart = true;
            for (int t : kept)
                apart = apart && degrees_between(regions.planes[ids[s]].normal_at(x), regions.planes[ids[t]].normal_at(x)) >= kSharpEdgeDeg;
            if (apart) glimpsed.push_back(ids[s]);
        }
        VertexPlanes& vp = model[v];
        vp.count = static_cast<int>(kept.size());
        for (int k = 0; k < vp.count; ++k) vp.plane[k] = ids[kept[k]];
        // Its own plane: the nearest.
        int own = 0;
        for (int k = 1; k < vp.count; ++k)
            if (std::abs(regions.planes[vp.plane[k]].distance(x)) < std::abs(regions.planes[vp.plane[own]].distance(x)))
                own = k;
        std::swap(vp.plane[0], vp.plane[own]);
        // The points must lie on the planes (within the noise), or the surface is not made of them here.
        size_t on_planes = 0, all = 0;
        std::array<int, 3> above{0, 0, 0}, below{0, 0, 0};
        for (int k : near) {
            ++all;
            std::array<double, 3> off{};
            double nearest = 1e9;
            for (int c = 0; c < vp.count; ++c) {
                off[c] = std::abs(regions.planes[vp.plane[c]].distance(positions[k]));
                nearest = std::min(nearest, off[c]);
            }
            // Right at the line two surfaces meet on, a camera pixel spans both: its points are
            // rounded off by a fraction of a millimetre, which is the edge, not a fillet; and
            // in the blur's tail, up to twice as far from the line, a little off a face.
            double line = std::numeric_limits<double>::infinity();
            for (int c = 0; c < vp.count; ++c)
                for (int e = c + 1; e < vp.count; ++e)
                    line = std::min(line, from_line(regions.planes[vp.plane[c]], regions.planes[vp.plane[e]], positions[k]));
            const bool blurred = line < kEdgeBlurMm || (line < 2 * kEdgeBlurMm && nearest < kBlurTailOff * agree);
            const bool on_glimpsed = std::find(glimpsed.begin(), glimpsed.end(), regions.label[k]) != glimpsed.end();
            if (nearest < agree || blurred || on_glimpsed) ++on_planes;
            if (regions.label[k] == vp.plane[0])
                for (int c = 1; c < vp.count; ++c) {
                    const double d = regions.planes[vp.plane[c]].distance(positions[k]);
                    if (d > agree) ++above[c];
                    else if (d < -agree) ++below[c];
                }
        }
        if (!points_agree(on_planes, all)) {
            vp.count = 0;
            continue;
        }
        for (int c = 1; c < vp.count; ++c) {
            const int total = above[c] + below[c];
            if (total > 0 && above[c] >= 0.95 * total) vp.side[c] = 1;
            else if (total > 0 && below[c] >= 0.95 * total) vp.side[c] = -1;
        }
        ++report.edge_vertices;
    }
    auto own_plane = [&](size_t v) { return model[v].count > 0 ? model[v].plane[0] : -1; };
    auto sharp_pair = [&](int a, int b, const cv::Vec3d& x) {
        return degrees_between(regions.planes[a].normal_at(x), regions.planes[b].normal_at(x)) >= kSharpEdgeDeg;
    };

    // 2. Mesh edges between vertices of two planes: where they cross the bisector of the planes
    // (equal distance from both). Crossings near an end put that end on the line instead.
    struct Crossing {
        int a, b;      // the vertices
        double t;      // from a to b
        int plane_a, plane_b;
    };
    std::unordered_map<long long, Crossing> crossings;
    // A vertex of a rebuilt hole wall with no other surface's points near (the wall was not seen
    // there, and the face it opens on rarely was right at the rim): an edge from it to a vertex
    // of the face that knows the wall still crosses their edge, or the face spans the corner.
    std::vector<uint8_t> rebuilt_surface(regions.planes.size(), 0);
    for (const HoleWall& wall : walls) rebuilt_surface[wall.surface] = rebuilt_surface[wall.surface] || wall.rebuilt;
    auto only_rebuilt_wall = [&](int v) { return model[v].count == 1 && rebuilt_surface[model[v].plane[0]]; };
    auto edge_key = [&](int a, int b) { return (long long)std::min(a, b) * (long long)vertex_count + std::max(a, b); };
    std::vector<std::vector<std::pair<int, int>>> snaps(vertex_count);  // planes pairs an end goes onto
    for (const cv::Vec3i& face : mesh.faces)
        for (int k = 0; k < 3; ++k) {
            const int a = face[k], b = face[(k + 1) % 3];
            const int pa = own_plane(a), pb = own_plane(b);
            if (pa < 0 || pb < 0 || pa == pb || !(model[a].has(pb) || only_rebuilt_wall(a)) ||
                !(model[b].has(pa) || only_rebuilt_wall(b)) ||
                !sharp_pair(pa, pb, 0.5 * (cv::Vec3d(mesh.vertices[a]) + cv::Vec3d(mesh.vertices[b]))))
                continue;
            const long long key = edge_key(a, b);
            if (crossings.count(key)) continue;
            const cv::Vec3d xa(mesh.vertices[a]), xb(mesh.vertices[b]);
            const Plane &plane_a = regions.planes[pa], &plane_b = regions.planes[pb];
            auto gap = [&](double t) {
                const cv::Vec3d x = xa + t * (xb - xa);
                return std::abs(plane_a.distance(x)) - std::abs(plane_b.distance(x));
            };
            double lo = 0, hi = 1;
            for (int i = 0; i < 30; ++i) {
                const double mid = 0.5 * (lo + hi);
                (gap(mid) <= 0 ? lo : hi) = mid;
            }
            const double t = 0.5 * (lo + hi);
            crossings.emplace(key, Crossing{a, b, t, pa, pb});
            if (t < 0.15) snaps[a].push_back({pa, pb});
            else if (t > 0.85) snaps[b].push_back({pa, pb});
        }

    // 3. Where each vertex goes. `safe` is where it may go back to without folding anything:
    // its place on the Poisson surface (for a new vertex, its place on the split edge).
    std::vector<cv::Vec3d> safe(vertex_count), target(vertex_count);
    for (size_t v = 0; v < vertex_count; ++v) safe[v] = target[v] = cv::Vec3d(mesh.vertices[v]);
    std::vector<uint8_t> on_feature(vertex_count, 0);  // on a line or a corner: its edges are not split
    // The Poisson surface's normals (area-weighted), to tell a hole's wall from the faces it opens on.
    std::vector<cv::Vec3d> vertex_normal(vertex_count, cv::Vec3d(0, 0, 0));
    for (const cv::Vec3i& face : mesh.faces) {
        const cv::Vec3d a(mesh.vertices[face[0]]), b(mesh.vertices[face[1]]), c(mesh.vertices[face[2]]);
        const cv::Vec3d n = (b - a).cross(c - a);
        for (int k = 0; k < 3; ++k) vertex_normal[face[k]] += n;
    }
    for (cv::Vec3d& n : vertex_normal) n = cv::norm(n) > 0 ? cv::normalize(n) : n;
    // Corners: three planes meeting in a point, each with its points beside it, get a vertex
    // within the largest move of that point whose points lie on all three (Poisson leaves none
    // there, and an edge split near it rarely lands on it).
    using Triple = std::array<int, 3>;
    std::map<Triple, cv::Vec3d> corner_at;                   // the supported corners
    std::map<Triple, std::pair<double, int>> corner_vertex;  // its nearest vertex and how near
    for (size_t v = 0; v < vertex_count; ++v) {
        const VertexPlanes& vp = model[v];
        if (vp.count != 3) continue;
        Triple triple{vp.plane[0], vp.plane[1], vp.plane[2]};
        std::sort(triple.begin(), triple.end());
        auto found = corner_at.find(triple);
        if (found == corner_at.end()) {
            cv::Vec3d corner;
            bool supported = corner_of(regions.planes[triple[0]], regions.planes[triple[1]], regions.planes[triple[2]], corner) &&
                             sharp_pair(triple[0], triple[1], corner) && sharp_pair(triple[1], triple[2], corner) &&
                             sharp_pair(triple[0], triple[2], corner);
            if (supported) {
                // Each plane's points beside it (the edges' blur leaves few within the reach of
                // the corner itself: two, at a convex corner of the half-resolution camera) ...
                grid.within(corner, 2 * reach, near);
                for (int plane : triple)
                    supported = supported &&
                                std::count_if(near.begin(), near.end(), [&](int k) { return regions.label[k] == plane; }) >= 3;
                // ... and the points around it on the planes or their lines (a corner cut off
                // or rounded has its points off them).
                grid.within(corner, reach, near);
                const size_t on = size_t(std::count_if(near.begin(), near.end(), [&](int k) {
                    const cv::Vec3d& p = positions[k];
                    for (int a = 0; a < 3; ++a) {
                        if (std::abs(regions.planes[triple[a]].distance(p)) < agree) return true;
                        for (int b = a + 1; b < 3; ++b)
                            if (from_line(regions.planes[triple[a]], regions.planes[triple[b]], p) < kEdgeBlurMm) return true;
                    }
                    return false;
                }));
                supported = supported && near.size() >= 3 && double(on) >= kLeastAgreement * double(near.size());
            }
            if (!supported) corner = cv::Vec3d(1e30, 1e30, 1e30);  // remembered as none
            found = corner_at.emplace(triple, corner).first;
        }
        const cv::Vec3d move = found->second - safe[v];
        if (cv::norm(move) > longest_move) continue;
        // The vertex the corner lies straight out from: one moved sideways drags its faces
        // across its neighbours' (and a fold pulls it or them back).
        const double sideways = cv::norm(move - vertex_normal[v] * vertex_normal[v].dot(move));
        auto best = corner_vertex.find(triple);
        if (best == corner_vertex.end() || sideways < best->second.first) corner_vertex[triple] = {sideways, int(v)};
    }
    for (const auto& [triple, nearest] : corner_vertex) {
        target[nearest.second] = corner_at[triple];
        on_feature[nearest.second] = 1;
        ++report.corners;
    }
    auto corner_taken = [&](int a, int b, int c) {
        Triple triple{a, b, c};
        std::sort(triple.begin(), triple.end());
        return corner_vertex.count(triple) > 0;
    };
    // The fitted surface each vertex is put on (-1: a line, a corner, or not moved): the fold
    // check judges faces lying on one such surface by the surface's own normal.
    std::vector<int> surface_of(vertex_count, -1);
    for (size_t v = 0; v < vertex_count; ++v) {
        const VertexPlanes& vp = model[v];
        if (vp.count == 0) continue;  // no surface of the points here (filled in: see the holes below)
        if (on_feature[v]) continue;  // a corner
        const cv::Vec3d x = safe[v];
        cv::Vec3d moved;
        bool placed = false;
        if (!snaps[v].empty()) {
            // The planes of its lines: two (one line) or three (a corner).
            std::vector<int> planes;
            for (const auto& [p, q] : snaps[v])
                for (int r : {p, q})
                    if (std::find(planes.begin(), planes.end(), r) == planes.end()) planes.push_back(r);
            if (planes.size() == 2) placed = onto_line(regions.planes[planes[0]], regions.planes[planes[1]], x, moved);
            else if (planes.size() == 3 && !corner_taken(planes[0], planes[1], planes[2]))
                placed = corner_of(regions.planes[planes[0]], regions.planes[planes[1]], regions.planes[planes[2]], moved);
            if (placed && cv::norm(moved - x) <= longest_move) {
                on_feature[v] = 1;
                report.corners += planes.size() == 3;
                target[v] = moved;
                continue;
            }
        }
        // On the bisector of two surfaces (a rounded edge's middle): onto their line, as a cut
        // there would go; onto one of them, a sliver across the rounding turns over.
        if (vp.count == 2 && sharp_pair(vp.plane[0], vp.plane[1], x) &&
            std::abs(regions.planes[vp.plane[1]].distance(x)) <= 1.3 * std::abs(regions.planes[vp.plane[0]].distance(x)) &&
            onto_line(regions.planes[vp.plane[0]], regions.planes[vp.plane[1]], x, moved) && cv::norm(moved - x) <= longest_move) {
            on_feature[v] = 1;
            target[v] = moved;
            continue;
        }
        // On its own plane, within the part of it its points are on (not past an edge).
        const Plane& own = regions.planes[vp.plane[0]];
        moved = onto_own_plane(regions, vp, x);
        std::vector<int> crossed;
        for (int c = 1; c < vp.count; ++c)
            if (vp.side[c] != 0 && sharp_pair(vp.plane[0], vp.plane[c], x) &&
                vp.side[c] * regions.planes[vp.plane[c]].distance(moved) < 0)
                crossed.push_back(vp.plane[c]);
        if (crossed.size() == 1) placed = onto_line(own, regions.planes[crossed[0]], moved, moved);
        else if (crossed.size() == 2) placed = corner_of(own, regions.planes[crossed[0]], regions.planes[crossed[1]], moved);
        else placed = true;
        if (placed && cv::norm(moved - x) <= longest_move) {
            target[v] = moved;
            // Stopped on the line (or the corner) of a surface its own plane would have taken it
            // past: on both surfaces, so its edges are not split again next to it (a cut landing
            // beside it on the same line makes faces with no area there, which count as crossing
            // and sent the whole rim back to Poisson's rounding).
            if (crossed.empty()) surface_of[v] = vp.plane[0];
            else on_feature[v] = 1;
        }
    }
    // Walls whose rebuild was refused: Poisson's vertices relaxed onto the cylinder instead.
    report.hole_vertices += fill_hole_walls(mesh, regions, walls, grid, model, vertex_normal, reach, filled_reach, target, surface_of);

    // 4. Split the edges that cross a line, each once.
    std::unordered_map<long long, int> split_vertex;
    std::vector<std::pair<int, int>> split_line;  // per split vertex: the planes of its line
    // An end already on both surfaces (on their line or a corner) leaves the edge whole; an end
    // on another line (near a corner) does not: the edge would cut across the corner.
    auto on_both = [&](int v, const Crossing& crossing) {
        return on_feature[v] && std::abs(regions.planes[crossing.plane_a].distance(target[v])) < 1e-3 &&
               std::abs(regions.planes[crossing.plane_b].distance(target[v])) < 1e-3;
    };
    for (auto& [key, crossing] : crossings) {
        if (on_both(crossing.a, crossing) || on_both(crossing.b, crossing)) continue;
        const cv::Vec3d xa(mesh.vertices[crossing.a]), xb(mesh.vertices[crossing.b]);
        const cv::Vec3d on_edge = xa + crossing.t * (xb - xa);
        // The line is within reach of the edge as it is, or as its ends go (a deeply rounded
        // rim: both ends move onto their surfaces). Otherwise the edge is not split: a vertex
        // left where Poisson rounded it, between neighbours moved onto both surfaces, would
        // stand out of them as a spike.
        const cv::Vec3d chord = target[crossing.a] + crossing.t * (target[crossing.b] - target[crossing.a]);
        cv::Vec3d moved;
        if (!onto_line(regions.planes[crossing.plane_a], regions.planes[crossing.plane_b], on_edge, moved) ||
            std::min(cv::norm(moved - on_edge), cv::norm(moved - chord)) > longest_move)
            continue;
        split_vertex.emplace(key, static_cast<int>(safe.size()));
        split_line.emplace_back(std::min(crossing.plane_a, crossing.plane_b), std::max(crossing.plane_a, crossing.plane_b));
        safe.push_back(on_edge);
        target.push_back(moved);
        ++report.cut_edges;
    }
    // Two cuts of one face that go onto the same line almost at the same point are one vertex
    // (the short edge between them collapsed): left as two, they swap places along the line as
    // often as not and fold the faces between them.
    std::vector<int> same_as(safe.size());
    std::iota(same_as.begin(), same_as.end(), 0);
    auto merged_into = [&](int v) {
        while (same_as[v] != v) v = same_as[v] = same_as[same_as[v]];
        return v;
    };
    const double coincident = 0.25 * spacing_mm;
    for (const cv::Vec3i& face : mesh.faces) {
        std::array<int, 3> cut{-1, -1, -1};
        for (int k = 0; k < 3; ++k) {
            const auto found = split_vertex.find(edge_key(face[k], face[(k + 1) % 3]));
            if (found != split_vertex.end()) cut[k] = found->second;
        }
        for (int k = 0; k < 3; ++k) {
            const int a = cut[k], b = cut[(k + 1) % 3];
            if (a < 0 || b < 0 || split_line[a - vertex_count] != split_line[b - vertex_count] ||
                cv::norm(target[a] - target[b]) > coincident || kept_apart.count(a) || kept_apart.count(b))
                continue;
            const int ra = merged_into(a), rb = merged_into(b);
            if (ra != rb) {
                same_as[std::max(ra, rb)] = std::min(ra, rb);
                ++report.merged_cuts;
            }
        }
    }

    // 5. The faces, split along the lines; each remembers the face it came from.
    std::vector<cv::Vec3i> faces;
    std::vector<int> parent;
    faces.reserve(mesh.faces.size() + 3 * split_vertex.size());
    const size_t before_centres = safe.size();
    const size_t corners_before = report.corners;
    auto add = [&](int a, int b, int c, int from) {
        a = merged_into(a), b = merged_into(b), c = merged_into(c);
        if (a == b || b == c || c == a) return;  // collapsed
        faces.emplace_back(a, b, c);
        parent.push_back(from);
    };
    auto split_faces = [&]() {
        for (size_t f = 0; f < mesh.faces.size(); ++f) {
            const cv::Vec3i& face = mesh.faces[f];
            std::array<int, 3> cut{-1, -1, -1};
            int cuts = 0;
            for (int k = 0; k < 3; ++k) {
                const auto found = split_vertex.find(edge_key(face[k], face[(k + 1) % 3]));
                if (found != split_vertex.end()) {
                    cut[k] = found->second;
                    ++cuts;
                }
            }
            const int from = static_cast<int>(f);
            if (cuts == 0) {
                add(face[0], face[1], face[2], from);
            } else if (cuts == 1) {
                int k = 0;
                while (cut[k] < 0) ++k;
                add(face[k], cut[k], face[(k + 2) % 3], from);
                add(cut[k], face[(k + 1) % 3], face[(k + 2) % 3], from);
            } else if (cuts == 2) {
                int k = 0;
                while (cut[k] >= 0) ++k;  // the edge not cut: face[k] -> face[k+1]
                const int v0 = face[k], v1 = face[(k + 1) % 3], lone = face[(k + 2) % 3];
                const int c1 = cut[(k + 1) % 3], c2 = cut[(k + 2) % 3];  // on v1 -> lone and lone -> v0
                add(c1, lone, c2, from);
                if (cv::norm(target[v0] - target[c1]) < cv::norm(target[v1] - target[c2])) {
                    add(v0, v1, c1, from);
                    add(v0, c1, c2, from);
                } else {
                    add(v0, v1, c2, from);
                    add(v1, c1, c2, from);
                }
            } else {
                for (int k = 0; k < 3; ++k) add(face[k], cut[k], cut[(k + 2) % 3], from);
                // The middle holds the corner where the three planes meet, when they do.
                const int pa = own_plane(face[0]), pb = own_plane(face[1]), pc = own_plane(face[2]);
                cv::Vec3d corner;
                const cv::Vec3d middle = (safe[cut[0]] + safe[cut[1]] + safe[cut[2]]) * (1.0 / 3);
                if (pa != pb && pb != pc && pa != pc && !corner_taken(pa, pb, pc) && corner_of(regions.planes[pa], regions.planes[pb], regions.planes[pc], corner) &&
                    cv::norm(corner - middle) <= longest_move) {
                    const int centre = static_cast<int>(safe.size());
                    safe.push_back(middle);
                    target.push_back(corner);
                    same_as.push_back(centre);  // merged_into() reads it: a vertex of its own
                    ++report.corners;
                    for (int k = 0; k < 3; ++k) add(cut[k], cut[(k + 1) % 3], centre, from);
                } else {
                    add(cut[0], cut[1], cut[2], from);
                }
            }
        }
    };
    split_faces();
    // A merge whose two vertices had other neighbours in common than the faces between them
    // leaves an edge with more than two faces: then the faces are split again with no merges.
    const long long count = static_cast<long long>(safe.size());
    std::unordered_map<long long, int> directed;  // a -> b, as a * count + b
    bool manifold = true;
    for (const cv::Vec3i& face : faces)
        for (int k = 0; k < 3; ++k) manifold = manifold && ++directed[face[k] * count + face[(k + 1) % 3]] == 1;
    for (const auto& [edge, faces_on_it] : directed) manifold = manifold && directed.count(edge % count * count + edge / count);
    if (!manifold) {
        same_as.resize(before_centres);
        std::iota(same_as.begin(), same_as.end(), 0);
        faces.clear();
        parent.clear();
        safe.resize(before_centres);
        target.resize(before_centres);
        report.corners = corners_before;
        split_faces();
    }

    // 6. Self-check: a face turned over against the face it came from, or faces crossing each
    // other, pull their vertices back: half way, then a quarter of the way, then all the way
    // (often a vertex need not go all the way back for its faces to stay unfolded).
    std::vector<cv::Vec3d> original_normal(mesh.faces.size());
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        const cv::Vec3i& face = mesh.faces[f];
        const cv::Vec3d a(mesh.vertices[face[0]]), b(mesh.vertices[face[1]]), c(mesh.vertices[face[2]]);
        original_normal[f] = (b - a).cross(c - a);
    }
    // A face whose corners all go onto one fitted surface is judged by that surface's normal
    // (Poisson's faces put onto a hole's wall can turn a long way), and so is a face
    // whose corners all go onto one plane, some of them onto its lines (the rounded edge's
    // faces Poisson turned a little past square); others by the face they came from.
    surface_of.resize(target.size(), -1);  // the split vertices: on lines
    auto reference_normal = [&](size_t f) {
        const cv::Vec3i& face = faces[f];
        const int s = surface_of[face[0]];
        if (s >= 0 && surface_of[face[1]] == s && surface_of[face[2]] == s)
            return regions.planes[s].normal_at((target[face[0]] + target[face[1]] + target[face[2]]) * (1.0 / 3));
        const int p = on_one_plane(face, regions, surface_of, target);
        return p >= 0 ? regions.planes[p].normal : original_normal[parent[f]];
    };
    untangle_on_planes(faces, regions, safe, surface_of, longest_move, target);
    std::vector<cv::Vec3d> position = target;
    std::vector<double> share(position.size(), 1.0);  // of the way from safe to target
    auto movable = [&](int v) { return share[v] > 0 && target[v] != safe[v]; };
    auto pulled_share = [&](int v) { return share[v] > 0.3 ? 0.5 * share[v] : 0.0; };
    auto pull_back_to = [&](int v, double to) {
        share[v] = to;
        position[v] = safe[v] + share[v] * (target[v] - safe[v]);
        if (share[v] == 0) ++report.reverted;
    };
    auto pull_back = [&](int v) { pull_back_to(v, pulled_share(v)); };
    auto send_back = [&](const cv::Vec3i& face) {
        bool pulled = false;
        for (int k = 0; k < 3; ++k)
            if (movable(face[k])) {
                pull_back(face[k]);
                pulled = true;
            }
        return pulled;
    };
    // A folded face first pulls back only the one vertex whose pulling back unfolds it most (the
    // others keep their edge); the whole face goes back when that is not enough. So does a face
    // left of no area (its corners put on one line: cuts kept apart, or a cut between two vertices
    // put on its line), which touches the faces along that line: pulled back, the vertex that
    // widens it most.
    auto facing = [&](const cv::Vec3i& face, size_t f) {
        const cv::Vec3d normal = (position[face[1]] - position[face[0]]).cross(position[face[2]] - position[face[0]]);
        return normal.dot(reference_normal(f));
    };
    // How far back a vertex goes to unfold a face: to where the face lies flat (its normal is
    // linear in one corner's place) and kUnfoldMarginMm more, but no more than half way. A sliver
    // turned over by micrometres (its corners put nearly in a line: on the circle where a hole's
    // wall meets a face, or across the wall) then costs micrometres; half way back, its vertex
    // stood 150-161 um off the two-placement models' hole rim.
    auto unfolding_share = [&](const cv::Vec3i& face, size_t f, int v) {
        const double folded = facing(face, f);
        const cv::Vec3d kept = position[v];
        position[v] = safe[v];
        const double unmoved = facing(face, f);
        position[v] = kept;
        const double half_way = pulled_share(v);
        if (!(unmoved > 0) || !(folded < 0)) return half_way;
        const double flat = share[v] * unmoved / (unmoved - folded);
        return std::max(half_way, flat - kUnfoldMarginMm / cv::norm(target[v] - safe[v]));
    };
    auto sliver = [&](const cv::Vec3i& face) { return is_sliver(position[face[0]], position[face[1]], position[face[2]]); };
    auto width = [&](const cv::Vec3i& face) {
        return height_over_longest_edge(position[face[0]], position[face[1]], position[face[2]]);
    };
    for (int round = 0; round < 60; ++round) {
        bool changed = false;
        for (size_t f = 0; f < faces.size(); ++f) {
            const cv::Vec3i& face = faces[f];
            const bool folded = facing(face, f) < 0;
            if (!folded && !sliver(face)) continue;
            int best = -1;
            double best_facing = -1e300;
            for (int k = 0; round < 30 && k < 3; ++k) {
                const int v = face[k];
                if (!movable(v)) continue;
                const cv::Vec3d kept = position[v];
                position[v] = safe[v] + pulled_share(v) * (target[v] - safe[v]);
                const double after = folded ? facing(face, f) : width(face);
                position[v] = kept;
                if (after > best_facing) best_facing = after, best = v;
            }
            if (best >= 0) {
                pull_back_to(best, unfolding_share(face, f, best));
                changed = true;
            } else {
                changed = send_back(face) || changed;
            }
        }
        if (!changed) break;
    }
    Mesh out;
    out.faces = faces;
    auto write_positions = [&]() {
        out.vertices.resize(position.size());
        for (size_t v = 0; v < position.size(); ++v) out.vertices[v] = cv::Vec3f(position[v]);
    };
    write_positions();
    // Faces that crossed each other before (none, usually) are not this stage's doing: only
    // crossings with a moved vertex send vertices back.
    auto moved_crossings = [&]() {
        std::vector<int> moved;
        for (int f : self_intersecting_faces(out)) {
            const cv::Vec3i& face = faces[f];
            if (position[face[0]] != safe[face[0]] || position[face[1]] != safe[face[1]] || position[face[2]] != safe[face[2]])
                moved.push_back(f);
        }
        return moved;
    };
    for (int round = 0;; ++round) {
        const std::vector<int> crossing_faces = moved_crossings();
        if (crossing_faces.empty()) break;
        if (round == 12) {
            // Still crossing itself: nothing is moved (the split faces stay, flat on their parents).
            position = safe;
            report.reverted = position.size();
            write_positions();
            break;
        }
        for (int f : crossing_faces) send_back(faces[f]);
        write_positions();
    }
    // The vertices merged away are left out.
    std::vector<int> renumber(out.vertices.size(), -1);
    Mesh compact;
    for (cv::Vec3i& face : out.faces)
        for (int k = 0; k < 3; ++k) {
            int& index = renumber[face[k]];
            if (index < 0) {
                index = static_cast<int>(compact.vertices.size());
                compact.vertices.push_back(out.vertices[face[k]]);
            }
            face[k] = index;
        }
    compact.faces = std::move(out.faces);
    // Last self-check, on the whole stage (the rebuilt walls too): faces crossing that did not
    // cross before (a face of no area touching another counts) undo the sharpening; the mesh
    // goes on as it came in. Faces of no area it could not widen that touch nothing else stay
    // (undoing for them undid the whole sharpening of the one-placement model at 0.4 mm).
    if (self_intersecting_faces(compact).size() > crossing_before) {
        // The merged cuts among the crossing faces' vertices, and the cuts merged into them.
        std::vector<int> original(compact.vertices.size());
        for (size_t v = 0; v < renumber.size(); ++v)
            if (renumber[v] >= 0) original[renumber[v]] = static_cast<int>(v);
        std::set<int> merged;
        for (int f : self_intersecting_faces(compact))
            for (int k = 0; k < 3; ++k)
                if (original[compact.faces[f][k]] >= static_cast<int>(vertex_count)) merged.insert(original[compact.faces[f][k]]);
        std::set<int> apart;
        for (int v = static_cast<int>(vertex_count); v < static_cast<int>(same_as.size()); ++v)
            if (merged_into(v) != v && merged.count(merged_into(v))) apart.insert({v, merged_into(v)});
        report.crossing_merged_cuts.assign(apart.begin(), apart.end());
        mesh = unsharpened;
        report.undone = true;
        return report;
    }
    mesh = std::move(compact);
    return report;
}

}  // namespace

// Merged cuts can make faces cross where no vertex moved (the faces around the vertex kept are
// no longer flat on the faces they came from: 3 pairs beside the boss of FreeCAD's eight-view
// walkthrough, which undid every edge): the pass is run again with those cuts kept apart (the
// others still merged: apart, close cuts leave faces of no area, which the pass widens).
SharpenReport sharpen_edges(Mesh& mesh, const std::vector<PointWithNormal>& points, double spacing_mm) {
    SharpenReport report = sharpen_edges_pass(mesh, points, spacing_mm, {});
    std::set<int> kept_apart;
    for (int pass = 1; pass < 5 && report.undone && !report.crossing_merged_cuts.empty(); ++pass) {
        kept_apart.insert(report.crossing_merged_cuts.begin(), report.crossing_merged_cuts.end());
        report = sharpen_edges_pass(mesh, points, spacing_mm, kept_apart);
    }
    return report;
}

}  // namespace picoscan::detail
