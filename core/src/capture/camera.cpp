// Cameras: frame averaging, OpenCV VideoCapture (V4L2 webcams or video files standing in for
// them), and the virtual camera over the simulator.
#include "picoscan/capture.h"

#include "picoscan/error.h"

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <cctype>
#include <filesystem>

namespace fs = std::filesystem;

namespace picoscan {

namespace {

std::string size_text(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

bool is_device_index(const std::string& source) {
    return !source.empty() && source.size() <= 3 &&
           std::all_of(source.begin(), source.end(), [](unsigned char c) { return std::isdigit(c); });
}

}  // namespace

cv::Mat grab_average(Camera& camera, int count) {
    if (count < 1 || count > 64) throw Error("frames per pattern", "must be 1..64, got " + std::to_string(count));
    cv::Mat first = camera.grab();
    if (count == 1) return first;
    cv::Mat sum;
    first.convertTo(sum, CV_MAKETYPE(CV_64F, first.channels()));
    for (int index = 1; index < count; ++index) {
        const cv::Mat frame = camera.grab();
        if (frame.size() != first.size() || frame.type() != first.type())
            throw Error(camera.name(), "frame " + std::to_string(index + 1) + " of an average changed size or type");
        cv::add(sum, frame, sum, cv::noArray(), sum.type());
    }
    cv::Mat mean;
    sum.convertTo(mean, first.type(), 1.0 / count);  // convertTo rounds to nearest
    return mean;
}

void check_camera_source_exists(const std::string& source) {
    // Image sequences name their files with a printf pattern; everything else must exist.
    if (is_device_index(source) || source.find('%') != std::string::npos || fs::exists(source)) return;
    throw Error(source, source.rfind("/dev/", 0) == 0 ? "no such camera (the device does not exist; is it plugged in?)"
                                                      : "no such camera or video file");
}

// ---- VideoCaptureCamera --------------------------------------------------------------------

struct VideoCaptureCamera::Impl {
    cv::VideoCapture capture;
};

VideoCaptureCamera::VideoCaptureCamera(const std::string& source, const CameraSettings& settings)
    : impl_(std::make_unique<Impl>()), flush_frames_(settings.flush_frames) {
    if (settings.flush_frames < 0 || settings.flush_frames > 100)
        throw Error("flush frames", "must be 0..100, got " + std::to_string(settings.flush_frames));
    const bool index = is_device_index(source);
    const bool device_path = source.rfind("/dev/", 0) == 0;
    name_ = index ? "camera " + source : source;
    check_camera_source_exists(source);
    // OpenCV logs every backend it tries and fails with; the one-line Error below says it all.
    struct QuietOpenCvLog {
        cv::utils::logging::LogLevel previous = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
        ~QuietOpenCvLog() { cv::utils::logging::setLogLevel(previous); }
    } quiet;
    try {
        if (index) impl_->capture.open(std::stoi(source), cv::CAP_V4L2);
        else if (device_path) impl_->capture.open(source, cv::CAP_V4L2);
        else impl_->capture.open(source, cv::CAP_ANY);
    } catch (const cv::Exception& failure) {
        throw Error(name_, std::string("cannot open: ") + failure.what());
    }
    if (!impl_->capture.isOpened())
        throw Error(name_, index ? "cannot open (no such V4L2 camera, or another program uses it)"
                                 : "cannot open (not a camera or a readable video)");

    auto& capture = impl_->capture;
    auto set = [&](int property, double value, const std::string& what) {
        bool accepted = false;
        try {
            accepted = capture.set(property, value);
        } catch (const cv::Exception&) {
            accepted = false;
        }
        if (!accepted) warnings_.push_back(name_ + ": the driver does not let " + what + " be set; left as it is");
        return accepted;
    };
    if (!settings.resolution.empty()) {
        set(cv::CAP_PROP_FRAME_WIDTH, settings.resolution.width, "the width");
        set(cv::CAP_PROP_FRAME_HEIGHT, settings.resolution.height, "the height");
    }
    // V4L2 exposure control: 1 = manual, 3 = aperture priority (automatic).
    if (!std::isnan(settings.exposure) && set(cv::CAP_PROP_AUTO_EXPOSURE, 1, "manual exposure"))
        set(cv::CAP_PROP_EXPOSURE, settings.exposure, "the exposure");
    if (!std::isnan(settings.gain)) set(cv::CAP_PROP_GAIN, settings.gain, "the gain");
    if (!std::isnan(settings.focus) && set(cv::CAP_PROP_AUTOFOCUS, 0, "manual focus"))
        set(cv::CAP_PROP_FOCUS, settings.focus, "the focus");
    if (!std::isnan(settings.white_balance_k) && set(cv::CAP_PROP_AUTO_WB, 0, "manual white balance"))
        set(cv::CAP_PROP_WB_TEMPERATURE, settings.white_balance_k, "the white balance");

    // The first frame proves the camera delivers and gives the true size.
    const cv::Mat first = grab();
    frame_size_ = first.size();
    if (!settings.resolution.empty() && frame_size_ != settings.resolution)
        throw Error(name_, "asked for " + size_text(settings.resolution) + " but it delivers " + size_text(frame_size_));
}

VideoCaptureCamera::~VideoCaptureCamera() = default;

void VideoCaptureCamera::flush() {
    // grab() without retrieve() is cheap: it only dequeues a buffer.
    for (int index = 0; index < flush_frames_; ++index)
        if (!impl_->capture.grab()) throw Error(name_, "delivered no frame while flushing (unplugged, or the video ended)");
}

cv::Mat VideoCaptureCamera::grab() {
    cv::Mat frame;
    try {
        if (!impl_->capture.read(frame)) frame.release();
    } catch (const cv::Exception&) {
        frame.release();
    }
    if (frame.empty()) throw Error(name_, "delivered no frame (unplugged, or the video ended)");
    if (frame.depth() != CV_8U && frame.depth() != CV_16U)
        throw Error(name_, "delivers frames of an unsupported bit depth (8 or 16 bit needed)");
    if (frame.channels() == 4) cv::cvtColor(frame, frame, cv::COLOR_BGRA2BGR);
    if (!frame_size_.empty() && frame.size() != frame_size_)
        throw Error(name_, "frame size changed from " + size_text(frame_size_) + " to " + size_text(frame.size()));
    return frame;
}

}  // namespace picoscan
