// A strict reader for the small subset of OpenCV FileStorage YAML, XML and JSON that calibration
// files use: one level of `key: value` entries whose values are numbers, words, lists of
// numbers, or !!opencv-matrix maps (rows, cols, dt, data).
//
// OpenCV 4.6's own parsers loop forever or crash on some malformed files, so files from
// users and other systems are read with this instead; PicoScan still writes through OpenCV.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace picoscan::detail {

struct StorageValue {
    enum class Kind { Number, Word, List, Matrix };
    Kind kind = Kind::Word;
    std::vector<double> numbers;  // Number: one; List: all; Matrix: rows * cols, row-major
    int rows = 0, cols = 0;       // Matrix only
    std::string word;             // Word only
    int line = 0;                 // where it starts in the file, for messages
};

using StorageEntries = std::map<std::string, StorageValue>;

// Parses YAML (with or without the "%YAML:1.0" line), XML (<opencv_storage>) or JSON (a
// top-level object; matrices as {"type_id": "opencv-matrix", ...}), chosen by the first
// character. Throws Error(path, "line N: what is wrong").
StorageEntries parse_storage_text(const std::string& text, const std::string& path);

// The cv::FileStorage format flag that writes a calibration file named `path`: XML for
// .xml, JSON for .json, YAML otherwise (.yml, .yaml).
int storage_format_for(const std::string& path);

}  // namespace picoscan::detail
