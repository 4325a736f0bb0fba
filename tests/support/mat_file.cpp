#include "support/mat_file.h"

#include <zlib.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace picoscan::test_support {

namespace {

// MATLAB v5 data types.
enum : uint32_t { kInt8 = 1, kUInt8 = 2, kInt16 = 3, kUInt16 = 4, kInt32 = 5, kUInt32 = 6, kSingle = 7,
                  kDouble = 9, kInt64 = 12, kUInt64 = 13, kMatrix = 14, kCompressed = 15 };

struct Element {
    uint32_t type = 0;
    const uint8_t* data = nullptr;
    uint32_t size = 0;
};

// Reads one tagged element at `offset` (small or normal format) and advances past its padding.
Element next_element(const std::vector<uint8_t>& bytes, size_t& offset) {
    if (offset + 8 > bytes.size()) throw std::runtime_error("mat: truncated tag");
    uint32_t first, second;
    std::memcpy(&first, &bytes[offset], 4);
    std::memcpy(&second, &bytes[offset + 4], 4);
    Element element;
    if (first >> 16) {  // small element: size in the upper half, data in the tag's second word
        element.type = first & 0xffff;
        element.size = first >> 16;
        element.data = &bytes[offset + 4];
        offset += 8;
        return element;
    }
    element.type = first;
    element.size = second;
    if (offset + 8 + size_t(element.size) > bytes.size()) throw std::runtime_error("mat: truncated element");
    element.data = &bytes[offset + 8];
    offset += 8 + size_t(element.size);
    if (element.type != kCompressed) offset = (offset + 7) & ~size_t(7);
    return element;
}

template <typename T>
void append_as_double(const Element& element, std::vector<double>& values) {
    const size_t count = element.size / sizeof(T);
    for (size_t index = 0; index < count; ++index) {
        T value;
        std::memcpy(&value, element.data + index * sizeof(T), sizeof(T));
        values.push_back(double(value));
    }
}

void read_matrix(const std::vector<uint8_t>& bytes, std::map<std::string, MatArray>& arrays) {
    size_t offset = 0;
    const Element flags = next_element(bytes, offset);
    const Element dimensions = next_element(bytes, offset);
    const Element name = next_element(bytes, offset);
    if (flags.type != kUInt32 || dimensions.type != kInt32) return;
    const uint8_t matlab_class = flags.data[0];
    if (matlab_class < 6 || matlab_class > 15) return;  // not a numeric array
    MatArray array;
    for (uint32_t index = 0; index < dimensions.size / 4; ++index) {
        int32_t value;
        std::memcpy(&value, dimensions.data + 4 * index, 4);
        array.dimensions.push_back(value);
    }
    const Element real = next_element(bytes, offset);
    switch (real.type) {
    case kDouble: append_as_double<double>(real, array.values); break;
    case kSingle: append_as_double<float>(real, array.values); break;
    case kUInt8: append_as_double<uint8_t>(real, array.values); break;
    case kInt8: append_as_double<int8_t>(real, array.values); break;
    case kInt16: append_as_double<int16_t>(real, array.values); break;
    case kUInt16: append_as_double<uint16_t>(real, array.values); break;
    case kInt32: append_as_double<int32_t>(real, array.values); break;
    case kUInt32: append_as_double<uint32_t>(real, array.values); break;
    default: return;
    }
    arrays[std::string(reinterpret_cast<const char*>(name.data), name.size)] = std::move(array);
}

}  // namespace

std::map<std::string, MatArray> read_mat_file(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
    if (bytes.size() < 128 || std::memcmp(bytes.data(), "MATLAB 5.0", 10) != 0)
        throw std::runtime_error(path + ": not a MATLAB 5.0 file");
    std::map<std::string, MatArray> arrays;
    size_t offset = 128;
    while (offset + 8 <= bytes.size()) {
        const Element element = next_element(bytes, offset);
        if (element.type == kCompressed) {
            std::vector<uint8_t> inflated;
            z_stream stream{};
            inflateInit(&stream);
            stream.next_in = const_cast<Bytef*>(element.data);
            stream.avail_in = element.size;
            uint8_t chunk[1 << 16];
            int status;
            do {
                stream.next_out = chunk;
                stream.avail_out = sizeof chunk;
                status = inflate(&stream, Z_NO_FLUSH);
                if (status != Z_OK && status != Z_STREAM_END) {
                    inflateEnd(&stream);
                    throw std::runtime_error(path + ": corrupt compressed element");
                }
                inflated.insert(inflated.end(), chunk, chunk + (sizeof chunk - stream.avail_out));
            } while (status != Z_STREAM_END);
            inflateEnd(&stream);
            size_t inner = 0;
            const Element matrix = next_element(inflated, inner);
            if (matrix.type == kMatrix)
                read_matrix(std::vector<uint8_t>(matrix.data, matrix.data + matrix.size), arrays);
        } else if (element.type == kMatrix) {
            read_matrix(std::vector<uint8_t>(element.data, element.data + element.size), arrays);
        }
    }
    return arrays;
}

}  // namespace picoscan::test_support
