// A capture set: one camera image per frame of a PatternSequence, plus the manifest.
#pragma once

#include "picoscan/patterns.h"
#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

struct CaptureSet {
    std::string directory;
    PatternSequence sequence;
    std::vector<cv::Mat> images;  // one per frame, single channel, CV_8U or CV_16U, all one size
    cv::Mat white_colour;         // the white frame in colour (CV_8UC3), for the cloud's colour
};

// Loads the images named by the manifest. `manifest_path` empty means
// "<directory>/sequence.json". Throws Error naming the file for missing, unreadable or
// corrupt images, mismatched sizes or bit depths, and extra image files in the directory.
// Image sizes are read from the headers first: every image must match the first one and
// `expected_size` (the calibration's camera_size) when given, within kLargestImageSide and
// the memory budget, before any image is decoded.
CaptureSet load_capture_set(const std::string& directory, const std::string& manifest_path = "",
                            const ProgressCallback& progress = nullptr, cv::Size expected_size = {});

// Writes images and manifest into `directory` (each file through a temporary + rename).
void write_capture_set(const CaptureSet& captures, const std::string& directory);

// Throws Error naming `directory` unless it is absent or an empty folder, so that a new
// capture set never overwrites or mixes with existing files.
void require_empty_directory(const std::string& directory);

// Writes one frame's image as `directory`/frame.file (encoded by the file's extension, through
// a temporary + rename): what write_capture_set does per frame, for captures taken one by one.
void write_capture_frame(const Frame& frame, const cv::Mat& image, const std::string& directory);

// Decodes one image file with cv::imread's `flags` (-1: unchanged). Throws Error naming the
// file when it cannot be decoded; what the decoder printed (libpng's errors and warnings) is
// attached to that error and never printed itself, and dropped when the image decodes.
cv::Mat read_image_file(const std::string& path, int flags = -1);

}  // namespace picoscan
