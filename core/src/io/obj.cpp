// Wavefront OBJ writing (vertices, optional vertex colours and normals, triangles).
#include "io/io_detail.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"

#include <string>

namespace picoscan {

void write_obj(const Mesh& mesh, const std::string& path) {
    detail::check_mesh(mesh, path);
    const bool has_normals = !mesh.normals.empty();
    const bool has_colours = !mesh.colours.empty();
    std::string out = "# written by PicoScan\n";
    out += "# " + std::to_string(mesh.vertices.size()) + " vertices, " + std::to_string(mesh.faces.size()) +
           " faces\n";
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        out += 'v';
        for (int k = 0; k < 3; ++k) {
            out += ' ';
            detail::append_number(out, mesh.vertices[i][k]);
        }
        if (has_colours) {
            // The common "v x y z r g b" extension, channels 0..1.
            for (int k = 0; k < 3; ++k) {
                out += ' ';
                detail::append_number(out, mesh.colours[i][k] / 255.0f);
            }
        }
        out += '\n';
    }
    if (has_normals) {
        for (const cv::Vec3f& n : mesh.normals) {
            out += "vn";
            for (int k = 0; k < 3; ++k) {
                out += ' ';
                detail::append_number(out, n[k]);
            }
            out += '\n';
        }
    }
    for (const cv::Vec3i& face : mesh.faces) {
        out += 'f';
        for (int k = 0; k < 3; ++k) {
            const std::string index = std::to_string(static_cast<long long>(face[k]) + 1);  // OBJ is 1-based
            out += ' ';
            out += index;
            if (has_normals) out += "//" + index;
        }
        out += '\n';
    }
    write_file_atomically(path, out);
}

}  // namespace picoscan
