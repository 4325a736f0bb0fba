// Image sizes read from the file's header, before any decoding, so that a small file that
// claims a huge image is refused before it is decoded.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace picoscan::detail {

struct ImageHeader {
    cv::Size size;
    int bytes_per_sample = 1;  // 2 for 16-bit PNG and TIFF
};

// The size in the header of a PNG, BMP, JPEG or TIFF file; throws Error(path, ...) when the
// header is missing, truncated or names an impossible size.
ImageHeader read_image_header(const std::string& path);

// Whether the file is a whole image: a readable header and, for PNG and JPEG, the end marker
// (IEND, EOI) at the end, so that a frame cut short by a crash or a copy is not taken as present.
bool image_file_complete(const std::string& path);

}  // namespace picoscan::detail
