// PLY reading: ASCII, binary little- and big-endian; any property order and scalar type;
// unknown properties and elements skipped; polygons triangulated as fans.
// The input is untrusted: every count is checked against the bytes that are left before
// anything is allocated, and every failure is an Error naming the file.
#include "common/memory_budget.h"
#include "cloud/view_check.h"
#include "io/io_detail.h"
#include "picoscan/error.h"
#include "picoscan/io.h"

#include <algorithm>
#include <cstring>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace picoscan {

namespace {

enum class Scalar { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };
enum class Format { Ascii, BinaryLittle, BinaryBig };

std::optional<Scalar> parse_scalar(std::string_view name) {
    if (name == "char" || name == "int8") return Scalar::Int8;
    if (name == "uchar" || name == "uint8") return Scalar::UInt8;
    if (name == "short" || name == "int16") return Scalar::Int16;
    if (name == "ushort" || name == "uint16") return Scalar::UInt16;
    if (name == "int" || name == "int32") return Scalar::Int32;
    if (name == "uint" || name == "uint32") return Scalar::UInt32;
    if (name == "float" || name == "float32") return Scalar::Float32;
    if (name == "double" || name == "float64") return Scalar::Float64;
    return std::nullopt;
}

size_t scalar_size(Scalar type) {
    switch (type) {
        case Scalar::Int8: case Scalar::UInt8: return 1;
        case Scalar::Int16: case Scalar::UInt16: return 2;
        case Scalar::Int32: case Scalar::UInt32: case Scalar::Float32: return 4;
        case Scalar::Float64: return 8;
    }
    return 1;
}

bool is_float(Scalar type) { return type == Scalar::Float32 || type == Scalar::Float64; }

struct Property {
    std::string name;
    Scalar type = Scalar::Float32;  // item type for lists
    bool is_list = false;
    Scalar count_type = Scalar::UInt8;
};

struct Element {
    std::string name;
    uint64_t count = 0;
    std::vector<Property> properties;

    // Fewest bytes (binary) or tokens (ASCII) one record can take: lists may be empty.
    size_t min_record_units(bool binary) const {
        size_t units = 0;
        for (const Property& p : properties)
            units += binary ? scalar_size(p.is_list ? p.count_type : p.type) : 1;
        return units;
    }
    bool has_lists() const {
        return std::any_of(properties.begin(), properties.end(), [](const Property& p) { return p.is_list; });
    }
    int find(std::string_view wanted) const {
        for (size_t i = 0; i < properties.size(); ++i)
            if (properties[i].name == wanted) return static_cast<int>(i);
        return -1;
    }
};

struct Header {
    Format format = Format::Ascii;
    std::vector<std::string> comments;
    std::vector<Element> elements;
    size_t body_offset = 0;
};

std::vector<std::string_view> split_words(std::string_view line) {
    std::vector<std::string_view> words;
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
        const size_t start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
        if (i > start) words.push_back(line.substr(start, i - start));
    }
    return words;
}

bool parse_count(std::string_view text, uint64_t& value) {
    if (text.empty()) return false;
    value = 0;
    for (char c : text) {
        if (c < '0' || c > '9') return false;
        const uint64_t digit = static_cast<uint64_t>(c - '0');
        if (value > (std::numeric_limits<uint64_t>::max() - digit) / 10) return false;
        value = value * 10 + digit;
    }
    return true;
}

Header parse_header(const std::string& data, const std::string& path) {
    auto fail = [&](const std::string& problem) -> Error { return Error(path, "PLY header: " + problem); };
    Header header;
    bool have_format = false;
    bool first = true;
    size_t pos = 0;
    for (;;) {
        if (pos >= data.size()) throw fail(first ? "not a PLY file (no 'ply' line)" : "end_header missing");
        // The last line may lack its newline (an empty file body).
        const size_t newline = std::min(data.find('\n', pos), data.size());
        std::string_view line(data.data() + pos, newline - pos);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        pos = std::min(newline + 1, data.size());
        const std::vector<std::string_view> words = split_words(line);
        if (first) {
            if (words.size() != 1 || words[0] != "ply") throw fail("not a PLY file (no 'ply' line)");
            first = false;
            continue;
        }
        if (words.empty()) continue;
        const std::string_view keyword = words[0];
        if (keyword == "comment" || keyword == "obj_info") {
            const size_t text = line.find(keyword) + keyword.size();
            header.comments.emplace_back(line.substr(std::min(text + 1, line.size())));
            continue;
        }
        if (keyword == "end_header") {
            if (!have_format) throw fail("format line missing");
            header.body_offset = pos;
            return header;
        }
        if (keyword == "format") {
            if (have_format) throw fail("more than one format line");
            if (words.size() < 3) throw fail("format line incomplete");
            if (words[1] == "ascii") header.format = Format::Ascii;
            else if (words[1] == "binary_little_endian") header.format = Format::BinaryLittle;
            else if (words[1] == "binary_big_endian") header.format = Format::BinaryBig;
            else throw fail("unknown format '" + std::string(words[1]) + "'");
            have_format = true;
        } else if (keyword == "element") {
            if (words.size() < 2) throw fail("element name missing");
            Element element;
            element.name = std::string(words[1]);
            if (words.size() < 3) throw fail("element " + element.name + " count missing");
            if (!parse_count(words[2], element.count))
                throw fail("element " + element.name + " has a bad count '" + std::string(words[2]) + "'");
            for (const Element& other : header.elements)
                if (other.name == element.name) throw fail("element " + element.name + " declared twice");
            header.elements.push_back(std::move(element));
        } else if (keyword == "property") {
            if (header.elements.empty()) throw fail("property before any element");
            Property property;
            if (words.size() >= 2 && words[1] == "list") {
                if (words.size() < 5) throw fail("list property incomplete");
                const auto count_type = parse_scalar(words[2]);
                const auto item_type = parse_scalar(words[3]);
                if (!count_type || !item_type)
                    throw fail("unknown list type in '" + std::string(line) + "'");
                if (is_float(*count_type)) throw fail("list count type must be an integer type");
                property.is_list = true;
                property.count_type = *count_type;
                property.type = *item_type;
                property.name = std::string(words[4]);
            } else {
                if (words.size() < 3) throw fail("property incomplete: '" + std::string(line) + "'");
                const auto type = parse_scalar(words[1]);
                if (!type) throw fail("unknown property type '" + std::string(words[1]) + "'");
                property.type = *type;
                property.name = std::string(words[2]);
            }
            header.elements.back().properties.push_back(std::move(property));
        } else {
            throw fail("unexpected line '" + std::string(line.substr(0, 40)) + "'");
        }
    }
}

// Reads scalars from the body in the file's encoding, never past its end.
class BodyReader {
public:
    BodyReader(const std::string& data, size_t offset, Format format, const std::string& path)
        : pos_(data.data() + offset), end_(data.data() + data.size()), format_(format), path_(path) {}

    bool binary() const { return format_ != Format::Ascii; }
    size_t remaining() const { return static_cast<size_t>(end_ - pos_); }
    void set_context(const Element& element, uint64_t record) {
        element_ = &element;
        record_ = record;
    }

    double scalar(Scalar type) { return binary() ? binary_scalar(type) : ascii_scalar(); }

    // A list count: a non-negative integer whose items can still fit in the file.
    uint64_t list_count(const Property& property) {
        const double value = scalar(property.count_type);
        if (!(value >= 0) || value != std::floor(value)) fail("bad list count");
        // Each item takes at least one byte (binary: its size; ASCII: a digit and a space).
        const double per_item = binary() ? static_cast<double>(scalar_size(property.type)) : 1.0;
        if (value * per_item > static_cast<double>(remaining())) fail("list count beyond the end of the file");
        return static_cast<uint64_t>(value);
    }

    // One binary record of scalars only, each into values[property]: its room was checked
    // for the whole element (check_count_fits), so no value needs a check of its own.
    void fixed_record(const std::vector<Property>& properties, std::vector<double>& values) {
        const bool swap = (format_ == Format::BinaryLittle) != detail::host_is_little_endian();
        for (size_t p = 0; p < properties.size(); ++p) {
            const Scalar type = properties[p].type;
            if (swap) {
                values[p] = binary_scalar(type);
                continue;
            }
            switch (type) {
                case Scalar::Int8: values[p] = unchecked<int8_t>(); break;
                case Scalar::UInt8: values[p] = unchecked<uint8_t>(); break;
                case Scalar::Int16: values[p] = unchecked<int16_t>(); break;
                case Scalar::UInt16: values[p] = unchecked<uint16_t>(); break;
                case Scalar::Int32: values[p] = unchecked<int32_t>(); break;
                case Scalar::UInt32: values[p] = unchecked<uint32_t>(); break;
                case Scalar::Float32: values[p] = unchecked<float>(); break;
                case Scalar::Float64: values[p] = unchecked<double>(); break;
            }
        }
    }

    void skip_bytes(size_t bytes) {
        if (bytes > remaining()) fail("file ends early");
        pos_ += bytes;
    }

    [[noreturn]] void fail(const std::string& problem) const {
        std::string where;
        if (element_)
            where = " in element " + element_->name + " record " + std::to_string(record_);
        throw Error(path_, "PLY body: " + problem + where);
    }

private:
    template <class T>
    T load() {
        if (sizeof(T) > remaining()) fail("file ends early");
        unsigned char bytes[sizeof(T)];
        std::memcpy(bytes, pos_, sizeof(T));
        pos_ += sizeof(T);
        const bool file_little = format_ == Format::BinaryLittle;
        if (file_little != detail::host_is_little_endian())
            for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
        T value;
        std::memcpy(&value, bytes, sizeof(T));
        return value;
    }

    // A value in the host's byte order, known to lie before the end.
    template <class T>
    T unchecked() {
        T value;
        std::memcpy(&value, pos_, sizeof(T));
        pos_ += sizeof(T);
        return value;
    }

    double binary_scalar(Scalar type) {
        switch (type) {
            case Scalar::Int8: return load<int8_t>();
            case Scalar::UInt8: return load<uint8_t>();
            case Scalar::Int16: return load<int16_t>();
            case Scalar::UInt16: return load<uint16_t>();
            case Scalar::Int32: return load<int32_t>();
            case Scalar::UInt32: return load<uint32_t>();
            case Scalar::Float32: return load<float>();
            case Scalar::Float64: return load<double>();
        }
        return 0;
    }

    double ascii_scalar() {
        while (pos_ < end_ && is_space(*pos_)) ++pos_;
        if (pos_ == end_) fail("file ends early");
        const char* start = pos_;
        while (pos_ < end_ && !is_space(*pos_)) ++pos_;
        const std::string_view token(start, static_cast<size_t>(pos_ - start));
        double value = 0;
        if (!detail::parse_double(token, value))
            fail("bad number '" + std::string(token.substr(0, 32)) + "'");
        return value;
    }

    static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }

    const char* pos_;
    const char* end_;
    Format format_;
    const std::string& path_;
    const Element* element_ = nullptr;
    uint64_t record_ = 0;
};

uint8_t to_colour_channel(double value, Scalar type) {
    // Float colours are taken as 0..1 (the common convention), integers as 0..255.
    if (is_float(type)) value *= 255.0;
    if (!(value > 0)) return 0;  // also NaN
    if (value >= 255) return 255;
    return static_cast<uint8_t>(std::lround(value));
}

// Refuses an element whose declared count cannot fit in what is left of the file.
void check_count_fits(const Element& element, BodyReader& body) {
    const size_t units = element.min_record_units(body.binary());
    if (units == 0) return;  // consumes nothing; the count cannot cause harm
    // ASCII: a token is at least one character plus a separator.
    const size_t available = body.binary() ? body.remaining() : body.remaining() / 2 + 1;
    if (element.count > available / units)
        body.fail("element " + element.name + " declares " + std::to_string(element.count) +
                  " records but the file is too short for them");
}

void skip_element(const Element& element, BodyReader& body, detail::ReadProgress& read) {
    if (element.properties.empty() || element.count == 0) return;
    if (body.binary() && !element.has_lists()) {
        body.skip_bytes(static_cast<size_t>(element.count) * element.min_record_units(true));
        for (uint64_t r = 0; r < element.count; ++r) read.record_done();
        return;
    }
    for (uint64_t r = 0; r < element.count; ++r) {
        body.set_context(element, r);
        read.record_done();
        for (const Property& property : element.properties) {
            if (!property.is_list) {
                body.scalar(property.type);
                continue;
            }
            const uint64_t items = body.list_count(property);
            if (body.binary()) {
                body.skip_bytes(static_cast<size_t>(items) * scalar_size(property.type));
            } else {
                for (uint64_t i = 0; i < items; ++i) body.scalar(property.type);
            }
        }
    }
}

void read_vertices(const Element& element, BodyReader& body, Mesh& mesh, detail::PlyExtras* extras,
                   detail::ReadProgress& read) {
    const int x = element.find("x"), y = element.find("y"), z = element.find("z");
    if (x < 0 || y < 0 || z < 0) body.fail("element vertex lacks x, y or z");
    for (int p : {x, y, z})
        if (element.properties[p].is_list) body.fail("vertex coordinate declared as a list");
    auto scalar_index = [&](std::initializer_list<const char*> names) {
        for (const char* name : names) {
            const int index = element.find(name);
            if (index >= 0 && !element.properties[index].is_list) return index;
        }
        return -1;
    };
    const int nx = scalar_index({"nx"}), ny = scalar_index({"ny"}), nz = scalar_index({"nz"});
    const int red = scalar_index({"red", "r", "diffuse_red"});
    const int green = scalar_index({"green", "g", "diffuse_green"});
    const int blue = scalar_index({"blue", "b", "diffuse_blue"});
    const bool has_normals = nx >= 0 && ny >= 0 && nz >= 0;
    const bool has_colours = red >= 0 && green >= 0 && blue >= 0;
    const int quality = extras ? scalar_index({"quality"}) : -1;
    const int pixel = extras ? scalar_index({"pixel"}) : -1;

    const size_t count = static_cast<size_t>(element.count);
    mesh.vertices.reserve(count);
    if (has_normals) mesh.normals.reserve(count);
    if (has_colours) mesh.colours.reserve(count);

    std::vector<double> values(element.properties.size(), 0.0);
    const bool fixed_size = body.binary() && !element.has_lists();  // check_count_fits made room for every record
    for (size_t r = 0; r < count; ++r) {
        body.set_context(element, r);
        read.record_done();
        if (fixed_size) {
            body.fixed_record(element.properties, values);
        } else {
            for (size_t p = 0; p < element.properties.size(); ++p) {
                const Property& property = element.properties[p];
                if (!property.is_list) {
                    values[p] = body.scalar(property.type);
                    continue;
                }
                const uint64_t items = body.list_count(property);
                for (uint64_t i = 0; i < items; ++i) body.scalar(property.type);
            }
        }
        mesh.vertices.emplace_back(detail::to_float(values[x]), detail::to_float(values[y]),
                                   detail::to_float(values[z]));
        if (has_normals)
            mesh.normals.emplace_back(detail::to_float(values[nx]), detail::to_float(values[ny]),
                                      detail::to_float(values[nz]));
        if (has_colours)
            mesh.colours.emplace_back(to_colour_channel(values[red], element.properties[red].type),
                                      to_colour_channel(values[green], element.properties[green].type),
                                      to_colour_channel(values[blue], element.properties[blue].type));
        if (quality >= 0) extras->quality.push_back(detail::to_float(values[quality]));
        if (pixel >= 0) {
            const double value = values[pixel];
            if (!(value >= 0 && value < 9.0e15) || value != std::floor(value)) body.fail("pixel index is not a count");
            extras->pixels.push_back(static_cast<int64_t>(value));
        }
    }
}

void read_faces(const Element& element, BodyReader& body, uint64_t vertex_count, Mesh& mesh, detail::ReadProgress& read) {
    int list = element.find("vertex_indices");
    if (list < 0 || !element.properties[list].is_list) list = element.find("vertex_index");
    if (list < 0 || !element.properties[list].is_list) body.fail("element face has no vertex_indices list");

    std::vector<int> polygon;
    for (uint64_t r = 0; r < element.count; ++r) {
        body.set_context(element, r);
        read.record_done();
        for (size_t p = 0; p < element.properties.size(); ++p) {
            const Property& property = element.properties[p];
            if (!property.is_list) {
                body.scalar(property.type);
                continue;
            }
            const uint64_t items = body.list_count(property);
            if (static_cast<int>(p) != list) {
                for (uint64_t i = 0; i < items; ++i) body.scalar(property.type);
                continue;
            }
            polygon.clear();
            for (uint64_t i = 0; i < items; ++i) {
                const double value = body.scalar(property.type);
                if (!(value >= 0) || value != std::floor(value) || value >= static_cast<double>(vertex_count)) {
                    std::string text;
                    detail::append_number(text, value);
                    body.fail("vertex index " + text + " but there are " + std::to_string(vertex_count) +
                              " vertices");
                }
                polygon.push_back(static_cast<int>(value));
            }
            // Fan triangulation keeps the polygon's winding.
            for (size_t i = 2; i < polygon.size(); ++i)
                mesh.faces.emplace_back(polygon[0], polygon[i - 1], polygon[i]);
        }
    }
}

Mesh read_ply_body(const std::string& path, detail::PlyExtras* extras, const ProgressCallback& progress) {
    const std::string data = detail::read_whole_file(path);
    const Header header = parse_header(data, path);

    uint64_t vertex_count = 0;
    uint64_t records = 0;
    bool have_vertices = false;
    for (const Element& element : header.elements) {
        records += element.count;
        if (element.name == "vertex") {
            vertex_count = element.count;
            have_vertices = true;
        }
    }
    // Faces hold int indices.
    if (vertex_count > static_cast<uint64_t>(std::numeric_limits<int>::max()))
        throw Error(path, "PLY header: too many vertices (" + std::to_string(vertex_count) + ")");
    if (!have_vertices) throw Error(path, "PLY header: element vertex missing");

    BodyReader body(data, header.body_offset, header.format, path);
    detail::ReadProgress read(progress, path, records);
    Mesh mesh;
    for (const Element& element : header.elements) {
        check_count_fits(element, body);
        if (element.name == "vertex") read_vertices(element, body, mesh, extras, read);
        else if (element.name == "face") read_faces(element, body, vertex_count, mesh, read);
        else skip_element(element, body, read);
    }
    if (extras) extras->comments = header.comments;
    return mesh;
}

}  // namespace

namespace detail {

Mesh read_ply_with_extras(const std::string& path, PlyExtras& extras) { return read_ply_body(path, &extras, {}); }

}  // namespace detail

Mesh read_ply(const std::string& path, const ProgressCallback& progress) { return read_ply_body(path, nullptr, progress); }

namespace {

constexpr int64_t kAnyGridPixels = int64_t(1) << 22;
constexpr int64_t kGridPixelsPerPoint = 256;
constexpr double kViewBytesPerPixel = 12 + 12 + 3 + 4;  // points, normals, colours, quality

}  // namespace

ScanView read_view_ply(const std::string& path) {
    detail::PlyExtras extras;
    const Mesh mesh = read_ply_with_extras(path, extras);
    int width = 0, height = 0;
    cv::Matx44d pose = cv::Matx44d::eye();
    cv::Matx33d camera_matrix = cv::Matx33d::zeros();
    cv::Mat distortion;
    bool have_grid = false;
    for (const std::string& comment : extras.comments) {
        const std::vector<std::string_view> words = split_words(comment);
        if (words.size() == 3 && words[0] == "picoscan_grid") {
            uint64_t w = 0, h = 0;
            if (!parse_count(words[1], w) || !parse_count(words[2], h) || w == 0 || h == 0 || w > 100000 ||
                h > 100000)
                throw Error(path, "picoscan_grid comment has no valid width and height");
            width = static_cast<int>(w);
            height = static_cast<int>(h);
            have_grid = true;
        } else if (words.size() == 6 && words[0] == "picoscan_camera") {
            double value[5];
            for (int i = 0; i < 5; ++i)
                if (!detail::parse_double(words[static_cast<size_t>(i) + 1], value[i]) || !std::isfinite(value[i]))
                    throw Error(path, "picoscan_camera comment has a malformed number");
            if (!(value[0] > 0 && value[1] > 0)) throw Error(path, "picoscan_camera comment has a non-positive focal length");
            camera_matrix = cv::Matx33d(value[0], value[4], value[2], 0, value[1], value[3], 0, 0, 1);
        } else if (!words.empty() && words[0] == "picoscan_distortion") {
            if (words.size() > 15) throw Error(path, "picoscan_distortion comment has more than 14 coefficients");
            distortion = cv::Mat::zeros(1, static_cast<int>(words.size()) - 1, CV_64F);
            for (size_t i = 1; i < words.size(); ++i)
                if (!detail::parse_double(words[i], distortion.at<double>(static_cast<int>(i) - 1)) ||
                    !std::isfinite(distortion.at<double>(static_cast<int>(i) - 1)))
                    throw Error(path, "picoscan_distortion comment has a malformed number");
        } else if (!words.empty() && words[0] == "picoscan_pose") {
            if (words.size() != 17) throw Error(path, "picoscan_pose comment needs 16 numbers");
            for (int i = 0; i < 16; ++i)
                if (!detail::parse_double(words[static_cast<size_t>(i) + 1], pose(i / 4, i % 4)))
                    throw Error(path, "picoscan_pose comment has a malformed number");
        }
    }
    if (!have_grid || extras.pixels.size() != mesh.vertices.size())
        throw Error(path, "has no camera pixel grid (write it with 'picoscan reconstruct' to keep one)");

    // The grid is a camera image: a few bytes must not make it allocate gigabytes. Beyond
    // a 4-megapixel camera, a view keeps at least one point per 256 grid pixels.
    const int64_t pixel_count = static_cast<int64_t>(width) * height;
    const int64_t allowed_pixels = std::max<int64_t>(kAnyGridPixels, kGridPixelsPerPoint * int64_t(mesh.vertices.size()));
    if (pixel_count > allowed_pixels)
        throw Error(path, "picoscan_grid " + std::to_string(width) + "x" + std::to_string(height) + " has " +
                              std::to_string(pixel_count) + " pixels for only " + std::to_string(mesh.vertices.size()) +
                              " points (a grid over 4 Mpixel needs a point per 256 pixels)");
    for (size_t i = 0; i < extras.pixels.size(); ++i)
        if (extras.pixels[i] < 0 || extras.pixels[i] >= pixel_count)
            throw Error(path, "vertex " + std::to_string(i) + " has a pixel outside the grid");
    for (size_t i = 0; i < mesh.vertices.size(); ++i)
        if (detail::beyond_reach(mesh.vertices[i]))  // NaN (not measured) passes
            throw Error(path, "vertex " + std::to_string(i) + " lies beyond 1 km (1e6 mm) from the origin: not a scan view");
    detail::check_memory_budget(double(pixel_count) * kViewBytesPerPixel, path,
                                "the " + std::to_string(width) + "x" + std::to_string(height) + " pixel grid");

    ScanView view;
    view.pose = pose;
    view.camera_matrix = camera_matrix;
    view.camera_distortion = distortion;
    // A view measures a few percent of its grid: the zero grids are left as the system's
    // fresh pages, written only where a point is.
    view.points = detail::nan_grid(height, width, CV_32FC3);
    if (!mesh.normals.empty()) view.normals = detail::zeroed_grid(height, width, CV_32FC3);
    if (!mesh.colours.empty()) view.colours = detail::zeroed_grid(height, width, CV_8UC3);
    if (!extras.quality.empty()) view.quality = detail::zeroed_grid(height, width, CV_32F);
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        const int64_t pixel = extras.pixels[i];
        const int y = static_cast<int>(pixel / width), x = static_cast<int>(pixel % width);
        view.points.at<cv::Vec3f>(y, x) = mesh.vertices[i];
        if (!view.normals.empty()) view.normals.at<cv::Vec3f>(y, x) = mesh.normals[i];
        if (!view.colours.empty()) {
            const cv::Vec3b rgb = mesh.colours[i];
            view.colours.at<cv::Vec3b>(y, x) = cv::Vec3b(rgb[2], rgb[1], rgb[0]);
        }
        if (!view.quality.empty()) view.quality.at<float>(y, x) = extras.quality[i];
    }
    return view;
}

}  // namespace picoscan
