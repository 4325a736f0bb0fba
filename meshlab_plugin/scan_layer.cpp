#include "scan_layer.h"

#include "picoscan/io.h"

#include <wrap/io_trimesh/io_mask.h>

#include <QDir>
#include <QFile>
#include <QFileInfo>

#include <algorithm>
#include <cmath>
#include <limits>

namespace picoscan_meshlab {

namespace {

const char* const kCameraAttribute = "picoscan_camera";

using CameraHandle = CMeshO::PerMeshAttributeHandle<LayerCamera>;

bool finite_point(const cv::Vec3f& p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

bool has_camera_attribute(CMeshO& mesh) {
    CameraHandle camera = vcg::tri::Allocator<CMeshO>::FindPerMeshAttribute<LayerCamera>(mesh, kCameraAttribute);
    return vcg::tri::Allocator<CMeshO>::IsValidHandle(mesh, camera) && camera().width > 0 && camera().height > 0;
}

// MeshLab's camera of a layer (cm.shot, which MeshLab writes into PLY) holds four distortion
// coefficients, k[0..3]: OpenCV's k1 k2 p1 p2. k3, which OpenCV's calibration fits by default, is
// kept in the one free value MeshLab also saves: only focal / pixel size is the focal length in
// pixels, so the pixel size along x is exp(k3) (1 for k3 = 0, as layers of older versions have it).
// A lens with more coefficients (rational, thin prism, tilt) gets no MeshLab camera: reopened
// without its view file such a layer is refused, rather than given another lens.
const int kShotDistortionCount = 5;

// MeshLab's camera of a layer read from a file: focal in pixels = FocalMm / PixelSizeMm.
bool has_shot(MeshModel& layer) {
    const auto& intrinsics = layer.cm.shot.Intrinsics;
    return intrinsics.ViewportPx[0] > 0 && intrinsics.ViewportPx[1] > 0 && intrinsics.FocalMm > 0 &&
           intrinsics.PixelSizeMm[0] > 0 && intrinsics.PixelSizeMm[1] > 0;
}

LayerCamera layer_camera(MeshModel& layer) {
    CMeshO& mesh = layer.cm;
    if (has_camera_attribute(mesh))
        return vcg::tri::Allocator<CMeshO>::FindPerMeshAttribute<LayerCamera>(mesh, kCameraAttribute)();
    const auto& intrinsics = mesh.shot.Intrinsics;
    LayerCamera camera;
    camera.width = intrinsics.ViewportPx[0];
    camera.height = intrinsics.ViewportPx[1];
    const double fx = intrinsics.FocalMm / intrinsics.PixelSizeMm[0], fy = intrinsics.FocalMm / intrinsics.PixelSizeMm[1];
    const double matrix[9] = {fx, 0, intrinsics.CenterPx[0], 0, fy, intrinsics.CenterPx[1], 0, 0, 1};
    std::copy(matrix, matrix + 9, camera.matrix);
    camera.distortion_count = kShotDistortionCount;
    for (int i = 0; i < 4; ++i) camera.distortion[i] = intrinsics.k[i];
    camera.distortion[4] = std::log(double(intrinsics.PixelSizeMm[0]));
    return camera;
}

// A layer read from a PLY with MeshLab's camera element (as the GUI saves a layer by default) has the
// camera in cm.shot, but MeshLab does not mark the layer as having one (its PLY reader's load mask
// leaves the camera out). So the camera is judged by the points: each sampled vertex's texture
// coordinates must be a whole pixel of the viewport, and the camera must see the vertex there
// (median reprojection error below half a pixel). A textured mesh's UVs, or a camera of another
// program, fail this.
bool has_saved_camera(MeshModel& layer) {
    if (!layer.hasDataMask(MeshModel::MM_VERTTEXCOORD) || !has_shot(layer) || layer.cm.vn == 0) return false;
    const LayerCamera camera = layer_camera(layer);
    const double fx = camera.matrix[0], fy = camera.matrix[4], cx = camera.matrix[2], cy = camera.matrix[5];
    const double k1 = camera.distortion[0], k2 = camera.distortion[1], p1 = camera.distortion[2], p2 = camera.distortion[3],
                 k3 = camera.distortion[4];
    const int step = std::max(1, layer.cm.vn / 20000);
    std::vector<double> errors;
    int index = 0;
    for (const CVertexO& vertex : layer.cm.vert) {
        if (vertex.IsD() || index++ % step != 0) continue;
        const double u = vertex.cT().U(), v = vertex.cT().V(), z = vertex.cP()[2];
        if (std::abs(u - std::round(u)) > 1e-3 || std::abs(v - std::round(v)) > 1e-3 || u < 0 || v < 0 ||
            u >= camera.width || v >= camera.height || !(z > 0))
            return false;
        const double x = vertex.cP()[0] / z, y = vertex.cP()[1] / z, r2 = x * x + y * y;
        const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
        const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
        const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
        errors.push_back(std::hypot(fx * xd + cx - u, fy * yd + cy - v));
    }
    if (errors.empty()) return false;
    std::nth_element(errors.begin(), errors.begin() + long(errors.size() / 2), errors.end());
    return errors[errors.size() / 2] < 0.5;
}

// meshlabserver -w (2020.09) saves every layer with its MeshLab data mask (MM_*) handed to the PLY
// writer as a file mask (IOM_*), whose bits mean other things: MM_VERTMARK is read as texture
// coordinates (the pixels), MM_FACECOLOR as the camera (MM_VERTQUALITY, which a PicoScan layer has,
// as normals). A PicoScan layer enables those two, so a project saved by meshlabserver keeps its
// pixel grid and camera. The GUI's save dialog reads the mask right. A point cloud has no faces to
// colour: the extra bits cost a mark per vertex, and at most face colour properties of no face.
void keep_grid_in_meshlabserver_saves(MeshModel& layer) {
    static_assert(int(MeshModel::MM_VERTMARK) == int(vcg::tri::io::Mask::IOM_VERTTEXCOORD) &&
                      int(MeshModel::MM_FACECOLOR) == int(vcg::tri::io::Mask::IOM_CAMERA) &&
                      int(MeshModel::MM_VERTQUALITY) == int(vcg::tri::io::Mask::IOM_VERTNORMAL),
                  "the masks meshlabserver confuses");
    layer.updateDataMask(MeshModel::MM_VERTMARK | MeshModel::MM_FACECOLOR);
}

// The pixel a vertex came from (its texture coordinates), or -1 outside the grid.
int vertex_pixel(const CVertexO& vertex, int width, int height) {
    const int x = int(std::lround(vertex.cT().U())), y = int(std::lround(vertex.cT().V()));
    return x >= 0 && x < width && y >= 0 && y < height ? y * width + x : -1;
}

// Stores the view's camera on the layer: in full as the attribute, and as MeshLab's camera of
// the layer (saved in PLY; see kShotDistortionCount), for which the view's camera sits at the
// origin of the vertices' frame.
void set_layer_camera(MeshModel& layer, const picoscan::ScanView& view) {
    CMeshO& mesh = layer.cm;
    layer.updateDataMask(MeshModel::MM_CAMERA);
    LayerCamera camera;
    camera.width = view.points.cols;
    camera.height = view.points.rows;
    for (int i = 0; i < 9; ++i) camera.matrix[i] = view.camera_matrix.val[i];
    const cv::Mat distortion = view.camera_distortion.empty() ? cv::Mat() : view.camera_distortion.reshape(1, 1);
    camera.distortion_count = std::min(14, int(distortion.total()));
    for (int i = 0; i < camera.distortion_count; ++i) camera.distortion[i] = distortion.at<double>(0, i);
    vcg::tri::Allocator<CMeshO>::GetPerMeshAttribute<LayerCamera>(mesh, kCameraAttribute)() = camera;
    mesh.shot = Shotm();
    for (int i = kShotDistortionCount; i < camera.distortion_count; ++i)
        if (camera.distortion[i] != 0) return;  // a lens MeshLab's camera cannot hold
    const double k3 = camera.distortion_count > 4 ? camera.distortion[4] : 0;
    if (!(std::abs(k3) < 30)) return;  // exp(k3) must stay a float
    const double pixel_size = std::exp(k3);
    auto& intrinsics = mesh.shot.Intrinsics;
    intrinsics.cameraType = 0;
    intrinsics.ViewportPx = vcg::Point2i(camera.width, camera.height);
    intrinsics.FocalMm = Scalarm(view.camera_matrix(0, 0) * pixel_size);
    intrinsics.PixelSizeMm = vcg::Point2<Scalarm>(Scalarm(pixel_size), Scalarm(pixel_size * view.camera_matrix(0, 0) / view.camera_matrix(1, 1)));
    intrinsics.CenterPx = vcg::Point2<Scalarm>(Scalarm(view.camera_matrix(0, 2)), Scalarm(view.camera_matrix(1, 2)));
    intrinsics.DistorCenterPx = intrinsics.CenterPx;
    for (int i = 0; i < 4; ++i) intrinsics.k[i] = Scalarm(i < camera.distortion_count ? camera.distortion[i] : 0);
    mesh.shot.Extrinsics.SetIdentity();
}

// The vertex count of a PicoScan view PLY (a file with the picoscan_grid comment), from its
// header alone; -1 for any other file.
long long view_file_vertex_count(const QString& path) {
    QFile file(path);
    if (!file.open(QIODevice::ReadOnly) || file.readLine(64).trimmed() != "ply") return -1;
    bool has_grid = false;
    long long vertex_count = -1;
    for (int line = 0; line < 1000 && !file.atEnd(); ++line) {
        const QByteArray text = file.readLine(4096).trimmed();
        if (text == "end_header") return has_grid ? vertex_count : -1;
        if (text.startsWith("comment picoscan_grid ")) has_grid = true;
        if (text.startsWith("element vertex ")) vertex_count = text.mid(15).trimmed().toLongLong();
    }
    return -1;
}

// The camera pixel of each of the layer's vertices, in order, when they are points of `view` in
// its row order: all of its valid points, or those left by Clean or by deleting points in MeshLab
// (MeshLab keeps the order of the remaining vertices). Empty when a vertex is not a point of the view.
std::vector<std::pair<int, int>> pixels_in_view(CMeshO& mesh, const picoscan::ScanView& view) {
    std::vector<std::pair<int, int>> pixels;
    pixels.reserve(size_t(mesh.vn));
    auto vertex = mesh.vert.begin();
    const auto skip_deleted = [&] {
        while (vertex != mesh.vert.end() && vertex->IsD()) ++vertex;
    };
    skip_deleted();
    for (int y = 0; y < view.points.rows && vertex != mesh.vert.end(); ++y)
        for (int x = 0; x < view.points.cols && vertex != mesh.vert.end(); ++x) {
            const cv::Vec3f& p = view.points.at<cv::Vec3f>(y, x);
            if (!finite_point(p) || cv::norm(p - cv::Vec3f(vertex->P()[0], vertex->P()[1], vertex->P()[2])) > 1e-4)
                continue;
            pixels.emplace_back(x, y);
            ++vertex;
            skip_deleted();
        }
    if (vertex != mesh.vert.end() || pixels.empty()) pixels.clear();
    return pixels;
}

// Gives the layer the pixels and camera of `view` (matched by pixels_in_view), and the normals,
// quality and colours the layer's file did not keep.
void adopt_view(MeshModel& layer, const picoscan::ScanView& view, const std::vector<std::pair<int, int>>& pixels) {
    CMeshO& mesh = layer.cm;
    const bool take_normals = !view.normals.empty() && mesh.vert.begin()->cN().SquaredNorm() == 0;
    const bool take_quality = !view.quality.empty() && !layer.hasDataMask(MeshModel::MM_VERTQUALITY);
    const bool take_colours = !view.colours.empty() && !layer.hasDataMask(MeshModel::MM_VERTCOLOR);
    int mask = MeshModel::MM_VERTTEXCOORD;
    if (take_quality) mask |= MeshModel::MM_VERTQUALITY;
    if (take_colours) mask |= MeshModel::MM_VERTCOLOR;
    layer.updateDataMask(mask);
    size_t index = 0;
    for (CVertexO& v : mesh.vert) {
        if (v.IsD()) continue;
        const int x = pixels[index].first, y = pixels[index].second;
        v.T().U() = Scalarm(x);
        v.T().V() = Scalarm(y);
        v.T().N() = 0;
        if (take_normals) {
            const cv::Vec3f& n = view.normals.at<cv::Vec3f>(y, x);
            v.N() = finite_point(n) ? Point3m(n[0], n[1], n[2]) : Point3m(0, 0, -1);
        }
        if (take_quality) v.Q() = view.quality.at<float>(y, x);
        if (take_colours) {
            const cv::Vec3b& bgr = view.colours.at<cv::Vec3b>(y, x);
            v.C() = vcg::Color4b(bgr[2], bgr[1], bgr[0], 255);
        }
        ++index;
    }
    set_layer_camera(layer, view);
}

// A layer opened from a file without the pixels and camera (MeshLab keeps neither when it reads a
// PicoScan view PLY; a save may have left them out) takes them from a PicoScan view PLY: its own
// file, or a view beside it (the view a MeshLab copy was saved from, or one written by 'PicoScan:
// Save Views for Project'), as long as the layer holds points of that view, in its order.
// Returns the view file used, or why there is none in `problem`.
QString adopt_view_file(MeshModel& layer, std::string& problem) {
    const QString file = layer.fullName();
    if (file.isEmpty()) {
        problem = "it was not opened from a file";
        return {};
    }
    const QFileInfo info(file);
    const bool own_file_is_view = view_file_vertex_count(file) >= 0;
    // Its own file first, then the views beside it, those whose name starts its name first
    // (meshlabserver saves VIEW.ply as VIEW_out.ply).
    QStringList candidates{file};
    QStringList others;
    for (const QFileInfo& sibling : info.dir().entryInfoList(QStringList{"*.ply", "*.PLY"}, QDir::Files, QDir::Name)) {
        if (sibling.absoluteFilePath() == info.absoluteFilePath()) continue;
        (info.completeBaseName().startsWith(sibling.completeBaseName()) ? candidates : others) << sibling.absoluteFilePath();
    }
    candidates << others;
    CMeshO& mesh = layer.cm;
    bool own_file_has_no_camera = false;
    for (const QString& candidate : candidates) {
        if (view_file_vertex_count(candidate) < mesh.vn) continue;
        picoscan::ScanView view;
        try {
            view = picoscan::read_view_ply(candidate.toStdString());
        } catch (const std::exception&) {
            continue;
        }
        if (view.camera_matrix(0, 0) <= 0) {  // a view of an older PicoScan, without its camera
            own_file_has_no_camera = own_file_has_no_camera || candidate == file;
            continue;
        }
        const std::vector<std::pair<int, int>> pixels = pixels_in_view(mesh, view);
        if (pixels.empty()) continue;
        adopt_view(layer, view, pixels);
        return candidate;
    }
    const std::string folder = info.absolutePath().toStdString();
    if (own_file_has_no_camera)
        problem = "its file is a PicoScan view without a camera (an older file)";
    else if (own_file_is_view)
        problem = "it no longer holds points of its file, and no other PicoScan view in " + folder + " holds them";
    else
        problem = "its file is not a PicoScan view, and no PicoScan view in " + folder + " holds its points";
    return {};
}

// A layer saved without its normals (MeshLab's PLY save dialog can leave them out, and MeshLab
// reads a point cloud without them as zero normals) gets them from its pixel grid, as the core
// computed them when it triangulated the view. Returns how many vertices got a normal.
int restore_normals_from_grid(MeshModel& layer) {
    CMeshO& mesh = layer.cm;
    const auto lacks_normal = [](const CVertexO& vertex) { return !vertex.IsD() && !(vertex.cN().SquaredNorm() > 0); };
    if (std::none_of(mesh.vert.begin(), mesh.vert.end(), lacks_normal)) return 0;
    picoscan::ScanView view = layer_view(layer);
    picoscan::estimate_normals(view);
    const int width = view.points.cols, height = view.points.rows;
    int restored = 0;
    for (CVertexO& vertex : mesh.vert) {
        if (!lacks_normal(vertex)) continue;
        const int pixel = vertex_pixel(vertex, width, height);
        const cv::Vec3f n = pixel >= 0 ? view.normals.at<cv::Vec3f>(pixel / width, pixel % width) : cv::Vec3f(0, 0, 0);
        vertex.N() = finite_point(n) && n.dot(n) > 0 ? Point3m(n[0], n[1], n[2]) : Point3m(0, 0, -1);  // as fill_layer
        ++restored;
    }
    return restored;
}

}  // namespace

void fill_layer(MeshModel& layer, const picoscan::ScanView& view) {
    view.focal_px();  // throws when the view does not know its camera
    CMeshO& mesh = layer.cm;
    layer.updateDataMask(MeshModel::MM_VERTCOLOR | MeshModel::MM_VERTQUALITY | MeshModel::MM_VERTNORMAL |
                         MeshModel::MM_VERTTEXCOORD | MeshModel::MM_CAMERA);
    const bool has_normals = !view.normals.empty(), has_colours = !view.colours.empty(),
               has_quality = !view.quality.empty();
    auto vertex = vcg::tri::Allocator<CMeshO>::AddVertices(mesh, size_t(view.valid_count()));
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
            vertex->T().U() = Scalarm(x);
            vertex->T().V() = Scalarm(y);
            vertex->T().N() = 0;
            ++vertex;
        }
    set_layer_camera(layer, view);
    keep_grid_in_meshlabserver_saves(layer);
    set_layer_pose(layer, view.pose);
    vcg::tri::UpdateBounding<CMeshO>::Box(mesh);
}

void fill_layer(MeshModel& layer, const picoscan::Mesh& source) {
    CMeshO& mesh = layer.cm;
    const bool has_normals = source.normals.size() == source.vertices.size(),
               has_colours = source.colours.size() == source.vertices.size(),
               has_measured = source.measured.size() == source.vertices.size();
    if (has_colours) layer.updateDataMask(MeshModel::MM_VERTCOLOR);
    if (has_measured) layer.updateDataMask(MeshModel::MM_VERTQUALITY);  // 1 measured, 0 filled in (as the PLY writer)
    auto vertex = vcg::tri::Allocator<CMeshO>::AddVertices(mesh, source.vertices.size());
    CVertexO* first_vertex = &*vertex;
    for (size_t i = 0; i < source.vertices.size(); ++i, ++vertex) {
        const cv::Vec3f& p = source.vertices[i];
        vertex->P() = Point3m(p[0], p[1], p[2]);
        if (has_normals) vertex->N() = Point3m(source.normals[i][0], source.normals[i][1], source.normals[i][2]);
        if (has_colours) vertex->C() = vcg::Color4b(source.colours[i][0], source.colours[i][1], source.colours[i][2], 255);
        if (has_measured) vertex->Q() = source.measured[i];
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

std::string missing_scan_data(MeshModel& layer, LayerRepair* repair) {
    LayerRepair done;
    const bool has_pixels = layer.hasDataMask(MeshModel::MM_VERTTEXCOORD);
    const bool has_camera = has_camera_attribute(layer.cm) || has_saved_camera(layer);
    if (!has_pixels || !has_camera) {
        std::string not_a_view;
        done.view_file = adopt_view_file(layer, not_a_view);
        if (done.view_file.isEmpty()) {
            if (!has_pixels)
                return "this layer has no camera pixel grid (" + not_a_view + "): it needs a point cloud layer made "
                       "by 'PicoScan: Reconstruct from Capture Set' or 'PicoScan: Simulate Scan', a PicoScan view "
                       "PLY, or such a layer saved as PLY with its texture coordinates and camera";
            return "this layer has pixel coordinates but no camera (" + not_a_view + "): save PicoScan layers as "
                   "PLY with their camera";
        }
    }
    done.normals_from_grid = restore_normals_from_grid(layer);
    keep_grid_in_meshlabserver_saves(layer);
    if (repair != nullptr) *repair = done;
    return {};
}

picoscan::ScanView layer_view(MeshModel& layer) {
    CMeshO& mesh = layer.cm;
    const LayerCamera camera = layer_camera(layer);
    const int width = camera.width, height = camera.height;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    picoscan::ScanView view;
    view.camera_matrix = cv::Matx33d(camera.matrix);
    if (camera.distortion_count > 0) cv::Mat(1, camera.distortion_count, CV_64F, const_cast<double*>(camera.distortion)).copyTo(view.camera_distortion);
    view.points.create(height, width, CV_32FC3);
    view.points.setTo(cv::Scalar::all(nan));
    view.normals.create(height, width, CV_32FC3);
    view.normals.setTo(cv::Scalar::all(nan));
    view.colours = cv::Mat(height, width, CV_8UC3, cv::Scalar::all(0));
    view.quality = cv::Mat(height, width, CV_32F, cv::Scalar(0));
    for (CVertexO& vertex : mesh.vert) {
        if (vertex.IsD()) continue;
        const int pixel = vertex_pixel(vertex, width, height);
        if (pixel < 0) continue;
        const int y = pixel / width, x = pixel % width;
        view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(vertex.P()[0], vertex.P()[1], vertex.P()[2]);
        view.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(vertex.N()[0], vertex.N()[1], vertex.N()[2]);
        view.colours.at<cv::Vec3b>(y, x) = cv::Vec3b(vertex.C()[2], vertex.C()[1], vertex.C()[0]);
        view.quality.at<float>(y, x) = vertex.Q();
    }
    view.pose = layer_pose(layer);
    return view;
}

int remove_vertices_missing_from(MeshModel& layer, const picoscan::ScanView& view) {
    CMeshO& mesh = layer.cm;
    const int width = view.points.cols, height = view.points.rows;
    int deleted = 0;
    for (CVertexO& vertex : mesh.vert) {
        if (vertex.IsD()) continue;
        const int pixel = vertex_pixel(vertex, width, height);
        if (pixel >= 0 && finite_point(view.points.at<cv::Vec3f>(pixel / width, pixel % width))) continue;
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

picoscan::Mesh layer_mesh(MeshModel& layer, bool apply_transform) {
    picoscan::Mesh mesh;
    std::vector<int> index(layer.cm.vert.size(), -1);  // the core's vertex of each of the layer's
    for (size_t i = 0; i < layer.cm.vert.size(); ++i) {
        const CVertexO& vertex = layer.cm.vert[i];
        if (vertex.IsD()) continue;
        const Point3m p = apply_transform ? layer.cm.Tr * vertex.cP() : vertex.cP();
        index[i] = int(mesh.vertices.size());
        mesh.vertices.emplace_back(p[0], p[1], p[2]);
    }
    for (const CFaceO& face : layer.cm.face) {
        if (face.IsD()) continue;
        cv::Vec3i corners;
        for (int corner = 0; corner < 3; ++corner) corners[corner] = index[size_t(vcg::tri::Index(layer.cm, face.cV(corner)))];
        mesh.faces.push_back(corners);
    }
    return mesh;
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
