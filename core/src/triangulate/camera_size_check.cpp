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
    check_projector_size(calibration, captures.sequence, calibration_name, "the manifest of " + captures.directory);
}

void check_projector_size(const Calibration& calibration, const PatternSequence& sequence,
                          const std::string& calibration_name, const std::string& manifest_name) {
    const cv::Size patterns = sequence.projector_size, calibrated = calibration.projector_size;
    if (patterns != calibrated)
        throw Error(manifest_name, "projector " + std::to_string(patterns.width) + "x" + std::to_string(patterns.height) +
                                       " differs from the projector_size " + std::to_string(calibrated.width) + "x" +
                                       std::to_string(calibrated.height) + " of " + calibration_name +
                                       ": the patterns were made for another projector");
}

}  // namespace picoscan
