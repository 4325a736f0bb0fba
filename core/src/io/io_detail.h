// Helpers shared by the mesh readers and writers: whole-file reading, byte order,
// locale-independent number formatting and parsing.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/progress.h"

#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace picoscan::detail {

// The whole file; throws Error(path, ...) when it cannot be read.
std::string read_whole_file(const std::string& path);

inline bool host_is_little_endian() {
    const uint16_t probe = 1;
    unsigned char first = 0;
    std::memcpy(&first, &probe, 1);
    return first == 1;
}

// Stores the raw bytes of `value` in little-endian order at `at`, and moves `at` past them.
template <class T>
void put_le(char*& at, T value) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (!host_is_little_endian()) {
        for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    }
    std::memcpy(at, bytes, sizeof(T));
    at += sizeof(T);
}

// Appends the raw bytes of `value` in little-endian order.
template <class T>
void append_le(std::string& out, T value) {
    char bytes[sizeof(T)];
    char* at = bytes;
    put_le(at, value);
    out.append(bytes, sizeof(T));
}

// Shortest text that reads back to exactly the same float (no locale).
void append_number(std::string& out, float value);
void append_number(std::string& out, double value);
void append_number(std::string& out, long long value);

// Parses a whole token as a double (accepts a leading '+', nan and inf); false if malformed.
bool parse_double(std::string_view token, double& value);

// double -> float without undefined behaviour for values beyond float range.
float to_float(double value);

// Face normal from the winding (unit, or zero for a degenerate triangle).
cv::Vec3f face_normal(const cv::Vec3f& a, const cv::Vec3f& b, const cv::Vec3f& c);

// Throws Error(path, ...) when normals/colours do not have one entry per vertex or a face
// index is out of range.
void check_mesh(const Mesh& mesh, const std::string& path);

// A rows x cols grid of zeros. Large ones come from the operating system's fresh pages and
// are not written here: only the pages a caller writes cost memory and time.
cv::Mat zeroed_grid(int rows, int cols, int type);
// A rows x cols grid of float NaNs (CV_32F, any channels). Large ones reuse the memory of
// recently freed ones, since every byte is written here anyway.
cv::Mat nan_grid(int rows, int cols, int type);

// A reader's progress: the share of a file's records read, reported every 65 536 records and at
// the last one (stage "reading the mesh"); throws Error("cancelled", ...) when the caller answers false.
class ReadProgress {
public:
    ReadProgress(const ProgressCallback& progress, const std::string& path, uint64_t total_records)
        : progress_(progress), path_(path), total_(total_records) {}
    void record_done() {
        ++done_;
        if (progress_ && (done_ % kEvery == 0 || done_ == total_)) report();
    }

private:
    static constexpr uint64_t kEvery = 65536;
    void report() const;
    const ProgressCallback& progress_;
    const std::string& path_;
    uint64_t total_;
    uint64_t done_ = 0;
};

// What read_ply_with_extras returns beside the mesh: the header comments and the vertex
// properties "quality" and "pixel" (empty when absent).
struct PlyExtras {
    std::vector<std::string> comments;
    std::vector<float> quality;
    std::vector<int64_t> pixels;
};
Mesh read_ply_with_extras(const std::string& path, PlyExtras& extras);

// ASCII lower case of a string.
std::string lower_case(std::string_view text);

}  // namespace picoscan::detail
