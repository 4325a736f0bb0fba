// Opening OpenCV FileStorage files (YAML, JSON, XML) from untrusted input.
#pragma once

#include <opencv2/core.hpp>

#include <string>

namespace picoscan::detail {

enum class StorageFormats { JsonOnly, Any };

// Reads `path` and opens it as a FileStorage, or throws Error(path, ...). OpenCV 4.6's
// parsers crash on some malformed input (a truncated XML tag) and throw std exceptions on
// others, so the text is screened first and every exception is turned into Error.
// `what` names the kind of file in messages ("manifest", "calibration file", ...).
// YAML without OpenCV's "%YAML:1.0" first line is accepted.
cv::FileStorage open_storage_file(const std::string& path, const std::string& what, StorageFormats formats);

// The whole of a small text file, or Error(path, ...) when it is missing, over 64 MB, or
// holds anything but printable ASCII, tabs and line breaks.
std::string read_text_file(const std::string& path, const std::string& what);

}  // namespace picoscan::detail
