// PLY writing (binary little-endian or ASCII) for point clouds and meshes.
#include "io/io_detail.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace picoscan {

namespace {

struct PlyPayload {
    const std::vector<cv::Vec3f>& points;
    const std::vector<cv::Vec3f>& normals;
    const std::vector<cv::Vec3b>& colours;
    const std::vector<float>& quality;
    const std::vector<cv::Vec3i>& faces;
    const std::vector<int32_t>& pixels;          // empty or one per point
    const std::vector<std::string>& comments;    // extra header comments
};

std::string build_ply(const PlyPayload& data, Encoding encoding) {
    const size_t count = data.points.size();
    const bool has_normals = !data.normals.empty();
    const bool has_colours = !data.colours.empty();
    const bool has_quality = !data.quality.empty();
    const bool has_pixels = !data.pixels.empty();
    const bool binary = encoding == Encoding::Binary;

    std::string out;
    out += "ply\n";
    out += binary ? "format binary_little_endian 1.0\n" : "format ascii 1.0\n";
    out += "comment written by PicoScan\n";
    for (const std::string& comment : data.comments) out += "comment " + comment + "\n";
    out += "element vertex " + std::to_string(count) + "\n";
    out += "property float x\nproperty float y\nproperty float z\n";
    if (has_normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
    if (has_colours) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    if (has_quality) out += "property float quality\n";
    if (has_pixels) out += "property int pixel\n";
    if (!data.faces.empty()) {
        out += "element face " + std::to_string(data.faces.size()) + "\n";
        out += "property list uchar int vertex_indices\n";
    }
    out += "end_header\n";

    if (binary) {
        // Sized once and filled in place: appended value by value, the body took longer to
        // build than to write.
        const size_t record = 12 + (has_normals ? 12 : 0) + (has_colours ? 3 : 0) + (has_quality ? 4 : 0) + (has_pixels ? 4 : 0);
        const size_t header_size = out.size();
        out.resize(header_size + count * record + data.faces.size() * 13);
        char* at = out.data() + header_size;
        for (size_t i = 0; i < count; ++i) {
            for (int k = 0; k < 3; ++k) detail::put_le(at, data.points[i][k]);
            if (has_normals)
                for (int k = 0; k < 3; ++k) detail::put_le(at, data.normals[i][k]);
            if (has_colours)
                for (int k = 0; k < 3; ++k) detail::put_le(at, data.colours[i][k]);
            if (has_quality) detail::put_le(at, data.quality[i]);
            if (has_pixels) detail::put_le(at, data.pixels[i]);
        }
        for (const cv::Vec3i& face : data.faces) {
            detail::put_le(at, uint8_t(3));
            for (int k = 0; k < 3; ++k) detail::put_le(at, static_cast<int32_t>(face[k]));
        }
    } else {
        for (size_t i = 0; i < count; ++i) {
            for (int k = 0; k < 3; ++k) {
                if (k) out += ' ';
                detail::append_number(out, data.points[i][k]);
            }
            if (has_normals)
                for (int k = 0; k < 3; ++k) {
                    out += ' ';
                    detail::append_number(out, data.normals[i][k]);
                }
            if (has_colours)
                for (int k = 0; k < 3; ++k) {
                    out += ' ';
                    detail::append_number(out, static_cast<long long>(data.colours[i][k]));
                }
            if (has_quality) {
                out += ' ';
                detail::append_number(out, data.quality[i]);
            }
            if (has_pixels) {
                out += ' ';
                detail::append_number(out, static_cast<long long>(data.pixels[i]));
            }
            out += '\n';
        }
        for (const cv::Vec3i& face : data.faces) {
            out += '3';
            for (int k = 0; k < 3; ++k) {
                out += ' ';
                detail::append_number(out, static_cast<long long>(face[k]));
            }
            out += '\n';
        }
    }
    return out;
}

}  // namespace

void write_ply(const PointCloud& cloud, const std::string& path, Encoding encoding) {
    const size_t count = cloud.points.size();
    auto check = [&](size_t size, const char* what) {
        if (size != 0 && size != count)
            throw Error(path, "cloud has " + std::to_string(size) + " " + what + " for " +
                                  std::to_string(count) + " points");
    };
    check(cloud.normals.size(), "normals");
    check(cloud.colours.size(), "colours");
    check(cloud.quality.size(), "quality values");
    static const std::vector<cv::Vec3i> no_faces;
    static const std::vector<int32_t> no_pixels;
    static const std::vector<std::string> no_comments;
    write_file_atomically(path, build_ply({cloud.points, cloud.normals, cloud.colours, cloud.quality, no_faces,
                                           no_pixels, no_comments},
                                          encoding));
}

void write_ply(const Mesh& mesh, const std::string& path, Encoding encoding) {
    detail::check_mesh(mesh, path);
    // Measured (1) or filled in (0) goes out as the vertex quality, which MeshLab shows.
    std::vector<float> quality;
    if (mesh.measured.size() == mesh.vertices.size()) quality.assign(mesh.measured.begin(), mesh.measured.end());
    static const std::vector<int32_t> no_pixels;
    static const std::vector<std::string> no_comments;
    write_file_atomically(path, build_ply({mesh.vertices, mesh.normals, mesh.colours, quality, mesh.faces,
                                           no_pixels, no_comments},
                                          encoding));
}

void write_view_ply(const ScanView& view, const std::string& path, Encoding encoding) {
    // The view's own (camera-frame) points: the pose travels in a comment so that the
    // organised grid stays in the frame its white-frame features were seen in.
    ScanView camera_frame = view;
    camera_frame.pose = cv::Matx44d::eye();
    const PointCloud cloud = to_point_cloud(camera_frame);
    std::vector<int32_t> pixels;
    pixels.reserve(cloud.points.size());
    for (int y = 0; y < view.points.rows; ++y) {
        const cv::Vec3f* row = view.points.ptr<cv::Vec3f>(y);
        for (int x = 0; x < view.points.cols; ++x)
            if (std::isfinite(row[x][0]) && std::isfinite(row[x][1]) && std::isfinite(row[x][2]))
                pixels.push_back(y * view.points.cols + x);
    }
    if (pixels.size() != cloud.points.size()) throw Error(path, "view points and pixel grid disagree");
    std::string pose = "picoscan_pose";
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) {
            pose += ' ';
            detail::append_number(pose, view.pose(r, c));
        }
    std::vector<std::string> comments = {
        "picoscan_grid " + std::to_string(view.points.cols) + " " + std::to_string(view.points.rows), pose};
    if (view.camera_matrix(0, 0) > 0) {
        // The camera that made the view: fx fy cx cy skew, then its distortion coefficients.
        const cv::Matx33d& k = view.camera_matrix;
        std::string camera = "picoscan_camera";
        for (double value : {k(0, 0), k(1, 1), k(0, 2), k(1, 2), k(0, 1)}) {
            camera += ' ';
            detail::append_number(camera, value);
        }
        comments.push_back(camera);
        std::string distortion = "picoscan_distortion";
        for (size_t i = 0; i < view.camera_distortion.total(); ++i) {
            distortion += ' ';
            detail::append_number(distortion, view.camera_distortion.at<double>(static_cast<int>(i)));
        }
        comments.push_back(distortion);
    }
    static const std::vector<cv::Vec3i> no_faces;
    write_file_atomically(path, build_ply({cloud.points, cloud.normals, cloud.colours, cloud.quality, no_faces,
                                           pixels, comments},
                                          encoding));
}

}  // namespace picoscan
