// Calibration files: PicoScan's own YAML, and the formats of SLMaster and SLStudio.
#include "picoscan/calibration.h"

#include "picoscan/error.h"
#include "picoscan/io.h"

#include <opencv2/core.hpp>

#include <cmath>
#include <filesystem>
#include <vector>

namespace picoscan {

namespace {

// Reads typed values from a FileStorage, with errors naming the file and the key.
class CalibrationReader {
public:
    CalibrationReader(const std::string& path, const cv::FileStorage& storage) : path_(path), storage_(storage) {}

    bool has(const std::string& key) const {
        const cv::FileNode node = storage_[key];
        return !node.empty() && !node.isNone();
    }
    [[noreturn]] void fail(const std::string& problem) const { throw Error(path_, problem); }

    cv::Mat matrix(const std::string& key, int rows, int cols) const {
        if (!has(key)) fail("missing key '" + key + "'");
        cv::Mat value;
        try {
            storage_[key] >> value;
        } catch (const cv::Exception&) {
            fail("'" + key + "' is not a matrix");
        }
        if (value.empty() || value.channels() != 1) fail("'" + key + "' is not a matrix");
        value.convertTo(value, CV_64F);
        if (rows > 0 && cols > 0 && value.total() == size_t(rows * cols)) value = value.reshape(1, rows);
        if ((rows > 0 && value.rows != rows) || (cols > 0 && value.cols != cols))
            fail("'" + key + "' must be " + std::to_string(rows) + "x" + std::to_string(cols) + ", got " +
                 std::to_string(value.rows) + "x" + std::to_string(value.cols));
        if (!cv::checkRange(value)) fail("'" + key + "' holds a non-finite value");
        return value;
    }
    cv::Mat distortion(const std::string& key) const {
        cv::Mat value = matrix(key, 0, 0);
        value = value.reshape(1, 1);
        const int count = value.cols;
        if (count != 4 && count != 5 && count != 8 && count != 12 && count != 14)
            fail("'" + key + "' must hold 4, 5, 8, 12 or 14 coefficients, got " + std::to_string(count));
        return value.clone();
    }
    int integer(const std::string& key) const {
        if (!has(key)) fail("missing key '" + key + "'");
        const cv::FileNode node = storage_[key];
        if (!node.isInt() && !node.isReal()) fail("'" + key + "' must be a number");
        return static_cast<int>(static_cast<double>(node));
    }
    // [width, height] as a plain list (PicoScan) or as a 2-element matrix (SLMaster).
    cv::Size size(const std::string& key) const {
        if (!has(key)) fail("missing key '" + key + "'");
        const cv::FileNode node = storage_[key];
        std::vector<double> values;
        if (node.isSeq()) {
            for (const cv::FileNode& item : node) {
                if (!item.isInt() && !item.isReal()) fail("'" + key + "' must be [width, height]");
                values.push_back(static_cast<double>(item));
            }
        } else if (node.isMap()) {
            const cv::Mat value = matrix(key, 0, 0);
            values.assign(value.begin<double>(), value.end<double>());
        } else {
            fail("'" + key + "' must be [width, height]");
        }
        if (values.size() != 2 || values[0] != std::floor(values[0]) || values[1] != std::floor(values[1]))
            fail("'" + key + "' must be [width, height] in whole pixels");
        return {static_cast<int>(values[0]), static_cast<int>(values[1])};
    }

private:
    std::string path_;
    const cv::FileStorage& storage_;
};

}  // namespace

void validate_calibration(const Calibration& calibration, const std::string& source) {
    auto fail = [&](const std::string& problem) { throw Error(source, problem); };
    auto check_size = [&](cv::Size size, const char* key) {
        if (size.width < 2 || size.height < 2 || size.width > 65536 || size.height > 65536)
            fail(std::string("'") + key + "' must be a positive image size");
    };
    check_size(calibration.camera_size, "camera_size");
    check_size(calibration.projector_size, "projector_size");
    auto check_intrinsics = [&](const cv::Matx33d& matrix, const char* key) {
        if (!(matrix(0, 0) > 0) || !(matrix(1, 1) > 0) || matrix(2, 0) != 0 || matrix(2, 1) != 0 || matrix(2, 2) != 1 ||
            !cv::checkRange(cv::Mat(matrix)))
            fail(std::string("'") + key + "' must be an intrinsic matrix [fx s cx; 0 fy cy; 0 0 1] with fx, fy > 0");
    };
    check_intrinsics(calibration.camera_matrix, "camera_matrix");
    check_intrinsics(calibration.projector_matrix, "projector_matrix");
    const cv::Matx33d should_be_identity = calibration.R.t() * calibration.R;
    if (cv::norm(should_be_identity - cv::Matx33d::eye()) > 1e-4 || cv::determinant(calibration.R) < 0)
        fail("'R' must be a rotation matrix");
    if (!cv::checkRange(cv::Mat(calibration.T)) || cv::norm(calibration.T) < 1e-9)
        fail("'T' must be a finite, non-zero translation (the camera-projector baseline)");
    if (!cv::checkRange(calibration.camera_distortion) || !cv::checkRange(calibration.projector_distortion))
        fail("distortion coefficients must be finite");
}

Calibration read_calibration(const std::string& path) {
    if (!std::filesystem::is_regular_file(path)) throw Error(path, "calibration file not found");
    cv::FileStorage storage;
    try {
        if (!storage.open(path, cv::FileStorage::READ)) throw Error(path, "cannot open calibration file");
    } catch (const cv::Exception& error) {
        throw Error(path, "not a readable OpenCV YAML/XML/JSON calibration file (" + error.err + ")");
    }
    if (!storage.root().isMap()) throw Error(path, "calibration file must hold a map of keys");
    const CalibrationReader reader(path, storage);
    Calibration calibration;
    try {
        if (reader.has("M1") && reader.has("Rlp")) {  // SLMaster caliInfo.yml
            calibration.camera_matrix = cv::Matx33d(reader.matrix("M1", 3, 3));
            calibration.camera_distortion = reader.distortion("D1");
            calibration.camera_size = reader.size("S");
            calibration.projector_matrix = cv::Matx33d(reader.matrix("M4", 3, 3));
            calibration.projector_distortion = reader.distortion("D4");
            // SLMaster stores no projector size; its DLP4710 is 1920x1080.
            calibration.projector_size = {1920, 1080};
            calibration.R = cv::Matx33d(reader.matrix("Rlp", 3, 3));
            calibration.T = cv::Vec3d(reader.matrix("Tlp", 3, 1));
        } else if (reader.has("Kc") && reader.has("Rp")) {  // SLStudio calibration.xml
            calibration.camera_matrix = cv::Matx33d(reader.matrix("Kc", 3, 3));
            calibration.camera_distortion = reader.distortion("kc");
            calibration.camera_size = {reader.integer("frameWidth"), reader.integer("frameHeight")};
            calibration.projector_matrix = cv::Matx33d(reader.matrix("Kp", 3, 3));
            calibration.projector_distortion = reader.distortion("kp");
            calibration.projector_size = {reader.integer("screenResX"), reader.integer("screenResY")};
            calibration.R = cv::Matx33d(reader.matrix("Rp", 3, 3));
            calibration.T = cv::Vec3d(reader.matrix("Tp", 3, 1));
        } else {
            calibration.camera_size = reader.size("camera_size");
            calibration.camera_matrix = cv::Matx33d(reader.matrix("camera_matrix", 3, 3));
            calibration.camera_distortion = reader.distortion("camera_distortion");
            calibration.projector_size = reader.size("projector_size");
            calibration.projector_matrix = cv::Matx33d(reader.matrix("projector_matrix", 3, 3));
            calibration.projector_distortion = reader.distortion("projector_distortion");
            calibration.R = cv::Matx33d(reader.matrix("R", 3, 3));
            calibration.T = cv::Vec3d(reader.matrix("T", 3, 1));
        }
    } catch (const cv::Exception& error) {
        throw Error(path, "malformed calibration file (" + error.err + ")");
    }
    validate_calibration(calibration, path);
    return calibration;
}

void write_calibration(const Calibration& calibration, const std::string& path) {
    validate_calibration(calibration, "calibration");
    cv::FileStorage storage("calibration.yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    storage.writeComment("PicoScan calibration, millimetres. X_projector = R * X_camera + T.");
    storage << "camera_size" << std::vector<int>{calibration.camera_size.width, calibration.camera_size.height};
    storage << "camera_matrix" << cv::Mat(calibration.camera_matrix);
    storage << "camera_distortion" << calibration.camera_distortion;
    storage << "projector_size" << std::vector<int>{calibration.projector_size.width, calibration.projector_size.height};
    storage << "projector_matrix" << cv::Mat(calibration.projector_matrix);
    storage << "projector_distortion" << calibration.projector_distortion;
    storage << "R" << cv::Mat(calibration.R);
    storage << "T" << cv::Mat(calibration.T);
    write_file_atomically(path, storage.releaseAndGetString());
}

}  // namespace picoscan
