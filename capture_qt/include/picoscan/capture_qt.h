// Capture on a real display, through Qt 5: the list of screens, the projector window and a
// camera that grabs the projector's screen. The header is Qt-free; the Qt application is
// started on first use and needs a display (X11: DISPLAY).
#pragma once

#include "picoscan/capture.h"

#include <memory>
#include <string>
#include <vector>

namespace picoscan {

struct ScreenInfo {
    int index = 0;
    std::string name;
    cv::Rect geometry;  // in the window system's pixels (device pixels: scaling is off)
};

// Every screen Qt sees, in Qt's order (the index --projector-screen takes). Throws Error when
// there is no display to connect to.
std::vector<ScreenInfo> list_screens();

// A borderless full-screen window on one screen that shows each pattern pixel for pixel: no
// scaling, no smoothing, no colour management, no cursor. Throws Error when the screen does
// not exist.
class ProjectorWindow : public PatternDisplay {
public:
    explicit ProjectorWindow(int screen_index);
    ~ProjectorWindow() override;
    cv::Size size() const override;
    void show(const cv::Mat& pattern) override;
    // The pattern last painted on the screen.
    cv::Mat visible() const override;
    // Runs the Qt event loop for `milliseconds` (the window paints meanwhile).
    void wait(double milliseconds) override;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// A camera that grabs a whole screen (the projector's) from the window system: it sees
// exactly what the projector would show, for testing the sequencer with no hardware.
class ScreenCamera : public Camera {
public:
    explicit ScreenCamera(int screen_index);
    ~ScreenCamera() override;
    std::string name() const override;
    cv::Mat grab() override;  // CV_8UC3

private:
    int screen_index_;
};

}  // namespace picoscan
