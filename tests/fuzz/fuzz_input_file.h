// Shared by the fuzz targets: the readers take paths, so each input goes through a
// per-process temporary file.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace picoscan::fuzz {

// Writes the input to "<tmp>/picoscan-fuzz-<name>-<pid><extension>" and returns its path.
inline const std::string& write_input(const char* name, const char* extension, const uint8_t* data, size_t size) {
    static const std::string path = [&] {
        const char* tmp = std::getenv("TMPDIR");
        return std::string(tmp && *tmp ? tmp : "/tmp") + "/picoscan-fuzz-" + name + "-" +
               std::to_string(::getpid()) + extension;
    }();
    FILE* file = std::fopen(path.c_str(), "wb");
    if (!file) std::abort();  // the harness itself is broken, not the reader
    if (size > 0 && std::fwrite(data, 1, size, file) != size) std::abort();
    if (std::fclose(file) != 0) std::abort();
    return path;
}

}  // namespace picoscan::fuzz

#include "picoscan/cloud.h"

namespace picoscan::fuzz {

// What every successfully read mesh must satisfy; a violation is a reader bug.
inline void check_mesh_invariants(const Mesh& mesh) {
    const size_t count = mesh.vertices.size();
    if (!mesh.normals.empty() && mesh.normals.size() != count) std::abort();
    if (!mesh.colours.empty() && mesh.colours.size() != count) std::abort();
    for (const cv::Vec3i& face : mesh.faces)
        for (int k = 0; k < 3; ++k)
            if (face[k] < 0 || static_cast<size_t>(face[k]) >= count) std::abort();
}

}  // namespace picoscan::fuzz
