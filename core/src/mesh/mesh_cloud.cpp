// mesh_cloud: prepare the points, reconstruct, fill small holes, simplify.
#include "cloud/view_check.h"
#include "common/text_format.h"
#include "mesh/cgal_types.h"
#include "mesh/sharpen.h"
#include "picoscan/error.h"
#include "picoscan/mesh.h"
#include "register/point_grid.h"

#include <opencv2/core.hpp>
#include <algorithm>
#include <cmath>
#include <random>

namespace picoscan {

namespace {

// A vertex is measured when input points lie around it; elsewhere the surface was made up
// (Poisson closing a side never seen, a filled hole).
void mark_measured(Mesh& mesh, const std::vector<detail::PointWithNormal>& points, double reach_mm) {
    std::vector<cv::Vec3d> cloud;
    cloud.reserve(points.size());
    for (const auto& p : points) cloud.emplace_back(p.first.x(), p.first.y(), p.first.z());
    const detail::PointGrid grid(cloud, reach_mm);
    std::vector<int> found;
    mesh.measured.assign(mesh.vertices.size(), 0);
    for (size_t v = 0; v < mesh.vertices.size(); ++v) {
        grid.within(cv::Vec3d(mesh.vertices[v]), reach_mm, found);
        mesh.measured[v] = found.size() >= 3 ? 1 : 0;
    }
}

// A face is filled (not measured) when fewer than two of its corners are measured.
bool is_filled(const Mesh& mesh, const cv::Vec3i& face) {
    return mesh.measured[face[0]] + mesh.measured[face[1]] + mesh.measured[face[2]] < 2;
}

// The plane of the table the part stood on: across the turntable axis when it is known,
// otherwise the plane through most of the rim where the measured surface meets the filled
// one; the table is on the side of the filled surface, at the lowest measured points.
// Refuses when the unseen side does not end on a plane (the part did not stand on one).
struct TablePlane {
    cv::Vec3d up;   // unit, from the table into the part
    double height;  // up . x on the table
};

TablePlane find_table(const Mesh& mesh, const std::vector<detail::PointWithNormal>& points, const cv::Vec3d& axis,
                      double spacing) {
    cv::Vec3d filled_centre(0, 0, 0), measured_centre(0, 0, 0);
    size_t filled = 0, measured = 0;
    std::vector<uint8_t> on_rim(mesh.vertices.size(), 0);
    for (const cv::Vec3i& face : mesh.faces) {
        if (!is_filled(mesh, face)) continue;
        for (int k = 0; k < 3; ++k) {
            filled_centre += cv::Vec3d(mesh.vertices[static_cast<size_t>(face[k])]);
            ++filled;
            if (mesh.measured[static_cast<size_t>(face[k])]) on_rim[static_cast<size_t>(face[k])] = 1;
        }
    }
    std::vector<cv::Vec3d> rim;
    for (size_t v = 0; v < mesh.vertices.size(); ++v) {
        if (mesh.measured[v]) {
            measured_centre += cv::Vec3d(mesh.vertices[v]);
            ++measured;
        }
        if (on_rim[v]) rim.emplace_back(mesh.vertices[v]);
    }
    if (filled == 0 || rim.size() < 10)
        throw Error("mesh.fill", "table: the scan leaves no unseen side to close (use fill poisson)");
    filled_centre *= 1.0 / double(filled);
    measured_centre *= 1.0 / double(measured);
    const double tolerance = std::max(1.5 * spacing, 0.3);
    auto inliers_of = [&](const cv::Vec3d& normal, double offset) {
        std::vector<cv::Vec3d> near;
        for (const cv::Vec3d& p : rim)
            if (std::abs(normal.dot(p) - offset) < tolerance) near.push_back(p);
        return near;
    };
    cv::Vec3d up;
    if (cv::norm(axis) > 0) {
        up = cv::normalize(axis);
    } else {
        // RANSAC over the rim, then a least-squares plane through the inliers.
        std::mt19937 random(12345);
        std::uniform_int_distribution<size_t> pick(0, rim.size() - 1);
        size_t best = 0;
        double offset = 0;
        for (int attempt = 0; attempt < 400; ++attempt) {
            const cv::Vec3d a = rim[pick(random)], b = rim[pick(random)], c = rim[pick(random)];
            const cv::Vec3d normal = (b - a).cross(c - a);
            if (cv::norm(normal) < 1e-9) continue;
            const cv::Vec3d unit = cv::normalize(normal);
            const size_t count = inliers_of(unit, unit.dot(a)).size();
            if (count > best) {
                best = count;
                up = unit;
                offset = unit.dot(a);
            }
        }
        if (best < 3) throw Error("mesh.fill", "table: no plane fits the rim of the unseen side");
        for (int round = 0; round < 3; ++round) {
            const std::vector<cv::Vec3d> near = inliers_of(up, offset);
            if (near.size() < 3) break;
            cv::Vec3d centre(0, 0, 0);
            for (const cv::Vec3d& p : near) centre += p;
            centre *= 1.0 / double(near.size());
            cv::Matx33d scatter = cv::Matx33d::zeros();
            for (const cv::Vec3d& p : near) scatter += (p - centre) * (p - centre).t();
            cv::Matx31d values;
            cv::Matx33d vectors;
            cv::eigen(scatter, values, vectors);
            const cv::Vec3d normal(vectors(2, 0), vectors(2, 1), vectors(2, 2));
            up = normal.dot(up) < 0 ? -normal : normal;
            offset = up.dot(centre);
        }
    }
    if ((filled_centre - measured_centre).dot(up) > 0) up = -up;  // the table is below the part
    // The table's height: the lowest measured points along up (a low quantile, so a stray
    // point does not lower it).
    std::vector<double> heights;
    heights.reserve(points.size());
    for (const auto& p : points) heights.push_back(up.dot(cv::Vec3d(p.first.x(), p.first.y(), p.first.z())));
    const size_t low = heights.size() / 2000;
    std::nth_element(heights.begin(), heights.begin() + static_cast<long>(low), heights.end());
    const double height = heights[low];
    // The unseen side must end on that plane: most of its rim lies on it.
    const double on_plane = double(inliers_of(up, height).size()) / double(rim.size());
    if (on_plane < 0.3)
        throw Error("mesh.fill", "table: the edge of the unseen side does not lie on one plane across " +
                                     std::string(cv::norm(axis) > 0 ? "the given turntable axis" : "the part") + " (" +
                                     std::to_string(int(100 * on_plane)) +
                                     " % of it does): did the part stand on the table? Use fill open or poisson");
    return {up, height};
}

// Walls the views saw only in part (the lower half of a through hole: no camera looks far
// enough down into it) continued straight down to the table, as a part standing on the table
// is in the turntable's direction: points copied downwards from the lowest seen points of
// each wall, with the wall's normal. A line that meets measured surface before the table is
// dropped (the wall stands on something else, e.g. a boss on the top face).
std::vector<detail::PointWithNormal> walls_down_to_table(const std::vector<detail::PointWithNormal>& points,
                                                         const TablePlane& table, double spacing) {
    std::vector<cv::Vec3d> positions;
    positions.reserve(points.size());
    for (const auto& p : points) positions.emplace_back(p.first.x(), p.first.y(), p.first.z());
    const double reach = 2 * spacing;
    const detail::PointGrid grid(positions, reach);
    std::vector<detail::PointWithNormal> added;
    for (size_t i = 0; i < points.size(); ++i) {
        const cv::Vec3d p = positions[i];
        const cv::Vec3d n(points[i].second.x(), points[i].second.y(), points[i].second.z());
        const double height = table.up.dot(p) - table.height;
        if (std::abs(n.dot(table.up)) > 0.3 || height < 4 * spacing) continue;  // not a wall, or at the table
        if (grid.nearest(p - 2.5 * spacing * table.up, reach) >= 0) continue;  // the wall goes on below
        std::vector<detail::PointWithNormal> line;
        bool blocked = false;
        for (double t = spacing; t < height && !blocked; t += spacing) {
            const cv::Vec3d c = p - t * table.up;
            blocked = t > 2.5 * spacing && grid.nearest(c, reach) >= 0;
            line.emplace_back(detail::Point3(c[0], c[1], c[2]), points[i].second);
        }
        if (!blocked) added.insert(added.end(), line.begin(), line.end());
    }
    return added;
}

// Walls seen from two sides but not in between (a through hole seen into from each end, its
// middle never): each wall continued straight across the gap, as a ruled surface, where the
// straight line from its last seen points meets the same wall (a point facing the same way)
// on the other side, or the face the wall ends on (a face turned the way the line goes: the
// line leaves the part there, as a hole's wall ends at the face it opens on). Straight means
// along the wall's own straight direction: the axis of a curved wall (across the way its
// normals turn), or, on a flat wall, away from the seen points. A line that first meets
// surface facing it (the far wall at a hole's mouth, a slot's side) or meets nothing within
// max_gap_mm is dropped: Poisson closes that gap as before.
// Without this, Poisson's smooth closure narrows a hole's unseen middle by millimetres.
std::vector<detail::PointWithNormal> bridge_wall_gaps(const std::vector<detail::PointWithNormal>& points,
                                                      double spacing, double max_gap_mm) {
    std::vector<cv::Vec3d> positions, normals;
    positions.reserve(points.size());
    normals.reserve(points.size());
    for (const auto& p : points) {
        positions.emplace_back(p.first.x(), p.first.y(), p.first.z());
        normals.emplace_back(p.second.x(), p.second.y(), p.second.z());
    }
    const double reach = 2 * spacing, neighbourhood = 4 * spacing;
    const double same_wall = std::cos(20.0 * CV_PI / 180.0);
    const double curved = std::pow(std::sin(3.0 * CV_PI / 180.0), 2);  // normals spread over more than ~3 degrees
    const detail::PointGrid grid(positions, neighbourhood);
    std::vector<int> near;
    std::vector<detail::PointWithNormal> added;
    for (size_t i = 0; i < points.size(); ++i) {
        const cv::Vec3d p = positions[i], n = normals[i];
        grid.within(p, neighbourhood, near);
        cv::Vec3d centre(0, 0, 0), mean_normal(0, 0, 0);
        size_t count = 0;
        for (int k : near)
            if (normals[k].dot(n) > same_wall) {
                centre += positions[k];
                mean_normal += normals[k];
                ++count;
            }
        if (count < 8) continue;
        centre *= 1.0 / double(count);
        mean_normal *= 1.0 / double(count);
        cv::Matx33d spread = cv::Matx33d::zeros();
        for (int k : near)
            if (normals[k].dot(n) > same_wall) spread += (normals[k] - mean_normal) * (normals[k] - mean_normal).t();
        cv::Matx31d values;
        cv::Matx33d vectors;
        cv::eigen(spread * (1.0 / double(count)), values, vectors);
        const cv::Vec3d outward = p - centre;  // from the seen points towards the gap (if any)
        cv::Vec3d along;
        if (values(0) > curved) {
            along = n.cross(cv::Vec3d(vectors(0, 0), vectors(0, 1), vectors(0, 2)));
        } else {
            along = outward - n * n.dot(outward);
        }
        if (cv::norm(along) < 1e-9) continue;
        along = cv::normalize(along);
        if (along.dot(outward) < 0) along = -along;
        if (along.dot(outward) < 0.5 * spacing) continue;  // the seen surface goes on this way: no edge here
        if (grid.nearest(p + 2.5 * spacing * along, reach) >= 0) continue;
        std::vector<detail::PointWithNormal> line;
        bool bridged = false;
        std::vector<int> met;
        for (double t = spacing; t <= max_gap_mm; t += spacing) {
            const cv::Vec3d c = p + t * along;
            if (t > 2.5 * spacing) {
                grid.within(c, reach, met);
                if (!met.empty()) {
                    for (int k : met) bridged = bridged || normals[k].dot(n) > same_wall || normals[k].dot(along) > same_wall;
                    break;
                }
            }
            line.emplace_back(detail::Point3(c[0], c[1], c[2]), points[i].second);
        }
        if (bridged) added.insert(added.end(), line.begin(), line.end());
    }
    return added;
}

// Poisson's surface moved onto the points (undoing its smoothing); where that folded
// triangles through each other (at tight concave edges), those vertices go back.
void onto_points(Mesh& mesh, const std::vector<detail::PointWithNormal>& points, double spacing) {
    const Mesh smooth = mesh;
    detail::project_onto_points(mesh, points, 2.0 * spacing);
    for (int round = 0; round < 5; ++round) {
        const std::vector<int> folded = detail::self_intersecting_faces(mesh);
        if (folded.empty()) break;
        for (int f : folded)
            for (int k = 0; k < 3; ++k) mesh.vertices[mesh.faces[f][k]] = smooth.vertices[mesh.faces[f][k]];
    }
}

// Each vertex takes the white-frame colour of the nearest input point; vertices far from
// every point (filled surface) are grey. The grid is built over the vertices and the points
// pass by once, so nothing the size of the cloud (millions of merged points) is copied; each
// vertex keeps the nearest point (the first of equally near ones).
void colour_from_points(Mesh& mesh, const PointCloud& cloud, double reach_mm) {
    if (cloud.colours.size() != cloud.points.size()) return;
    std::vector<cv::Vec3d> vertices(mesh.vertices.begin(), mesh.vertices.end());
    const detail::PointGrid grid(vertices, reach_mm);
    std::vector<double> nearest(vertices.size(), reach_mm * reach_mm);  // squared distance, strictly within reach
    mesh.colours.assign(mesh.vertices.size(), cv::Vec3b(150, 150, 150));
    std::vector<int> near;
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        if (!is_finite_point(cloud.points[i])) continue;
        const cv::Vec3d point(cloud.points[i]);
        grid.within(point, reach_mm, near);
        for (int v : near) {
            const cv::Vec3d d = vertices[static_cast<size_t>(v)] - point;
            const double distance = d.dot(d);
            if (distance < nearest[static_cast<size_t>(v)]) {
                nearest[static_cast<size_t>(v)] = distance;
                mesh.colours[static_cast<size_t>(v)] = cloud.colours[i];
            }
        }
    }
}

// A point counts as covered by the surface within this many average spacings of a vertex;
// the surface must cover this share of the points.
constexpr double kCoverageReach = 5.0;
constexpr double kLeastCoverage = 0.95;
// Walls are continued across gaps up to this long (a through hole's unseen middle).
constexpr double kLongestBridgeMm = 30;

}  // namespace

Mesh mesh_cloud(const PointCloud& cloud, const MeshOptions& options, const ProgressCallback& progress) {
    auto report = [&](double fraction, const char* stage) {
        if (progress && !progress(fraction, stage)) throw Error("cancelled", "meshing cancelled");
    };
    if (options.method == MeshMethod::Grid)
        throw Error("method", "grid meshing joins the pixels of one view: use mesh_view or grid_mesh");
    if (cloud.points.empty()) throw Error("point cloud", "is empty: nothing to mesh");
    if (cloud.normals.size() != cloud.points.size())
        throw Error("point cloud", "has no normals; mesh a cloud written by picoscan (reconstruct or stitch)");
    // As for views (check_view_reach): beyond 1 km a float coordinate is coarser than 0.06 mm, so a
    // far cloud would mesh into crumbs (a ball at 1e7 mm gave 41 pieces) and be reported as meshed.
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        const cv::Vec3f& p = cloud.points[i];
        if (!is_finite_point(p) || !detail::beyond_reach(p)) continue;
        throw Error("point cloud", "point " + std::to_string(i) + " lies " + format("%.3g", cv::norm(cv::Vec3d(p))) +
                                       " mm from the origin, beyond 1 km: too far to mesh at the points' precision; bring the "
                                       "cloud near the origin");
    }
    report(0.0, "thinning the points");
    double spacing = 0;
    const std::vector<detail::PointWithNormal> points = detail::prepare_points(
        cloud, options.sample_spacing_mm, options.max_points, spacing,
        [&](double fraction, const char* stage) { report(0.05 + 0.05 * fraction, stage); });
    if (points.size() < 100)
        throw Error("point cloud", "has only " + std::to_string(points.size()) + " usable points; at least 100 are needed");
    // Degenerate: all points on a line or (for a closed surface) a plane.
    cv::Vec3d centre(0, 0, 0);
    for (const auto& p : points) centre += cv::Vec3d(p.first.x(), p.first.y(), p.first.z());
    centre *= 1.0 / static_cast<double>(points.size());
    cv::Matx33d scatter = cv::Matx33d::zeros();
    for (const auto& p : points) {
        const cv::Vec3d d = cv::Vec3d(p.first.x(), p.first.y(), p.first.z()) - centre;
        scatter += d * d.t();
    }
    cv::Matx31d extent;
    cv::eigen(scatter * (1.0 / static_cast<double>(points.size())), extent);
    const double thickness = std::sqrt(std::max(extent(2), 0.0)), width = std::sqrt(std::max(extent(1), 0.0));
    if (!(spacing > 0)) throw Error("point cloud", "is degenerate (its points coincide)");
    if (width < 2 * spacing) throw Error("point cloud", "is degenerate (its points lie along a line)");
    const bool closed_first = options.method == MeshMethod::Poisson && options.fill != MeshFill::Open;
    if (closed_first && thickness < 0.5 * spacing)
        throw Error("point cloud", "is flat (all points on one plane): Poisson needs a closed shape; use --method advancing-front or grid");

    const double measured_reach = std::max(2.0 * spacing, 0.5);
    Mesh mesh;
    if (options.method == MeshMethod::Poisson && options.fill == MeshFill::Open) {
        // Nothing to close: the points contoured where they are, on voxels of their spacing.
        PointCloud oriented;
        for (const auto& p : points) {
            oriented.points.emplace_back(float(p.first.x()), float(p.first.y()), float(p.first.z()));
            oriented.normals.emplace_back(float(p.second.x()), float(p.second.y()), float(p.second.z()));
        }
        mesh = band_surface(oriented, spacing, [&](double fraction, const std::string& stage) {
            report(0.1 + 0.75 * fraction, stage.c_str());
            return true;
        });
    } else if (options.method == MeshMethod::Poisson) {
        report(0.1, "Poisson reconstruction");
        const detail::PoissonSettings settings{spacing, options.poisson_triangle_size, options.poisson_distance,
                                               options.max_faces};
        // The surface Poisson is built on: the points, and walls continued across gaps seen
        // on both sides (those stay marked filled: only `points` are measured).
        std::vector<detail::PointWithNormal> surface = points;
        const std::vector<detail::PointWithNormal> bridges = bridge_wall_gaps(points, spacing, kLongestBridgeMm);
        surface.insert(surface.end(), bridges.begin(), bridges.end());
        mesh = detail::poisson_mesh(surface, settings, [&](double fraction, const char* stage) {
            report(0.1 + fraction * 0.6 / 0.7, stage);
        });
        // CGAL's mesher grows the surface from one seed: a separate part of the cloud is left
        // out without a word. Refuse a surface that misses a share of the points.
        const double covered = detail::fraction_of_points_near(mesh, points, kCoverageReach * spacing);
        if (covered < kLeastCoverage)
            throw Error("point cloud", "the Poisson surface covers only " + std::to_string(int(covered * 100)) +
                                           "% of the points: a separate part was left out (mesh each part on its "
                                           "own, or use --method advancing-front)");
        report(0.7, "projecting onto the points");
        onto_points(mesh, surface, spacing);
        mark_measured(mesh, points, measured_reach);
        if (options.fill == MeshFill::Table) {
            report(0.75, "closing at the table");
            const TablePlane table = find_table(mesh, points, options.table_axis, spacing);
            const std::vector<detail::PointWithNormal> walls = walls_down_to_table(points, table, spacing);
            if (!walls.empty()) {
                std::vector<detail::PointWithNormal> extended = surface;
                extended.insert(extended.end(), walls.begin(), walls.end());
                mesh = detail::poisson_mesh(extended, settings, [&](double fraction, const char* stage) {
                    report(0.75 + fraction * 0.1 / 0.7, stage);
                });
                onto_points(mesh, extended, spacing);
            }
            mesh = detail::clip_at_plane(mesh, table.up, table.height, std::max(3 * spacing, 1.0), spacing * spacing);
        }
        // Last, on the surface that stays: the cut at the table needs a mesh that does not cross
        // itself, and the sharpening only moves vertices where that stays so.
        report(0.8, "sharpening edges");
        if (detail::sharpen_edges(mesh, points, spacing).undone)
            report(0.8, "sharpening undone: it made faces cross each other (the edges stay as Poisson rounded them)");
    } else {
        report(0.2, "advancing-front reconstruction");
        mesh = detail::advancing_front_mesh(points, spacing, options.advancing_front_max_radius);
        if (options.max_hole_diameter_mm > 0) {
            report(0.7, "filling small holes");
            mesh = detail::fill_small_holes(mesh, options.max_hole_diameter_mm);
        }
    }
    if (mesh.faces.empty()) throw Error("point cloud", "meshing produced no triangles");
    if (options.target_faces > 0 && static_cast<int>(mesh.faces.size()) > options.target_faces) {
        report(0.85, "simplifying");
        mesh = detail::simplify(mesh, options.target_faces);
    }
    mark_measured(mesh, points, measured_reach);
    colour_from_points(mesh, cloud, std::max(2.0 * spacing, 1.0));
    report(1.0, "meshed");
    return mesh;
}

MeshFill mesh_fill_from_name(const std::string& name, const std::string& what) {
    if (name == "open") return MeshFill::Open;
    if (name == "table") return MeshFill::Table;
    if (name == "poisson") return MeshFill::Poisson;
    throw Error(what, "must be open, table or poisson, got '" + name + "'");
}

}  // namespace picoscan
