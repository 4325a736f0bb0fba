// Advancing-front surface reconstruction (Cohen-Steiner & Da, 2004) for open surfaces:
// it interpolates the points and leaves holes where nothing was measured.
#include "mesh/cgal_types.h"

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <array>

namespace picoscan::detail {

namespace {

// Rejects triangles much larger than the point spacing (they would bridge gaps).
struct SmallTriangles {
    double max_radius_mm;
    template <class AdvancingFront, class CellHandle>
    double operator()(const AdvancingFront& front, CellHandle& cell, const int& index) const {
        const auto& a = cell->vertex((index + 1) % 4)->point();
        const auto& b = cell->vertex((index + 2) % 4)->point();
        const auto& c = cell->vertex((index + 3) % 4)->point();
        const double radius2 = CGAL::squared_radius(a, b, c);
        if (radius2 > max_radius_mm * max_radius_mm) return front.infinity();
        return front.smallest_radius_delaunay_sphere(cell, index);
    }
};

}  // namespace

Mesh advancing_front_mesh(const std::vector<PointWithNormal>& points, double spacing_mm, double max_radius) {
    std::vector<Point3> cloud;
    cloud.reserve(points.size());
    for (const PointWithNormal& p : points) cloud.push_back(p.first);
    std::vector<std::array<std::size_t, 3>> faces;
    const SmallTriangles priority{max_radius * spacing_mm};
    CGAL::advancing_front_surface_reconstruction(cloud.begin(), cloud.end(), std::back_inserter(faces), priority);
    Mesh mesh;
    for (const Point3& p : cloud)
        mesh.vertices.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    // Turn each triangle to face the side its points were seen from.
    for (const auto& f : faces) {
        const cv::Vec3f &a = mesh.vertices[f[0]], &b = mesh.vertices[f[1]], &c = mesh.vertices[f[2]];
        const cv::Vec3f normal = (b - a).cross(c - a);
        Vector3 seen = points[f[0]].second + points[f[1]].second + points[f[2]].second;
        const bool flip = normal[0] * seen.x() + normal[1] * seen.y() + normal[2] * seen.z() < 0;
        if (flip) mesh.faces.emplace_back(static_cast<int>(f[0]), static_cast<int>(f[2]), static_cast<int>(f[1]));
        else mesh.faces.emplace_back(static_cast<int>(f[0]), static_cast<int>(f[1]), static_cast<int>(f[2]));
    }
    return mesh;
}

}  // namespace picoscan::detail
