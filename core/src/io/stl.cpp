// STL writing and reading (binary and ASCII). STL stores unshared triangle corners, so
// reading merges corners that are exactly equal back into shared vertices.
#include "io/io_detail.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"

#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace picoscan {

namespace {

constexpr size_t kBinaryHeaderBytes = 80;
constexpr size_t kBinaryPrefixBytes = 84;    // header + uint32 triangle count
constexpr size_t kBinaryTriangleBytes = 50;  // normal, three corners, uint16 attribute

std::string build_binary_stl(const Mesh& mesh) {
    std::string out;
    out.reserve(kBinaryPrefixBytes + mesh.faces.size() * kBinaryTriangleBytes);
    // The header must not start with "solid", or naive readers would take it for ASCII.
    std::string header = "PicoScan binary STL";
    header.resize(kBinaryHeaderBytes, ' ');
    out += header;
    detail::append_le(out, static_cast<uint32_t>(mesh.faces.size()));
    for (const cv::Vec3i& face : mesh.faces) {
        const cv::Vec3f& a = mesh.vertices[face[0]];
        const cv::Vec3f& b = mesh.vertices[face[1]];
        const cv::Vec3f& c = mesh.vertices[face[2]];
        const cv::Vec3f n = detail::face_normal(a, b, c);
        for (const cv::Vec3f* v : {&n, &a, &b, &c})
            for (int k = 0; k < 3; ++k) detail::append_le(out, (*v)[k]);
        detail::append_le(out, static_cast<uint16_t>(0));
    }
    return out;
}

void append_triple(std::string& out, const cv::Vec3f& v) {
    for (int k = 0; k < 3; ++k) {
        out += ' ';
        detail::append_number(out, v[k]);
    }
}

std::string build_ascii_stl(const Mesh& mesh) {
    std::string out = "solid picoscan\n";
    for (const cv::Vec3i& face : mesh.faces) {
        const cv::Vec3f& a = mesh.vertices[face[0]];
        const cv::Vec3f& b = mesh.vertices[face[1]];
        const cv::Vec3f& c = mesh.vertices[face[2]];
        out += "  facet normal";
        append_triple(out, detail::face_normal(a, b, c));
        out += "\n    outer loop\n";
        for (const cv::Vec3f* v : {&a, &b, &c}) {
            out += "      vertex";
            append_triple(out, *v);
            out += '\n';
        }
        out += "    endloop\n  endfacet\n";
    }
    out += "endsolid picoscan\n";
    return out;
}

// Shares corners that are bit-for-bit the same point (+0 and -0 count as equal).
class VertexMerger {
public:
    // `expected_vertices`: a hint; a closed mesh has about half as many vertices as triangles.
    VertexMerger(Mesh& mesh, size_t expected_vertices) : mesh_(mesh) {
        indices_.reserve(expected_vertices);
        mesh_.vertices.reserve(expected_vertices);
    }

    int index_of(const cv::Vec3f& point) {
        Key key{};
        for (int k = 0; k < 3; ++k) {
            const float value = point[k] == 0.0f ? 0.0f : point[k];
            std::memcpy(&key.bits[k], &value, sizeof(float));
        }
        const auto [it, inserted] = indices_.try_emplace(key, static_cast<int>(mesh_.vertices.size()));
        if (inserted) mesh_.vertices.push_back(point);
        return it->second;
    }

private:
    struct Key {
        uint32_t bits[3];
        bool operator==(const Key& other) const {
            return bits[0] == other.bits[0] && bits[1] == other.bits[1] && bits[2] == other.bits[2];
        }
    };
    struct KeyHash {
        size_t operator()(const Key& key) const {
            uint64_t h = 1469598103934665603ull;
            for (uint32_t b : key.bits) h = (h ^ b) * 1099511628211ull;
            return static_cast<size_t>(h ^ (h >> 29));
        }
    };
    Mesh& mesh_;
    std::unordered_map<Key, int, KeyHash> indices_;
};

float load_le_float(const char* p) {
    unsigned char bytes[4];
    std::memcpy(bytes, p, 4);
    if (!detail::host_is_little_endian()) {
        std::swap(bytes[0], bytes[3]);
        std::swap(bytes[1], bytes[2]);
    }
    float value;
    std::memcpy(&value, bytes, 4);
    return value;
}

uint32_t load_le_u32(const char* p) {
    const auto* b = reinterpret_cast<const unsigned char*>(p);
    return static_cast<uint32_t>(b[0]) | static_cast<uint32_t>(b[1]) << 8 |
           static_cast<uint32_t>(b[2]) << 16 | static_cast<uint32_t>(b[3]) << 24;
}

Mesh parse_binary_stl(const std::string& data, const std::string& path, const ProgressCallback& progress) {
    const uint64_t triangles = load_le_u32(data.data() + kBinaryHeaderBytes);
    const uint64_t needed = kBinaryPrefixBytes + triangles * kBinaryTriangleBytes;
    if (needed > data.size())
        throw Error(path, "truncated or corrupt binary STL: its header declares " + std::to_string(triangles) +
                              " triangles (" + std::to_string(needed) + " bytes) but the file has " +
                              std::to_string(data.size()) + " bytes");
    Mesh mesh;
    mesh.faces.reserve(static_cast<size_t>(triangles));
    VertexMerger merger(mesh, static_cast<size_t>(triangles / 2 + 3));
    detail::ReadProgress read(progress, path, triangles);
    const char* record = data.data() + kBinaryPrefixBytes;
    for (uint64_t t = 0; t < triangles; ++t, record += kBinaryTriangleBytes) {
        cv::Vec3i face;
        for (int corner = 0; corner < 3; ++corner) {
            const char* p = record + 12 + corner * 12;  // skip the stored facet normal
            face[corner] = merger.index_of({load_le_float(p), load_le_float(p + 4), load_le_float(p + 8)});
        }
        mesh.faces.push_back(face);
        read.record_done();
    }
    return mesh;
}

class AsciiTokens {
public:
    AsciiTokens(const std::string& data, const std::string& path)
        : pos_(data.data()), end_(data.data() + data.size()), path_(path) {}

    bool at_end() {
        skip_space();
        return pos_ == end_;
    }
    std::string_view next() {
        skip_space();
        if (pos_ == end_) fail("file ends early");
        const char* start = pos_;
        while (pos_ < end_ && !is_space(*pos_)) ++pos_;
        return {start, static_cast<size_t>(pos_ - start)};
    }
    void skip_line() {
        while (pos_ < end_ && *pos_ != '\n') ++pos_;
    }
    void expect(std::string_view keyword) {
        const std::string_view word = next();
        if (detail::lower_case(word) != keyword)
            fail("expected '" + std::string(keyword) + "' but found '" + std::string(word.substr(0, 32)) + "'");
    }
    float number() {
        const std::string_view word = next();
        double value = 0;
        if (!detail::parse_double(word, value)) fail("bad number '" + std::string(word.substr(0, 32)) + "'");
        return detail::to_float(value);
    }
    [[noreturn]] void fail(const std::string& problem) const {
        throw Error(path_, "ASCII STL: " + problem);
    }

private:
    static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }
    void skip_space() {
        while (pos_ < end_ && is_space(*pos_)) ++pos_;
    }
    const char* pos_;
    const char* end_;
    const std::string& path_;
};

Mesh parse_ascii_stl(const std::string& data, const std::string& path, const ProgressCallback& progress) {
    AsciiTokens tokens(data, path);
    Mesh mesh;
    constexpr size_t kTextBytesPerTriangle = 250;  // about; the progress is an estimate
    VertexMerger merger(mesh, data.size() / (2 * kTextBytesPerTriangle));
    detail::ReadProgress read(progress, path, data.size() / kTextBytesPerTriangle + 1);
    std::vector<int> polygon;
    bool in_solid = false;
    bool seen_solid = false;
    while (!tokens.at_end()) {
        const std::string keyword = detail::lower_case(tokens.next());
        if (keyword == "solid") {
            if (in_solid) tokens.fail("'solid' inside a solid");
            in_solid = seen_solid = true;
            tokens.skip_line();  // the name is free text
        } else if (keyword == "endsolid") {
            if (!in_solid) tokens.fail("'endsolid' without 'solid'");
            in_solid = false;
            tokens.skip_line();
        } else if (keyword == "facet") {
            if (!in_solid) tokens.fail("'facet' outside a solid");
            tokens.expect("normal");
            for (int k = 0; k < 3; ++k) tokens.number();  // recomputed from the winding if needed
            tokens.expect("outer");
            tokens.expect("loop");
            polygon.clear();
            for (;;) {
                const std::string word = detail::lower_case(tokens.next());
                if (word == "endloop") break;
                if (word != "vertex") tokens.fail("expected 'vertex' or 'endloop' but found '" + word.substr(0, 32) + "'");
                const float x = tokens.number(), y = tokens.number(), z = tokens.number();
                polygon.push_back(merger.index_of({x, y, z}));
            }
            tokens.expect("endfacet");
            if (polygon.size() < 3) tokens.fail("facet with fewer than three vertices");
            for (size_t i = 2; i < polygon.size(); ++i)
                mesh.faces.emplace_back(polygon[0], polygon[i - 1], polygon[i]);
            read.record_done();
        } else {
            tokens.fail("unexpected '" + keyword.substr(0, 32) + "'");
        }
    }
    if (!seen_solid) tokens.fail("no 'solid'");
    return mesh;
}

// ASCII STL is text: a NUL or another control byte (not white space) means binary data,
// even behind a header that begins with "solid".
bool has_binary_bytes(const std::string& data) {
    for (const char c : data) {
        const auto byte = static_cast<unsigned char>(c);
        if (byte < 32 && byte != ' ' && byte != '\t' && byte != '\n' && byte != '\r' && byte != '\f' && byte != '\v')
            return true;
    }
    return false;
}

bool starts_with_solid(const std::string& data) {
    size_t i = 0;
    while (i < data.size() && (data[i] == ' ' || data[i] == '\t' || data[i] == '\r' || data[i] == '\n')) ++i;
    return detail::lower_case(std::string_view(data).substr(i, 5)) == "solid";
}

}  // namespace

void write_stl(const Mesh& mesh, const std::string& path, Encoding encoding) {
    detail::check_mesh(mesh, path);
    if (mesh.faces.size() > std::numeric_limits<uint32_t>::max())
        throw Error(path, "too many triangles for binary STL");
    write_file_atomically(path, encoding == Encoding::Binary ? build_binary_stl(mesh) : build_ascii_stl(mesh));
}

Mesh read_stl(const std::string& path, const ProgressCallback& progress) {
    const std::string data = detail::read_whole_file(path);
    // Binary files often start with "solid" too, so the size decides: a binary file is
    // exactly 84 + 50 n bytes. A file that does not start with "solid" is binary anyway
    // (some writers pad the end).
    if (data.size() >= kBinaryPrefixBytes) {
        const uint64_t triangles = load_le_u32(data.data() + kBinaryHeaderBytes);
        const bool exact = kBinaryPrefixBytes + triangles * kBinaryTriangleBytes == data.size();
        if (exact || !starts_with_solid(data) || has_binary_bytes(data)) return parse_binary_stl(data, path, progress);
    }
    if (starts_with_solid(data)) return parse_ascii_stl(data, path, progress);
    throw Error(path, "not an STL file (too short for binary, no 'solid' for ASCII)");
}

}  // namespace picoscan
