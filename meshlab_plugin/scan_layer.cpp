#include "scan_layer.h"

#include <cmath>
#include <limits>

namespace picoscan_meshlab {

namespace {

const char* const kPixelAttribute = "picoscan_pixel";
const char* const kGridAttribute = "picoscan_grid";

using PixelHandle = CMeshO::PerVertexAttributeHandle<int>;
using GridHandle = CMeshO::PerMeshAttributeHandle<ScanGrid>;

bool finite_point(const cv::Vec3f& p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

}  // namespace

void fill_layer(MeshModel& layer, const picoscan::ScanView& view, double focal_px) {
    CMeshO& mesh = layer.cm;
    layer.updateDataMask(MeshModel::MM_VERTCOLOR | MeshModel::MM_VERTQUALITY | MeshModel::MM_VERTNORMAL);
    const bool has_normals = !view.normals.empty(), has_colours = !view.colours.empty(),
               has_quality = !view.quality.empty();
    auto vertex = vcg::tri::Allocator<CMeshO>::AddVertices(mesh, size_t(view.valid_count()));
    PixelHandle pixels = vcg::tri::Allocator<CMeshO>::GetPerVertexAttribute<int>(mesh, kPixelAttribute);
    for (int y = 0; y < view.points.rows; ++y)
        for (int x = 0; x < view.points.cols; ++x) {
            const cv::Vec3f& p = view.points.at<cv::Vec3f>(y, x);
            if (!finite_point(p)) continue;
            vertex->P() = Point3m(p[0], p[1], p[2]);
            if (has_normals) {
                const cv::Vec3f& n = view.normals.at<cv::Vec3f>(y, x);
                vertex->N() = finite_point(n) ? Point3m(n[0], n[1], n[2]) : Point3m(0, 0, -1);
            }
            if (has_colours) {
                const cv::Vec3b& bgr = view.colours.at<cv::Vec3b>(y, x);
                vertex->C() = vcg::Color4b(bgr[2], bgr[1], bgr[0], 255);
            } else {
                vertex->C() = vcg::Color4b(200, 200, 200, 255);
            }
            vertex->Q() = has_quality ? view.quality.at<float>(y, x) : 0.f;
            pixels[*vertex] = y * view.points.cols + x;
            ++vertex;
        }
    GridHandle grid = vcg::tri::Allocator<CMeshO>::GetPerMeshAttribute<ScanGrid>(mesh, kGridAttribute);
    grid() = ScanGrid{view.points.cols, view.points.rows, focal_px};
    set_layer_pose(layer, view.pose);
    vcg::tri::UpdateBounding<CMeshO>::Box(mesh);
}

void fill_layer(MeshModel& layer, const picoscan::Mesh& source) {
    CMeshO& mesh = layer.cm;
    const bool has_normals = source.normals.size() == source.vertices.size(),
               has_colours = source.colours.size() == source.vertices.size();
    if (has_colours) layer.updateDataMask(MeshModel::MM_VERTCOLOR);
    auto vertex = vcg::tri::Allocator<CMeshO>::AddVertices(mesh, source.vertices.size());
    CVertexO* first_vertex = &*vertex;
    for (size_t i = 0; i < source.vertices.size(); ++i, ++vertex) {
        const cv::Vec3f& p = source.vertices[i];
        vertex->P() = Point3m(p[0], p[1], p[2]);
        if (has_normals) vertex->N() = Point3m(source.normals[i][0], source.normals[i][1], source.normals[i][2]);
        if (has_colours) vertex->C() = vcg::Color4b(source.colours[i][0], source.colours[i][1], source.colours[i][2], 255);
    }
    auto face = vcg::tri::Allocator<CMeshO>::AddFaces(mesh, source.faces.size());
    for (const cv::Vec3i& indices : source.faces) {
        for (int corner = 0; corner < 3; ++corner) face->V(corner) = first_vertex + indices[corner];
        ++face;
    }
    vcg::tri::UpdateNormal<CMeshO>::PerFaceNormalized(mesh);
    if (!has_normals) vcg::tri::UpdateNormal<CMeshO>::PerVertexNormalized(mesh);
    vcg::tri::UpdateBounding<CMeshO>::Box(mesh);
}

bool has_scan_grid(MeshModel& layer) {
    CMeshO& mesh = layer.cm;
    PixelHandle pixels = vcg::tri::Allocator<CMeshO>::FindPerVertexAttribute<int>(mesh, kPixelAttribute);
    GridHandle grid = vcg::tri::Allocator<CMeshO>::FindPerMeshAttribute<ScanGrid>(mesh, kGridAttribute);
    return vcg::tri::Allocator<CMeshO>::IsValidHandle(mesh, pixels) &&
           vcg::tri::Allocator<CMeshO>::IsValidHandle(mesh, grid) && grid().width > 0 && grid().height > 0;
}

LayerView layer_view(MeshModel& layer) {
    CMeshO& mesh = layer.cm;
    PixelHandle pixels = vcg::tri::Allocator<CMeshO>::FindPerVertexAttribute<int>(mesh, kPixelAttribute);
    GridHandle grid = vcg::tri::Allocator<CMeshO>::FindPerMeshAttribute<ScanGrid>(mesh, kGridAttribute);
    const int width = grid().width, height = grid().height;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    LayerView result;
    result.focal_px = grid().focal_px;
    picoscan::ScanView& view = result.view;
    // The grid keeps only the focal length; the principal point is taken at the image centre.
    view.camera_matrix = cv::Matx33d(result.focal_px, 0, (width - 1) / 2.0, 0, result.focal_px, (height - 1) / 2.0, 0, 0, 1);
    view.points.create(height, width, CV_32FC3);
    view.points.setTo(cv::Scalar::all(nan));
    view.normals.create(height, width, CV_32FC3);
    view.normals.setTo(cv::Scalar::all(nan));
    view.colours = cv::Mat(height, width, CV_8UC3, cv::Scalar::all(0));
    view.quality = cv::Mat(height, width, CV_32F, cv::Scalar(0));
    for (CVertexO& vertex : mesh.vert) {
        if (vertex.IsD()) continue;
        const int pixel = pixels[vertex];
        if (pixel < 0 || pixel >= width * height) continue;
        const int y = pixel / width, x = pixel % width;
        view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(vertex.P()[0], vertex.P()[1], vertex.P()[2]);
        view.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(vertex.N()[0], vertex.N()[1], vertex.N()[2]);
        view.colours.at<cv::Vec3b>(y, x) = cv::Vec3b(vertex.C()[2], vertex.C()[1], vertex.C()[0]);
        view.quality.at<float>(y, x) = vertex.Q();
    }
    view.pose = layer_pose(layer);
    return result;
}

int remove_vertices_missing_from(MeshModel& layer, const picoscan::ScanView& view) {
    CMeshO& mesh = layer.cm;
    PixelHandle pixels = vcg::tri::Allocator<CMeshO>::FindPerVertexAttribute<int>(mesh, kPixelAttribute);
    const int width = view.points.cols;
    int deleted = 0;
    for (CVertexO& vertex : mesh.vert) {
        if (vertex.IsD()) continue;
        const int pixel = pixels[vertex];
        if (finite_point(view.points.at<cv::Vec3f>(pixel / width, pixel % width))) continue;
        vcg::tri::Allocator<CMeshO>::DeleteVertex(mesh, vertex);
        ++deleted;
    }
    for (CFaceO& face : mesh.face)
        if (!face.IsD() && (face.V(0)->IsD() || face.V(1)->IsD() || face.V(2)->IsD()))
            vcg::tri::Allocator<CMeshO>::DeleteFace(mesh, face);
    vcg::tri::Allocator<CMeshO>::CompactEveryVector(mesh);
    vcg::tri::UpdateBounding<CMeshO>::Box(mesh);
    return deleted;
}

std::vector<cv::Vec3f> layer_points(MeshModel& layer, bool apply_transform, bool selected_only) {
    std::vector<cv::Vec3f> points;
    points.reserve(size_t(layer.cm.vn));
    for (const CVertexO& vertex : layer.cm.vert) {
        if (vertex.IsD() || (selected_only && !vertex.IsS())) continue;
        const Point3m p = apply_transform ? layer.cm.Tr * vertex.cP() : vertex.cP();
        points.emplace_back(p[0], p[1], p[2]);
    }
    return points;
}

cv::Matx44d layer_pose(MeshModel& layer) {
    cv::Matx44d pose;
    for (int row = 0; row < 4; ++row)
        for (int column = 0; column < 4; ++column) pose(row, column) = layer.cm.Tr.ElementAt(row, column);
    return pose;
}

void set_layer_pose(MeshModel& layer, const cv::Matx44d& pose) {
    for (int row = 0; row < 4; ++row)
        for (int column = 0; column < 4; ++column) layer.cm.Tr.ElementAt(row, column) = Scalarm(pose(row, column));
}

}  // namespace picoscan_meshlab
