// Shared by the fuzz targets: the readers take paths, so each input goes through a
// per-process temporary file.
#pragma once

#include "picoscan/cloud.h"

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace picoscan::fuzz {

// The input as "<dir>/picoscan-fuzz-<name>-<pid><extension>", removed again afterwards
// (a crash leaves it behind; libFuzzer keeps its own copy as the artifact). The directory
// is /dev/shm when there is one: a disk file costs ~20x in executions per second.
class InputFile {
public:
    InputFile(const char* name, const char* extension, const uint8_t* data, size_t size) {
        const char* tmp = std::getenv("TMPDIR");
        const std::string dir = ::access("/dev/shm", W_OK) == 0 ? "/dev/shm" : (tmp && *tmp ? tmp : "/tmp");
        path_ = dir + "/picoscan-fuzz-" + name + "-" + std::to_string(::getpid()) + extension;
        FILE* file = std::fopen(path_.c_str(), "wb");
        if (!file) std::abort();  // the harness itself is broken, not the reader
        if (size > 0 && std::fwrite(data, 1, size, file) != size) std::abort();
        if (std::fclose(file) != 0) std::abort();
    }
    ~InputFile() { std::remove(path_.c_str()); }
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;

    const std::string& path() const { return path_; }

private:
    std::string path_;
};

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
