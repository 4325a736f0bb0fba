// Capture from a projector and cameras: the Qt-free part.
//
// The sequencer shows each pattern on a PatternDisplay, waits for the projector's latency,
// flushes the cameras' stale frames, grabs (averaging several frames if asked) and writes the
// frame into each camera's capture set at once, so an interrupted capture keeps every frame
// already taken and can be resumed. Displays and cameras are interfaces: the projector window
// and the screen camera (Qt) live in capture_qt/, OpenCV VideoCapture cameras (V4L2 webcams,
// or video files standing in for them) and the simulator-backed virtual rig live here.
#pragma once

#include "picoscan/calibration.h"
#include "picoscan/patterns.h"
#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <chrono>
#include <cmath>
#include <deque>
#include <memory>
#include <string>
#include <vector>

namespace picoscan {

// Something that puts patterns on the projector.
class PatternDisplay {
public:
    virtual ~PatternDisplay() = default;
    // The projector's resolution; every pattern shown has this size.
    virtual cv::Size size() const = 0;
    // Puts `pattern` (CV_8U, size()) on the projector. It may become visible only later
    // (the projector's latency); the sequencer waits for that before grabbing.
    virtual void show(const cv::Mat& pattern) = 0;
    // The pattern the projector emits now (what a camera would see); black before the first.
    virtual cv::Mat visible() const = 0;
    // Waits `milliseconds`; a window system processes its events meanwhile. 0 = just poll.
    virtual void wait(double milliseconds);
};

// A display without a window, for the virtual camera: a pattern is visible as soon as shown.
class SimulatedDisplay : public PatternDisplay {
public:
    explicit SimulatedDisplay(cv::Size size);
    cv::Size size() const override { return size_; }
    void show(const cv::Mat& pattern) override;
    cv::Mat visible() const override { return visible_; }

private:
    cv::Size size_;
    cv::Mat visible_;
};

// Passes each pattern on to `display` only `latency_ms` after show(): a projector with a
// processing delay, for rehearsing the latency measurement and wait without one.
class DelayedDisplay : public PatternDisplay {
public:
    DelayedDisplay(PatternDisplay& display, double latency_ms);
    cv::Size size() const override { return display_.size(); }
    void show(const cv::Mat& pattern) override;
    cv::Mat visible() const override;
    void wait(double milliseconds) override;

private:
    using Clock = std::chrono::steady_clock;
    void pass_on_due_patterns() const;
    PatternDisplay& display_;
    double latency_ms_;
    mutable std::deque<std::pair<Clock::time_point, cv::Mat>> pending_;  // shown, not yet passed on
};

// A camera that delivers single frames.
class Camera {
public:
    virtual ~Camera() = default;
    // For messages: "camera 0", "/dev/video2", "virtual camera".
    virtual std::string name() const = 0;
    // Drops frames the driver buffered before now, so the next grab was exposed after this call.
    virtual void flush() {}
    // One frame as delivered (8 or 16 bit, 1 or 3 channels). Throws Error naming the camera.
    virtual cv::Mat grab() = 0;
};

// The mean of `count` grabs, rounded, in the frames' own type (the seed's noise reduction:
// noise falls with sqrt(count)). Throws Error when the frames change size or type.
cv::Mat grab_average(Camera& camera, int count);

// Driver settings of a VideoCapture camera. NaN leaves the driver's automatic setting.
struct CameraSettings {
    cv::Size resolution;                     // 0x0: the driver's default
    double exposure = std::nan("");          // driver units (V4L2: 100 us steps); sets manual exposure
    double gain = std::nan("");
    double focus = std::nan("");             // switches autofocus off
    double white_balance_k = std::nan("");   // colour temperature, K; switches auto white balance off
    int flush_frames = 5;                    // frames flush() drops: at least the driver's buffer count
};

// Throws Error naming `source` when it is a device path, video file or folder that does not
// exist; a device index or an image-sequence pattern ("frames/%03d.png") is left to opening.
// Opens nothing, so a command can name a missing camera before anything else is checked.
void check_camera_source_exists(const std::string& source);

// A camera through OpenCV's VideoCapture. `source` is a V4L2 device index ("0"), a device
// path ("/dev/video2"), or a video file or image sequence ("frames/%03d.png"), which stands in
// for a device in tests. Throws Error naming the source when it cannot be opened, delivers no
// frame, or does not give the requested resolution. Settings the driver refuses are listed in
// warnings() and otherwise ignored (many webcams have no manual focus, for example).
class VideoCaptureCamera : public Camera {
public:
    VideoCaptureCamera(const std::string& source, const CameraSettings& settings = {});
    ~VideoCaptureCamera() override;
    std::string name() const override { return name_; }
    void flush() override;
    cv::Mat grab() override;
    cv::Size frame_size() const { return frame_size_; }
    const std::vector<std::string>& warnings() const { return warnings_; }

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    std::string name_;
    cv::Size frame_size_;
    int flush_frames_ = 0;
    std::vector<std::string> warnings_;
};


struct CaptureOptions {
    int frames_per_pattern = 1;     // grabs averaged per pattern (1..64)
    double wait_ms = 0.0;           // between show and grab: the projector latency plus a margin
    bool resume = false;            // complete a partial capture already in the folders
    cv::Mat projector_inverse_response;  // 256-entry CV_8U gamma correction applied to patterns, or empty
};

struct CaptureReport {
    int captured = 0;         // frames grabbed now (per camera)
    int already_present = 0;  // frames a resumed capture found on disk
};

// Shows every frame of `sequence` on `display` and stores the grab of camera k in
// directories[k] as that directory's capture set (images named by the sequence, sequence.json
// written before the first frame). Frames are written as they arrive (temporary + rename).
// Refuses, before showing anything, a directory that holds anything but a capture of this very
// sequence; with options.resume a capture of this sequence is completed, otherwise refused.
// Nothing on disk is ever deleted. Reports progress per frame ("capture"); a callback
// returning false stops after the current frame with Error("cancelled", ...).
CaptureReport capture_sequence(const PatternSequence& sequence, PatternDisplay& display,
                               const std::vector<Camera*>& cameras, const std::vector<std::string>& directories,
                               const CaptureOptions& options, const ProgressCallback& progress = nullptr);

// The frames of `sequence` whose image is whole in `directory` (a partial capture: a frame cut
// short, without its PNG/JPEG end marker, counts as missing); throws Error when the directory
// holds something other than a capture of this sequence.
std::vector<bool> frames_present(const PatternSequence& sequence, const std::string& directory);

// Throws Error when a folder cannot take a capture of `sequence`: it holds something else, a
// capture of another sequence, a capture of this one without `resume`, or cannot be written.
// Two cameras may not share a folder. Checks only; creates nothing.
void check_capture_folders(const PatternSequence& sequence, const std::vector<std::string>& directories, bool resume);

struct LatencyOptions {
    int trials = 3;                // flashes; the latency is the slowest
    double settle_ms = 400.0;      // time the projector gets to settle on black or white
    double timeout_ms = 3000.0;    // a flash not seen within this is an error
    double min_contrast_dn = 10.0; // white - black mean level the camera must see
};

struct LatencyMeasurement {
    std::vector<double> trials_ms;  // time from show(white) to the first grab that sees it
    double latency_ms = 0.0;        // the slowest trial
    double black_level_dn = 0.0, white_level_dn = 0.0;  // mean camera levels (8-bit scale)
    // The wait to use between show and grab: the latency plus 20 % and 10 ms.
    double recommended_wait_ms() const { return latency_ms * 1.2 + 10.0; }
};

// Flash and detect: shows black, then white, and times how long the camera takes to see the
// white (its mean level past the middle between the black and white levels). Throws Error
// when the camera sees no difference between black and white or never sees the flash.
LatencyMeasurement measure_latency(PatternDisplay& display, Camera& camera, const LatencyOptions& options = {});

}  // namespace picoscan
