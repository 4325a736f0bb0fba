// OpenCV's image codecs (cv::imread, cv::imencode), loaded on first use. Linked directly,
// libopencv_imgcodecs brings about 115 more shared libraries (GDAL, GDCM, codecs of every
// kind) into every process: about 0.17 s of CPU at each start of 'picoscan', most of whose
// commands (clean, stitch, mesh, section) never read or write an image.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace picoscan::detail {

// cv::imread(path, flags); throws Error when the codec library cannot be loaded.
cv::Mat imread(const std::string& path, int flags);
// cv::imencode(extension, image, bytes); throws Error when the codec library cannot be loaded.
bool imencode(const std::string& extension, const cv::Mat& image, std::vector<uint8_t>& bytes);

}  // namespace picoscan::detail
