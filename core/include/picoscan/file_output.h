// Writing files so that a failure never leaves a half-written one: every writer of the core
// (clouds, meshes, images, manifests, calibrations, reports) goes through these.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace picoscan {

// Writes `bytes` to `path` through a temporary file beside it, synced and renamed over `path`.
// Temporary files are removed on failure and, unless the host handles these signals itself,
// on SIGINT, SIGTERM and SIGHUP.
void write_file_atomically(const std::string& path, const std::string& bytes);

// The outputs of one command, replaced together. While a batch is alive, every write
// through write_file_atomically (from any thread) stays in its temporary file; commit()
// renames them all into place. A batch destroyed without commit() (an error on the way)
// removes the temporary files, so the old outputs stay whole. One batch at a time.
class OutputBatch {
public:
    OutputBatch();
    ~OutputBatch();
    OutputBatch(const OutputBatch&) = delete;
    OutputBatch& operator=(const OutputBatch&) = delete;
    void commit();
};

// Encodes `image` in the format its extension names (.png, .jpg, .tif, ...) and writes it
// atomically. Throws Error naming the file when the image cannot be encoded.
void write_image_file(const cv::Mat& image, const std::string& path);

}  // namespace picoscan
