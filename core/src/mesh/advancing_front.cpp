// Advancing-front surface reconstruction (Cohen-Steiner & Da, 2004) for open surfaces:
// it interpolates the points and leaves holes where nothing was measured.
#include "common/text_format.h"
#include "mesh/cgal_types.h"
#include "picoscan/error.h"

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <algorithm>
#include <array>
#include <cmath>

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
    // CGAL's advancing_front_surface_reconstruction(), spelled out so that a triangulation
    // that stays flat is refused here instead of CGAL printing "not 3D" and returning nothing.
    using Vertex = CGAL::Advancing_front_surface_reconstruction_vertex_base_3<Kernel>;
    using Cell = CGAL::Advancing_front_surface_reconstruction_cell_base_3<Kernel>;
    using Delaunay = CGAL::Delaunay_triangulation_3<Kernel, CGAL::Triangulation_data_structure_3<Vertex, Cell>>;
    std::vector<std::pair<Point3, std::size_t>> indexed;
    indexed.reserve(points.size());
    for (const PointWithNormal& p : points) indexed.emplace_back(p.first, indexed.size());
    Delaunay triangulation(indexed.begin(), indexed.end());
    const SmallTriangles priority{max_radius * spacing_mm};
    // A flat cloud gets one point lifted about 10 mm off its plane; far from the origin the lift
    // is lost to rounding and the triangulation stays flat (found at 1e20 mm).
    CGAL::Advancing_front_surface_reconstruction<Delaunay, SmallTriangles> reconstruction(triangulation, priority);
    if (triangulation.dimension() < 3) {
        double farthest = 0;
        for (const PointWithNormal& p : points)
            farthest = std::max(farthest, std::sqrt(p.first.x() * p.first.x() + p.first.y() * p.first.y() + p.first.z() * p.first.z()));
        throw Error("point cloud", "is flat and lies " + format("%.3g", farthest) +
                                       " mm from the origin, too far to be triangulated in 3D: bring it near the origin");
    }
    reconstruction.run();
    std::vector<std::array<std::size_t, 3>> faces;
    CGAL::write_triple_indices(std::back_inserter(faces), reconstruction);
    Mesh mesh;
    for (const PointWithNormal& p : points)
        mesh.vertices.emplace_back(static_cast<float>(p.first.x()), static_cast<float>(p.first.y()), static_cast<float>(p.first.z()));
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
