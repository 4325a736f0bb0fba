// Point preparation and Poisson surface reconstruction (Kazhdan et al. 2006, CGAL's
// Delaunay-refinement implementation), then a projection of the surface back onto the points.
#define CGAL_EIGEN3_ENABLED 1
#include "mesh/cgal_types.h"
#include "common/third_party_output.h"
#include "picoscan/error.h"

#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/compute_average_spacing.h>
#include <CGAL/grid_simplify_point_set.h>
#include <CGAL/pca_estimate_normals.h>
#include <CGAL/poisson_surface_reconstruction.h>
#include <CGAL/property_map.h>

#include <opencv2/core.hpp>
#include <algorithm>
#include <cmath>
#include <map>

namespace picoscan::detail {

namespace {
using PointMap = CGAL::First_of_pair_property_map<PointWithNormal>;
using NormalMap = CGAL::Second_of_pair_property_map<PointWithNormal>;
}  // namespace

std::vector<PointWithNormal> prepare_points(const PointCloud& cloud, double spacing_mm, double& average_spacing_mm) {
    std::vector<PointWithNormal> points;
    points.reserve(cloud.points.size());
    const bool has_normals = cloud.normals.size() == cloud.points.size();
    size_t without_normal = 0;
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        const cv::Vec3f& p = cloud.points[i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
        const cv::Vec3f n = has_normals ? cloud.normals[i] : cv::Vec3f(0, 0, 0);
        // The given normal says which side the sensor saw; without it a PCA normal's sign is a guess.
        if (has_normals && !(std::isfinite(n[0]) && std::isfinite(n[1]) && std::isfinite(n[2]) && cv::norm(n) > 0)) {
            ++without_normal;
            continue;
        }
        points.emplace_back(Point3(p[0], p[1], p[2]), Vector3(n[0], n[1], n[2]));
    }
    if (has_normals && without_normal * 10 > points.size() + without_normal)
        throw Error("point cloud", std::to_string(without_normal) + " of " +
                                       std::to_string(points.size() + without_normal) +
                                       " points have no valid normal (NaN or zero): their outside is unknown");
    if (spacing_mm > 0) {
        points.erase(CGAL::grid_simplify_point_set(points, spacing_mm, CGAL::parameters::point_map(PointMap())), points.end());
    } else {
        // Coincident points have no spacing to mesh at (and crash the reconstruction).
        std::sort(points.begin(), points.end(), [](const PointWithNormal& a, const PointWithNormal& b) { return a.first < b.first; });
        points.erase(std::unique(points.begin(), points.end(),
                                 [](const PointWithNormal& a, const PointWithNormal& b) { return a.first == b.first; }),
                     points.end());
    }
    if (points.size() < 20) return points;
    // Re-estimated normals are smoother than per-pixel ones; the sensor's side says which way.
    std::vector<Vector3> sensor_side;
    sensor_side.reserve(points.size());
    for (const PointWithNormal& p : points) sensor_side.push_back(p.second);
    CGAL::pca_estimate_normals<CGAL::Parallel_if_available_tag>(
        points, 18, CGAL::parameters::point_map(PointMap()).normal_map(NormalMap()));
    for (size_t i = 0; i < points.size(); ++i) {
        Vector3& n = points[i].second;
        const double length = std::sqrt(n.squared_length());
        if (length > 0) n = n / length;
        if (has_normals && n * sensor_side[i] < 0) n = -n;
    }
    average_spacing_mm = CGAL::compute_average_spacing<CGAL::Parallel_if_available_tag>(
        points, 6, CGAL::parameters::point_map(PointMap()));
    return points;
}

Mesh poisson_mesh(const std::vector<PointWithNormal>& points, double spacing_mm, double triangle_size, double distance) {
    SurfaceMesh surface;
    ThirdPartyOutput cgal;  // CGAL prints its solver's complaints on stderr
    if (!CGAL::poisson_surface_reconstruction_delaunay(points.begin(), points.end(), PointMap(), NormalMap(), surface,
                                                       spacing_mm, 20.0, triangle_size, distance))
        throw Error("Poisson reconstruction", "the implicit function could not be solved (are the normals consistent?)" +
                                                  attached(cgal.text(), "CGAL"));
    return to_mesh(surface);
}

double fraction_of_points_near(const Mesh& mesh, const std::vector<PointWithNormal>& points, double reach_mm) {
    using Traits = CGAL::Search_traits_3<Kernel>;
    using Search = CGAL::Orthogonal_k_neighbor_search<Traits>;
    if (mesh.vertices.empty() || points.empty()) return 0;
    std::vector<Point3> vertices;
    vertices.reserve(mesh.vertices.size());
    for (const cv::Vec3f& v : mesh.vertices) vertices.emplace_back(v[0], v[1], v[2]);
    const Search::Tree tree(vertices.begin(), vertices.end());
    size_t near = 0;
    for (const PointWithNormal& point : points) {
        Search search(tree, point.first, 1);
        if (search.begin() != search.end() && search.begin()->second <= reach_mm * reach_mm) ++near;
    }
    return double(near) / double(points.size());
}

void project_onto_points(Mesh& mesh, const std::vector<PointWithNormal>& points, double reach_mm) {
    using Traits = CGAL::Search_traits_3<Kernel>;
    using Search = CGAL::Orthogonal_k_neighbor_search<Traits>;
    std::vector<Point3> cloud;
    std::map<Point3, size_t> index_of;
    cloud.reserve(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
        cloud.push_back(points[i].first);
        index_of.emplace(points[i].first, i);
    }
    const Search::Tree tree(cloud.begin(), cloud.end());
    const int neighbours = 16;
    const double same_face = std::cos(20.0 * CV_PI / 180.0);
    for (cv::Vec3f& vertex : mesh.vertices) {
        const Point3 query(vertex[0], vertex[1], vertex[2]);
        Search search(tree, query, neighbours);
        // The plane of the face the nearest point lies on: only neighbours whose normals agree
        // with the nearest one's, so a vertex near a sharp edge goes to its face, not a bevel.
        std::vector<cv::Vec3d> near;
        Vector3 nearest_normal(0, 0, 0);
        for (const auto& found : search) {
            if (found.second > reach_mm * reach_mm) break;
            const Vector3& n = points[index_of.at(found.first)].second;
            if (near.empty()) nearest_normal = n;
            else if (n * nearest_normal < same_face) continue;
            near.emplace_back(found.first.x(), found.first.y(), found.first.z());
        }
        if (near.size() < 6) continue;  // unsupported by data (a closed-over gap): leave it
        cv::Vec3d centre(0, 0, 0);
        for (const cv::Vec3d& p : near) centre += p;
        centre *= 1.0 / static_cast<double>(near.size());
        cv::Matx33d scatter = cv::Matx33d::zeros();
        for (const cv::Vec3d& p : near) scatter += (p - centre) * (p - centre).t();
        cv::Matx31d eigenvalues;
        cv::Matx33d eigenvectors;
        cv::eigen(scatter, eigenvalues, eigenvectors);
        const cv::Vec3d normal(eigenvectors(2, 0), eigenvectors(2, 1), eigenvectors(2, 2));
        const cv::Vec3d v(vertex);
        vertex = cv::Vec3f(v - normal * normal.dot(v - centre));
    }
}

}  // namespace picoscan::detail
