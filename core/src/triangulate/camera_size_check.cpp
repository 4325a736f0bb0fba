#include "picoscan/error.h"
#include "picoscan/triangulate.h"

namespace picoscan {

void check_camera_size(const Calibration& calibration, const CaptureSet& captures, const std::string& calibration_name) {
    if (captures.images.empty()) throw Error(captures.directory, "capture set has no images");
    const cv::Size images = captures.images.front().size();
    if (images != calibration.camera_size)
        throw Error(calibration_name, "camera_size " + std::to_string(calibration.camera_size.width) + "x" +
                                          std::to_string(calibration.camera_size.height) + " differs from the captures' " +
                                          std::to_string(images.width) + "x" + std::to_string(images.height));
}

}  // namespace picoscan
