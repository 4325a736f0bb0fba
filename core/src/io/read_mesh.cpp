// Mesh reading dispatched by file extension.
#include "io/io_detail.h"
#include "picoscan/error.h"
#include "picoscan/io.h"

#include <filesystem>

namespace picoscan {

Mesh read_mesh(const std::string& path) {
    const std::string extension = detail::lower_case(std::filesystem::path(path).extension().string());
    if (extension == ".ply") return read_ply(path);
    if (extension == ".stl") return read_stl(path);
    throw Error(path, "unsupported mesh format '" + extension + "' (expected .ply or .stl)");
}

}  // namespace picoscan
