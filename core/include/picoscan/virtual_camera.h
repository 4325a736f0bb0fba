// The simulator as a capture camera: hardware-free capture through the same sequencer as a
// webcam. It joins two stages (capture's Camera, the simulator), so it has its own header.
#pragma once

#include "picoscan/calibration.h"
#include "picoscan/capture.h"
#include "picoscan/simulate.h"

#include <memory>
#include <string>

namespace picoscan {

// A simulated camera: renders the scene, lit by whatever pattern `display` shows at the
// moment of the grab, with the simulator's rig (calibration) and noise. Each grab draws a
// new noise realisation, as a real camera does.
class VirtualCamera : public Camera {
public:
    VirtualCamera(const Calibration& calibration, const Scene& scene, const SimulationOptions& options,
                  const PatternDisplay& display);
    ~VirtualCamera() override;
    std::string name() const override { return "virtual camera"; }
    cv::Mat grab() override;

private:
    std::unique_ptr<Simulator> simulator_;
    const PatternDisplay& display_;
    cv::Size projector_size_;
    int grabs_ = 0;
};

}  // namespace picoscan
