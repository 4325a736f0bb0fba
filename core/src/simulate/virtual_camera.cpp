#include "picoscan/virtual_camera.h"

#include "picoscan/error.h"

#include <string>

namespace picoscan {

namespace {

std::string size_text(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

}  // namespace

VirtualCamera::VirtualCamera(const Calibration& calibration, const Scene& scene, const SimulationOptions& options,
                             const PatternDisplay& display)
    : simulator_(std::make_unique<Simulator>(calibration, scene, options)),
      display_(display),
      projector_size_(calibration.projector_size) {
    if (display.size() != projector_size_)
        throw Error("virtual camera", "its rig's projector is " + size_text(projector_size_) + " but the display is " +
                                          size_text(display.size()));
}

VirtualCamera::~VirtualCamera() = default;

cv::Mat VirtualCamera::grab() {
    cv::Mat pattern = display_.visible();
    if (pattern.empty()) pattern = cv::Mat::zeros(projector_size_, CV_8U);
    if (pattern.size() != projector_size_ || pattern.type() != CV_8U)
        throw Error(name(), "the display shows an image of another size or type than the rig's projector");
    return simulator_->render(pattern, grabs_++);
}

}  // namespace picoscan
