// Writing files so that a failure never leaves a half-written one: every writer of the core
// (clouds, meshes, images, manifests, calibrations, reports) goes through these.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace picoscan {

// Writes `bytes` to `path` through a temporary file beside it, synced and renamed over `path`.
void write_file_atomically(const std::string& path, const std::string& bytes);

// Encodes `image` in the format its extension names (.png, .jpg, .tif, ...) and writes it
// atomically. Throws Error naming the file when the image cannot be encoded.
void write_image_file(const cv::Mat& image, const std::string& path);

}  // namespace picoscan
