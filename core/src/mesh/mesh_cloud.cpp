// mesh_cloud: prepare the points, reconstruct, fill small holes, simplify.
#include "mesh/cgal_types.h"
#include "picoscan/error.h"
#include "picoscan/mesh.h"

#include <opencv2/core.hpp>
#include <cmath>

namespace picoscan {

Mesh mesh_cloud(const PointCloud& cloud, const MeshOptions& options, const ProgressCallback& progress) {
    auto report = [&](double fraction, const char* stage) {
        if (progress && !progress(fraction, stage)) throw Error("cancelled", "meshing cancelled");
    };
    if (options.method == MeshMethod::Grid)
        throw Error("method", "grid meshing joins the pixels of one view: use mesh_view or grid_mesh");
    if (cloud.points.empty()) throw Error("point cloud", "is empty: nothing to mesh");
    if (cloud.normals.size() != cloud.points.size())
        throw Error("point cloud", "has no normals; mesh a cloud written by picoscan (reconstruct or stitch)");
    report(0.0, "estimating normals");
    double spacing = 0;
    const std::vector<detail::PointWithNormal> points = detail::prepare_points(cloud, options.sample_spacing_mm, spacing);
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
    if (width < 2 * spacing) throw Error("point cloud", "is degenerate (its points lie along a line)");
    if (options.method == MeshMethod::Poisson && thickness < 0.5 * spacing)
        throw Error("point cloud", "is flat (all points on one plane): Poisson needs a closed shape; use --method advancing-front or grid");

    Mesh mesh;
    if (options.method == MeshMethod::Poisson) {
        report(0.2, "Poisson reconstruction");
        mesh = detail::poisson_mesh(points, spacing, options.poisson_triangle_size, options.poisson_distance);
        report(0.7, "projecting onto the points");
        const Mesh smooth = mesh;
        detail::project_onto_points(mesh, points, 2.0 * spacing);
        // Where moving vertices onto their faces folded triangles through each other (at
        // tight concave edges), those vertices go back to the smooth surface.
        for (int round = 0; round < 5; ++round) {
            const std::vector<int> folded = detail::self_intersecting_faces(mesh);
            if (folded.empty()) break;
            for (int f : folded)
                for (int k = 0; k < 3; ++k) mesh.vertices[mesh.faces[f][k]] = smooth.vertices[mesh.faces[f][k]];
        }
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
    report(1.0, "meshed");
    return mesh;
}

}  // namespace picoscan
