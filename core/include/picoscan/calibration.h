// The calibration of one camera and one projector (OpenCV FileStorage YAML, millimetres):
// plain data, read and written here; measuring it is in calibrate.h.
// Convention: X_projector = R * X_camera + T; pixel centres at integer coordinates.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

struct Calibration {
    cv::Size camera_size;
    cv::Matx33d camera_matrix = cv::Matx33d::eye();
    cv::Mat camera_distortion = cv::Mat::zeros(1, 5, CV_64F);  // OpenCV order k1 k2 p1 p2 [k3 ...]
    cv::Size projector_size;
    cv::Matx33d projector_matrix = cv::Matx33d::eye();
    cv::Mat projector_distortion = cv::Mat::zeros(1, 5, CV_64F);
    cv::Matx33d R = cv::Matx33d::eye();  // camera -> projector rotation
    cv::Vec3d T{0, 0, 0};                // camera -> projector translation, mm
    // Optional: 256-entry CV_8U table that linearises the projector's response (gamma); apply
    // it to every pattern level before projecting (render_pattern's response_lut). Empty if
    // the response was not measured.
    cv::Mat projector_inverse_response;
};

// Reads a calibration file. Besides PicoScan's own keys it understands
// SLMaster's caliInfo.yml (M1 D1 S M4 D4 Rlp Tlp) and SLStudio's calibration.xml
// (Kc kc Kp kp Rp Tp frameWidth frameHeight screenResX screenResY).
// Throws Error naming the file and the missing or malformed key.
Calibration read_calibration(const std::string& path);

// Writes PicoScan's own format through a temporary file and a rename.
void write_calibration(const Calibration& calibration, const std::string& path);

// Checks sizes, matrix shapes and finiteness; throws Error naming `source` and the bad key.
void validate_calibration(const Calibration& calibration, const std::string& source);

}  // namespace picoscan
