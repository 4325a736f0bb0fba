// Typed access to the entries of a calibration file (camera-projector or stereo), with
// errors naming the file and the key.
#pragma once

#include "picoscan/error.h"

#include "common/storage_text.h"

#include <opencv2/core.hpp>

#include <cmath>
#include <string>

namespace picoscan::detail {

class CalibrationReader {
public:
    CalibrationReader(const std::string& path, StorageEntries entries)
        : path_(path), entries_(std::move(entries)) {}

    bool has(const std::string& key) const { return entries_.count(key) > 0; }
    [[noreturn]] void fail(const std::string& problem) const { throw Error(path_, problem); }

    const StorageValue& value(const std::string& key) const {
        const auto found = entries_.find(key);
        if (found == entries_.end()) fail("missing key '" + key + "'");
        return found->second;
    }
    // A !!opencv-matrix, or a plain list taken as one row.
    cv::Mat matrix(const std::string& key, int rows, int cols) const {
        const StorageValue& entry = value(key);
        if (entry.kind != StorageValue::Kind::Matrix && entry.kind != StorageValue::Kind::List)
            fail("'" + key + "' is not a matrix");
        if (entry.numbers.empty()) fail("'" + key + "' is empty");
        const int entry_rows = entry.kind == StorageValue::Kind::Matrix ? entry.rows : 1;
        cv::Mat matrix = cv::Mat(entry.numbers, true).reshape(1, entry_rows);
        if (rows > 0 && cols > 0 && matrix.total() == size_t(rows * cols)) matrix = matrix.reshape(1, rows);
        if ((rows > 0 && matrix.rows != rows) || (cols > 0 && matrix.cols != cols))
            fail("'" + key + "' must be " + std::to_string(rows) + "x" + std::to_string(cols) + ", got " +
                 std::to_string(matrix.rows) + "x" + std::to_string(matrix.cols));
        return matrix;
    }
    cv::Mat distortion(const std::string& key) const {
        const cv::Mat coefficients = matrix(key, 0, 0).reshape(1, 1);
        const int count = coefficients.cols;
        if (count != 4 && count != 5 && count != 8 && count != 12 && count != 14)
            fail("'" + key + "' must hold 4, 5, 8, 12 or 14 coefficients, got " + std::to_string(count));
        if (count == 14 && (coefficients.at<double>(12) != 0 || coefficients.at<double>(13) != 0))
            fail("'" + key + "': the tilted-sensor terms tau_x, tau_y (coefficients 13 and 14) must be 0");
        return coefficients.clone();
    }
    int whole_pixels(double number, const std::string& key) const {
        if (!(std::abs(number) <= 1e6) || number != std::floor(number)) fail("'" + key + "' must be a whole number of pixels");
        return static_cast<int>(number);
    }
    int integer(const std::string& key) const {
        const StorageValue& entry = value(key);
        if (entry.kind != StorageValue::Kind::Number) fail("'" + key + "' must be a number");
        return whole_pixels(entry.numbers.front(), key);
    }
    // [width, height] as a plain list (PicoScan) or as a 2-element matrix (SLMaster).
    cv::Size size(const std::string& key) const {
        const StorageValue& entry = value(key);
        if ((entry.kind != StorageValue::Kind::List && entry.kind != StorageValue::Kind::Matrix) ||
            entry.numbers.size() != 2)
            fail("'" + key + "' must be [width, height]");
        return {whole_pixels(entry.numbers[0], key), whole_pixels(entry.numbers[1], key)};
    }

private:
    std::string path_;
    StorageEntries entries_;
};


}  // namespace picoscan::detail
