// grid_mesh: triangulates the pixel grid of an organised view, without bridging depth
// discontinuities.
#include "cloud/view_check.h"
#include "common/parallel.h"
#include "picoscan/cloud.h"
#include "picoscan/error.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

namespace picoscan {

namespace {

struct GridJoiner {
    const cv::Mat& points;
    double factor_over_focal;  // max_edge_factor / focal: edge limit per mm of depth

    const cv::Vec3f& at(int index) const {
        return points.ptr<cv::Vec3f>(index / points.cols)[index % points.cols];
    }
    bool edge_ok(int i, int j) const {
        const cv::Vec3f& p = at(i);
        const cv::Vec3f& q = at(j);
        const double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        // One pixel's footprint at the edge's mean depth.
        const double limit = factor_over_focal * 0.5 * (std::abs(p[2]) + std::abs(q[2]));
        return dx * dx + dy * dy + dz * dz < limit * limit;
    }
    double distance2(int i, int j) const {
        const cv::Vec3f d = at(i) - at(j);
        return static_cast<double>(d.dot(d));
    }
    void add(std::vector<cv::Vec3i>& faces, int i, int j, int k) const {
        if (edge_ok(i, j) && edge_ok(j, k) && edge_ok(k, i)) faces.emplace_back(i, j, k);
    }
};

}  // namespace

Mesh grid_mesh(const ScanView& view, const GridMeshOptions& options) {
    const detail::ViewLayers layers = detail::check_view(view);
    if (view.points.empty()) return {};
    const double camera_focal_px = view.focal_px();
    if (!(options.max_edge_factor > 0) || !std::isfinite(options.max_edge_factor))
        throw Error("grid_mesh", "max_edge_factor must be positive");

    if (options.pixel_step < 1 || options.pixel_step > 64) throw Error("grid_mesh", "pixel_step must be 1..64");
    if (options.pixel_step > 1) {
        // Every n-th pixel of every n-th row, meshed as a view seen with an n times shorter focal length.
        const int step = options.pixel_step;
        ScanView sparse;
        sparse.pose = view.pose;
        // The same camera with n times larger pixels.
        sparse.camera_matrix = view.camera_matrix;
        for (int c = 0; c < 3; ++c) sparse.camera_matrix(0, c) /= step, sparse.camera_matrix(1, c) /= step;
        auto every_nth = [step](const cv::Mat& layer) {
            if (layer.empty()) return cv::Mat();
            cv::Mat result((layer.rows + step - 1) / step, (layer.cols + step - 1) / step, layer.type());
            for (int y = 0; y < result.rows; ++y)
                for (int x = 0; x < result.cols; ++x)
                    std::memcpy(result.ptr(y, x), layer.ptr(y * step, x * step), layer.elemSize());
            return result;
        };
        sparse.points = every_nth(view.points);
        sparse.normals = every_nth(view.normals);
        sparse.colours = every_nth(view.colours);
        sparse.quality = every_nth(view.quality);
        GridMeshOptions dense = options;
        dense.pixel_step = 1;
        return grid_mesh(sparse, dense);
    }

    Mesh mesh;
    const int rows = view.points.rows, cols = view.points.cols;
    if (view.points.empty() || rows < 2 || cols < 2) return mesh;
    if (static_cast<long long>(rows) * cols > std::numeric_limits<int>::max())
        throw Error("grid_mesh", "view too large");

    const GridJoiner joiner{view.points, options.max_edge_factor / camera_focal_px};

    // Faces first as pixel indices (y * cols + x), one list per quad row.
    // Camera frame: x right, y down, z forward. For quad corners a (x,y), b (x+1,y),
    // c (x,y+1), d (x+1,y+1) the order a -> c -> b is counter-clockwise seen from the
    // camera, so the winding normal points back at it.
    std::vector<std::vector<cv::Vec3i>> row_faces(static_cast<size_t>(rows - 1));
    detail::parallel_rows(rows - 1, [&](int begin, int end) {
        for (int y = begin; y < end; ++y) {
            std::vector<cv::Vec3i>& faces = row_faces[static_cast<size_t>(y)];
            const cv::Vec3f* top = view.points.ptr<cv::Vec3f>(y);
            const cv::Vec3f* bottom = view.points.ptr<cv::Vec3f>(y + 1);
            for (int x = 0; x + 1 < cols; ++x) {
                const bool va = is_finite_point(top[x]), vb = is_finite_point(top[x + 1]);
                const bool vc = is_finite_point(bottom[x]), vd = is_finite_point(bottom[x + 1]);
                const int valid = va + vb + vc + vd;
                if (valid < 3) continue;
                const int a = y * cols + x, b = a + 1, c = a + cols, d = c + 1;
                if (valid == 4) {
                    // The shorter diagonal gives better-shaped triangles and, at a corner
                    // of a step, the one that keeps the odd corner out.
                    if (joiner.distance2(b, c) <= joiner.distance2(a, d)) {
                        joiner.add(faces, a, c, b);
                        joiner.add(faces, b, c, d);
                    } else {
                        joiner.add(faces, a, d, b);
                        joiner.add(faces, a, c, d);
                    }
                } else if (!vd) {
                    joiner.add(faces, a, c, b);
                } else if (!va) {
                    joiner.add(faces, b, c, d);
                } else if (!vb) {
                    joiner.add(faces, a, c, d);
                } else {
                    joiner.add(faces, a, d, b);
                }
            }
        }
    });

    // Compact index map: only pixels that some face uses become vertices (row-major).
    std::vector<int> index_of(static_cast<size_t>(rows) * cols, -1);
    size_t face_count = 0;
    for (const auto& faces : row_faces) {
        face_count += faces.size();
        for (const cv::Vec3i& face : faces)
            for (int k = 0; k < 3; ++k) index_of[static_cast<size_t>(face[k])] = 0;
    }
    int vertex_count = 0;
    for (int& index : index_of)
        if (index == 0) index = vertex_count++;

    mesh.vertices.resize(static_cast<size_t>(vertex_count));
    if (layers.normals) mesh.normals.resize(static_cast<size_t>(vertex_count));
    if (layers.colours) mesh.colours.resize(static_cast<size_t>(vertex_count));
    const cv::Matx33d rotation = view.pose.get_minor<3, 3>(0, 0);
    const cv::Vec3d translation(view.pose(0, 3), view.pose(1, 3), view.pose(2, 3));
    detail::parallel_rows(rows, [&](int begin, int end) {
        for (int y = begin; y < end; ++y) {
            for (int x = 0; x < cols; ++x) {
                const int index = index_of[static_cast<size_t>(y) * cols + x];
                if (index < 0) continue;
                mesh.vertices[index] = cv::Vec3f(rotation * cv::Vec3d(view.points.at<cv::Vec3f>(y, x)) + translation);
                if (layers.normals)
                    mesh.normals[index] = cv::Vec3f(rotation * cv::Vec3d(view.normals.at<cv::Vec3f>(y, x)));
                if (layers.colours) {
                    const cv::Vec3b bgr = view.colours.at<cv::Vec3b>(y, x);
                    mesh.colours[index] = cv::Vec3b(bgr[2], bgr[1], bgr[0]);
                }
            }
        }
    });

    mesh.faces.reserve(face_count);
    for (const auto& faces : row_faces)
        for (const cv::Vec3i& face : faces)
            mesh.faces.emplace_back(index_of[static_cast<size_t>(face[0])], index_of[static_cast<size_t>(face[1])],
                                    index_of[static_cast<size_t>(face[2])]);
    return mesh;
}

}  // namespace picoscan
