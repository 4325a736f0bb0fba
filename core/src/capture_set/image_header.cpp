#include "capture_set/image_header.h"

#include "picoscan/error.h"

#include <cstdint>
#include <fstream>
#include <vector>

namespace picoscan::detail {

namespace {

// JPEG headers may be preceded by metadata segments; real ones fit well within this.
constexpr size_t kLongestHeader = 1 << 20;

class Bytes {
public:
    Bytes(std::vector<unsigned char> data, std::string path) : data_(std::move(data)), path_(std::move(path)) {}
    size_t size() const { return data_.size(); }
    uint32_t at(size_t offset, int count, bool big_endian) const {
        if (offset + count > data_.size()) throw Error(path_, "image header is truncated");
        uint32_t value = 0;
        for (int i = 0; i < count; ++i) {
            const uint32_t byte = data_[offset + (big_endian ? i : count - 1 - i)];
            value = (value << 8) | byte;
        }
        return value;
    }

private:
    std::vector<unsigned char> data_;
    std::string path_;
};

ImageHeader png(const Bytes& bytes, const std::string& path) {
    if (bytes.at(12, 4, true) != 0x49484452u) throw Error(path, "PNG has no IHDR header chunk");  // "IHDR"
    ImageHeader header;
    header.size = {int(bytes.at(16, 4, true) & 0x7fffffff), int(bytes.at(20, 4, true) & 0x7fffffff)};
    header.bytes_per_sample = bytes.at(24, 1, true) == 16 ? 2 : 1;
    return header;
}

ImageHeader bmp(const Bytes& bytes) {
    ImageHeader header;
    const int32_t width = int32_t(bytes.at(18, 4, false)), height = int32_t(bytes.at(22, 4, false));
    header.size = {width < 0 ? 0 : width, height == INT32_MIN ? 0 : (height < 0 ? -height : height)};
    return header;
}

ImageHeader jpeg(const Bytes& bytes, const std::string& path) {
    size_t at = 2;
    while (at + 4 <= bytes.size()) {
        if (bytes.at(at, 1, true) != 0xFF) throw Error(path, "JPEG header is malformed");
        const uint32_t marker = bytes.at(at + 1, 1, true);
        if (marker == 0xFF) {  // fill byte
            ++at;
            continue;
        }
        const uint32_t length = bytes.at(at + 2, 2, true);
        const bool start_of_frame = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
        if (start_of_frame) {
            ImageHeader header;
            header.size = {int(bytes.at(at + 7, 2, true)), int(bytes.at(at + 5, 2, true))};
            return header;
        }
        if (length < 2) throw Error(path, "JPEG header is malformed");
        at += 2 + length;
    }
    throw Error(path, "JPEG has no frame header within its first MB");
}

ImageHeader tiff(const Bytes& bytes, const std::string& path) {
    const bool big_endian = bytes.at(0, 1, true) == 'M';
    const size_t directory = bytes.at(4, 4, big_endian);
    const uint32_t entries = bytes.at(directory, 2, big_endian);
    ImageHeader header;
    for (uint32_t i = 0; i < entries; ++i) {
        const size_t entry = directory + 2 + 12 * size_t(i);
        const uint32_t tag = bytes.at(entry, 2, big_endian), type = bytes.at(entry + 2, 2, big_endian);
        const uint32_t value = type == 3 ? bytes.at(entry + 8, 2, big_endian) : bytes.at(entry + 8, 4, big_endian);
        if (tag == 256) header.size.width = int(value & 0x7fffffff);
        if (tag == 257) header.size.height = int(value & 0x7fffffff);
        if (tag == 258 && value == 16) header.bytes_per_sample = 2;
    }
    if (header.size.width == 0 || header.size.height == 0) throw Error(path, "TIFF has no image width and height");
    return header;
}

}  // namespace

ImageHeader read_image_header(const std::string& path) {
    std::ifstream stream(path, std::ios::binary);
    if (!stream) throw Error(path, "cannot open the image");
    std::vector<unsigned char> data(kLongestHeader);
    stream.read(reinterpret_cast<char*>(data.data()), std::streamsize(data.size()));
    data.resize(size_t(stream.gcount()));
    const Bytes bytes(std::move(data), path);
    if (bytes.size() < 8) throw Error(path, "image is truncated");

    ImageHeader header;
    if (bytes.at(0, 4, true) == 0x89504E47u) header = png(bytes, path);
    else if (bytes.at(0, 2, true) == 0x424Du) header = bmp(bytes);                 // "BM"
    else if (bytes.at(0, 2, true) == 0xFFD8u) header = jpeg(bytes, path);
    else if (bytes.at(0, 4, true) == 0x49492A00u || bytes.at(0, 4, true) == 0x4D4D002Au) header = tiff(bytes, path);
    else throw Error(path, "not a PNG, BMP, JPEG or TIFF image");
    if (header.size.width < 1 || header.size.height < 1) throw Error(path, "image header gives no size");
    return header;
}

bool image_file_complete(const std::string& path) {
    try {
        read_image_header(path);
    } catch (const Error&) {
        return false;
    }
    std::ifstream stream(path, std::ios::binary | std::ios::ate);
    const std::streamoff size = stream.tellg();
    if (size < 12) return false;
    unsigned char first[2] = {0, 0}, tail[12] = {};
    stream.seekg(0);
    stream.read(reinterpret_cast<char*>(first), 2);
    stream.seekg(size - 12);
    stream.read(reinterpret_cast<char*>(tail), 12);
    if (!stream) return false;
    if (first[0] == 0x89 && first[1] == 'P') return std::string(reinterpret_cast<char*>(tail) + 4, 4) == "IEND";
    if (first[0] == 0xFF && first[1] == 0xD8) return tail[10] == 0xFF && tail[11] == 0xD9;
    return true;
}

}  // namespace picoscan::detail
