#include "io/io_detail.h"

#include "picoscan/error.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <limits>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace picoscan::detail {

void ReadProgress::report() const {
    const double fraction = total_ > 0 ? std::min(1.0, static_cast<double>(done_) / static_cast<double>(total_)) : 1.0;
    if (!progress_(fraction, "reading the mesh")) throw Error("cancelled", "reading " + path_ + " was stopped");
}

std::string read_whole_file(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw Error(path, std::string("cannot open: ") + std::strerror(errno));
    struct stat info {};
    if (::fstat(fd, &info) != 0) {
        const int saved = errno;
        ::close(fd);
        throw Error(path, std::string("cannot stat: ") + std::strerror(saved));
    }
    if (!S_ISREG(info.st_mode)) {
        ::close(fd);
        throw Error(path, "not a regular file");
    }
    std::string bytes;
    // The size is a hint only: read until EOF so a file that changes under us stays safe.
    if (info.st_size > 0) bytes.reserve(static_cast<size_t>(info.st_size));
    char buffer[1 << 16];
    for (;;) {
        const ssize_t got = ::read(fd, buffer, sizeof(buffer));
        if (got < 0) {
            if (errno == EINTR) continue;
            const int saved = errno;
            ::close(fd);
            throw Error(path, std::string("read failed: ") + std::strerror(saved));
        }
        if (got == 0) break;
        bytes.append(buffer, static_cast<size_t>(got));
    }
    ::close(fd);
    return bytes;
}

namespace {
template <class T>
void append_with_to_chars(std::string& out, T value) {
    char text[64];
    const auto result = std::to_chars(text, text + sizeof(text), value);
    out.append(text, result.ptr);
}
}  // namespace

void append_number(std::string& out, float value) {
    if (std::isnan(value)) { out += "nan"; return; }
    append_with_to_chars(out, value);
}
void append_number(std::string& out, double value) {
    if (std::isnan(value)) { out += "nan"; return; }
    append_with_to_chars(out, value);
}
void append_number(std::string& out, long long value) { append_with_to_chars(out, value); }

bool parse_double(std::string_view token, double& value) {
    if (!token.empty() && token.front() == '+') token.remove_prefix(1);
    if (token.empty()) return false;
    const char* end = token.data() + token.size();
    const auto result = std::from_chars(token.data(), end, value);
    if (result.ec == std::errc::result_out_of_range) {
        // Beyond double range: from_chars leaves value untouched; saturate like strtod.
        value = (token.front() == '-') ? -std::numeric_limits<double>::infinity()
                                       : std::numeric_limits<double>::infinity();
        return result.ptr == end;
    }
    return result.ec == std::errc() && result.ptr == end;
}

float to_float(double value) {
    constexpr double kMax = std::numeric_limits<float>::max();
    if (value > kMax) return std::numeric_limits<float>::infinity();
    if (value < -kMax) return -std::numeric_limits<float>::infinity();
    return static_cast<float>(value);  // NaN and in-range values convert fine
}

cv::Vec3f face_normal(const cv::Vec3f& a, const cv::Vec3f& b, const cv::Vec3f& c) {
    const cv::Vec3d ab(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    const cv::Vec3d ac(c[0] - a[0], c[1] - a[1], c[2] - a[2]);
    const cv::Vec3d n = ab.cross(ac);
    const double length = cv::norm(n);
    if (!(length > 0) || !std::isfinite(length)) return {0, 0, 0};
    return cv::Vec3f(static_cast<float>(n[0] / length), static_cast<float>(n[1] / length),
                     static_cast<float>(n[2] / length));
}

void check_mesh(const Mesh& mesh, const std::string& path) {
    const size_t count = mesh.vertices.size();
    if (!mesh.normals.empty() && mesh.normals.size() != count)
        throw Error(path, "mesh has " + std::to_string(mesh.normals.size()) + " normals for " +
                              std::to_string(count) + " vertices");
    if (!mesh.colours.empty() && mesh.colours.size() != count)
        throw Error(path, "mesh has " + std::to_string(mesh.colours.size()) + " colours for " +
                              std::to_string(count) + " vertices");
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        for (int k = 0; k < 3; ++k) {
            const int index = mesh.faces[f][k];
            if (index < 0 || static_cast<size_t>(index) >= count)
                throw Error(path, "face " + std::to_string(f) + " has vertex index " +
                                      std::to_string(index) + " but the mesh has " +
                                      std::to_string(count) + " vertices");
        }
    }
}

std::string lower_case(std::string_view text) {
    std::string lower(text);
    for (char& c : lower)
        if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    return lower;
}

}  // namespace picoscan::detail
