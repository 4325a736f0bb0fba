// Mesh reading dispatched by file extension.
#include "io/io_detail.h"
#include "picoscan/error.h"
#include "picoscan/io.h"

#include <filesystem>

namespace picoscan {

Mesh read_mesh(const std::string& path, const ProgressCallback& progress) {
    const std::string extension = detail::lower_case(std::filesystem::path(path).extension().string());
    if (extension == ".ply") return read_ply(path, progress);
    if (extension == ".stl") return read_stl(path, progress);
    if (extension == ".3mf") {
        Mesh mesh = read_3mf(path);
        detail::ReadProgress(progress, path, 1).record_done();
        return mesh;
    }
    throw Error(path, "unsupported mesh format '" + extension + "' (expected .ply, .stl or .3mf)");
}

void write_mesh(const Mesh& mesh, const std::string& path, Encoding encoding) {
    const std::string extension = detail::lower_case(std::filesystem::path(path).extension().string());
    if (extension == ".stl") return write_stl(mesh, path, encoding);
    if (extension == ".ply") return write_ply(mesh, path, encoding);
    if (extension == ".obj") return write_obj(mesh, path);
    if (extension == ".3mf") return write_3mf(mesh, path);
    throw Error(path, "unsupported mesh format '" + extension + "' (expected .stl, .ply, .obj or .3mf)");
}

}  // namespace picoscan
