// Calibration files: PicoScan's own YAML, and the formats of SLMaster and SLStudio.
#include "picoscan/calibration.h"

#include "picoscan/error.h"
#include "picoscan/file_output.h"

#include "common/calibration_reader.h"
#include "common/storage_file.h"

#include <opencv2/core.hpp>

#include <cmath>
#include <filesystem>
#include <vector>

namespace picoscan {

void validate_calibration(const Calibration& calibration, const std::string& source) {
    auto fail = [&](const std::string& problem) { throw Error(source, problem); };
    auto check_size = [&](cv::Size size, const char* key) {
        if (size.width < 2 || size.height < 2 || size.width > kLargestImageSide || size.height > kLargestImageSide ||
            int64_t(size.width) * size.height > kLargestImagePixels)
            fail(std::string("'") + key + "' must be an image size of 2.." + std::to_string(kLargestImageSide) +
                 " pixels a side and at most " + std::to_string(kLargestImagePixels >> 20) + " Mpixel, got " +
                 std::to_string(size.width) + "x" + std::to_string(size.height));
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
    auto check_distortion = [&](const cv::Mat& coefficients, const char* key) {
        cv::Mat values;
        coefficients.convertTo(values, CV_64F);
        values = values.reshape(1, 1);
        if (!cv::checkRange(values)) fail(std::string("'") + key + "' must hold finite coefficients");
        if (values.cols > 14) fail(std::string("'") + key + "' holds more than 14 coefficients");
        if (values.cols > 12 && (values.at<double>(12) != 0 || values.at<double>(13) != 0))
            fail(std::string("'") + key + "': the tilted-sensor terms tau_x, tau_y (coefficients 13 and 14) must be 0");
    };
    check_distortion(calibration.camera_distortion, "camera_distortion");
    check_distortion(calibration.projector_distortion, "projector_distortion");
}

Calibration read_calibration(const std::string& path) {
    const detail::CalibrationReader reader(path, detail::parse_storage_text(detail::read_text_file(path, "calibration file"), path));
    Calibration calibration;
    {
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
    }
    if (reader.has("projector_inverse_response")) {
        const cv::Mat table = reader.matrix("projector_inverse_response", 0, 0).reshape(1, 1);
        if (table.cols != 256) reader.fail("'projector_inverse_response' must hold 256 levels");
        double low, high;
        cv::minMaxLoc(table, &low, &high);
        if (low < 0 || high > 255) reader.fail("'projector_inverse_response' levels must be 0..255");
        table.convertTo(calibration.projector_inverse_response, CV_8U);
    }
    validate_calibration(calibration, path);
    return calibration;
}

void write_calibration(const Calibration& calibration, const std::string& path) {
    validate_calibration(calibration, "calibration");
    const int format = detail::storage_format_for(path);
    cv::FileStorage storage("calibration", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | format);
    if (format != cv::FileStorage::FORMAT_JSON)  // JSON has no comments
        storage.writeComment("PicoScan calibration, millimetres. X_projector = R * X_camera + T.");
    storage << "camera_size" << std::vector<int>{calibration.camera_size.width, calibration.camera_size.height};
    storage << "camera_matrix" << cv::Mat(calibration.camera_matrix);
    storage << "camera_distortion" << calibration.camera_distortion;
    storage << "projector_size" << std::vector<int>{calibration.projector_size.width, calibration.projector_size.height};
    storage << "projector_matrix" << cv::Mat(calibration.projector_matrix);
    storage << "projector_distortion" << calibration.projector_distortion;
    storage << "R" << cv::Mat(calibration.R);
    storage << "T" << cv::Mat(calibration.T);
    if (!calibration.projector_inverse_response.empty())
        storage << "projector_inverse_response" << calibration.projector_inverse_response;
    write_file_atomically(path, storage.releaseAndGetString());
}

}  // namespace picoscan
