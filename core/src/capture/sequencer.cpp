// The capture sequencer: project -> wait for the latency -> flush -> grab -> write, frame by
// frame, with resume; the simulated display; flash-and-detect latency measurement.
#include "picoscan/capture.h"

#include "picoscan/capture_set.h"
#include "picoscan/error.h"

#include "capture_set/image_header.h"
#include "io/image_codecs.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <thread>

#include <unistd.h>

namespace fs = std::filesystem;

namespace picoscan {

namespace {

using Clock = std::chrono::steady_clock;

double milliseconds_since(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::string size_text(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

bool same_axis(const AxisCode& a, const AxisCode& b) {
    auto same = [](double x, double y) { return std::abs(x - y) <= 1e-9 * std::max(1.0, std::abs(x)); };
    return a.gray_bits == b.gray_bits && same(a.gray_unit_px, b.gray_unit_px) && a.shifts == b.shifts &&
           same(a.period_px, b.period_px) && same(a.phase_offset_rad, b.phase_offset_rad) &&
           a.shift_sign == b.shift_sign && a.cue_shifts == b.cue_shifts && same(a.cue_period_px, b.cue_period_px);
}

bool same_sequence(const PatternSequence& a, const PatternSequence& b) {
    if (a.projector_size != b.projector_size || a.origin != b.origin || !same_axis(a.columns, b.columns) ||
        !same_axis(a.rows, b.rows) || a.frames.size() != b.frames.size())
        return false;
    for (size_t index = 0; index < a.frames.size(); ++index) {
        const Frame& x = a.frames[index];
        const Frame& y = b.frames[index];
        if (x.file != y.file || x.kind != y.kind || x.axis != y.axis || x.bit != y.bit || x.shift != y.shift) return false;
    }
    return true;
}

bool is_temporary_of(const std::string& name, const std::set<std::string>& targets) {
    const size_t marker = name.find(".tmp-");
    return marker != std::string::npos && targets.count(name.substr(0, marker)) > 0;
}

// Mean grey level on the 8-bit scale.
double mean_level(const cv::Mat& frame) {
    const cv::Scalar mean = cv::mean(frame);
    double level = 0.0;
    for (int channel = 0; channel < frame.channels(); ++channel) level += mean[channel];
    level /= frame.channels();
    return frame.depth() == CV_16U ? level / 257.0 : level;
}

// The image stored for a frame: the white frame keeps its colour (it colours the cloud), the
// others are stored grey, which is what decoding reads.
cv::Mat stored_image(const Frame& frame, const cv::Mat& grabbed) {
    if (grabbed.channels() == 1 || frame.kind == FrameKind::White) return grabbed;
    cv::Mat grey;
    cv::cvtColor(grabbed, grey, cv::COLOR_BGR2GRAY);
    return grey;
}

}  // namespace

// ---- displays ------------------------------------------------------------------------------

void PatternDisplay::wait(double milliseconds) {
    if (milliseconds > 0) std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(milliseconds));
}

SimulatedDisplay::SimulatedDisplay(cv::Size size) : size_(size), visible_(cv::Mat::zeros(size, CV_8U)) {
    if (size.width < 2 || size.height < 2) throw Error("simulated display", "size must be at least 2x2");
}

void SimulatedDisplay::show(const cv::Mat& pattern) {
    if (pattern.size() != size_ || pattern.type() != CV_8U)
        throw Error("simulated display", "pattern must be 8-bit grey " + size_text(size_));
    visible_ = pattern.clone();
}

DelayedDisplay::DelayedDisplay(PatternDisplay& display, double latency_ms) : display_(display), latency_ms_(latency_ms) {
    if (!(latency_ms >= 0 && latency_ms <= 10000)) throw Error("delayed display", "latency must be 0..10000 ms");
}

void DelayedDisplay::show(const cv::Mat& pattern) {
    pending_.emplace_back(Clock::now(), pattern.clone());
    pass_on_due_patterns();
}

void DelayedDisplay::pass_on_due_patterns() const {
    const auto latency = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(latency_ms_));
    while (!pending_.empty() && pending_.front().first + latency <= Clock::now()) {
        display_.show(pending_.front().second);
        pending_.pop_front();
    }
}

cv::Mat DelayedDisplay::visible() const {
    pass_on_due_patterns();
    return display_.visible();
}

void DelayedDisplay::wait(double milliseconds) {
    const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                        std::chrono::duration<double, std::milli>(std::max(0.0, milliseconds)));
    do {
        pass_on_due_patterns();
        const double left_ms = std::chrono::duration<double, std::milli>(end - Clock::now()).count();
        display_.wait(std::min(std::max(left_ms, 0.0), 1.0));  // short steps: a due pattern is passed on in time
    } while (Clock::now() < end);
}

// ---- capture sets on disk ------------------------------------------------------------------

std::vector<bool> frames_present(const PatternSequence& sequence, const std::string& directory) {
    std::vector<bool> present(sequence.frames.size(), false);
    if (!fs::exists(directory)) return present;
    if (!fs::is_directory(directory)) throw Error(directory, "is a file, not a folder for a capture set");
    const fs::path manifest = fs::path(directory) / "sequence.json";
    std::set<std::string> listed{"sequence.json"};
    for (const Frame& frame : sequence.frames) listed.insert(frame.file);
    if (!fs::exists(manifest)) {
        if (!fs::is_empty(directory))
            throw Error(directory, "holds files but no capture (no sequence.json); choose an empty or new folder");
        return present;
    }
    PatternSequence existing;
    try {
        existing = read_manifest(manifest.string());
    } catch (const Error& error) {
        throw Error(directory, std::string("holds an unreadable capture: ") + error.what());
    }
    if (!same_sequence(existing, sequence))
        throw Error(directory, "already holds a different capture (its sequence.json differs: " +
                                   std::to_string(existing.frames.size()) + " frames for a " +
                                   size_text(existing.projector_size) + " projector); choose another folder");
    for (const auto& entry : fs::directory_iterator(directory)) {
        const std::string name = entry.path().filename().string();
        // Temporary files of a capture killed while writing are harmless leftovers.
        if (!listed.count(name) && !is_temporary_of(name, listed))
            throw Error(entry.path().string(), "is not part of the capture in " + directory + "; move it away first");
    }
    for (size_t index = 0; index < sequence.frames.size(); ++index)
        present[index] = detail::image_file_complete((fs::path(directory) / sequence.frames[index].file).string());
    return present;
}

void check_capture_folders(const PatternSequence& sequence, const std::vector<std::string>& directories, bool resume) {
    for (size_t index = 0; index < directories.size(); ++index)
        for (size_t other = 0; other < index; ++other)
            if (fs::absolute(directories[index]).lexically_normal() == fs::absolute(directories[other]).lexically_normal())
                throw Error(directories[index], "given for two cameras; each camera needs its own folder");
    for (const std::string& directory : directories) {
        if (directory.empty()) throw Error("output folder", "is empty");
        const std::vector<bool> present = frames_present(sequence, directory);
        const bool started = fs::exists(fs::path(directory) / "sequence.json");
        const auto taken = std::count(present.begin(), present.end(), true);
        if (started && !resume)
            throw Error(directory, "already holds a capture of this sequence (" + std::to_string(taken) + " of " +
                                       std::to_string(sequence.frames.size()) + " frames); resume it to complete it");
        // The nearest existing folder on the way must be writable (the capture creates the rest).
        fs::path existing = fs::absolute(directory).lexically_normal();
        while (!fs::exists(existing) && existing.has_parent_path() && existing != existing.parent_path())
            existing = existing.parent_path();
        if (!fs::is_directory(existing))
            throw Error(directory, "cannot be created: " + existing.string() + " is not a folder");
        if (::access(existing.c_str(), W_OK) != 0)
            throw Error(directory, "is not writable (" + existing.string() + " does not allow writing)");
    }
}

// ---- the sequencer -------------------------------------------------------------------------

CaptureReport capture_sequence(const PatternSequence& sequence, PatternDisplay& display,
                               const std::vector<Camera*>& cameras, const std::vector<std::string>& directories,
                               const CaptureOptions& options, const ProgressCallback& progress) {
    if (cameras.empty()) throw Error("cameras", "no camera to capture with");
    if (cameras.size() != directories.size()) throw Error("capture", "one output folder per camera is needed");
    if (sequence.frames.empty()) throw Error("pattern sequence", "has no frames to capture");
    if (display.size() != sequence.projector_size)
        throw Error("projector", "the display is " + size_text(display.size()) + " but the patterns are for a " +
                                     size_text(sequence.projector_size) + " projector");
    if (options.frames_per_pattern < 1 || options.frames_per_pattern > 64)
        throw Error("frames per pattern", "must be 1..64");
    if (!(options.wait_ms >= 0 && options.wait_ms <= 60000)) throw Error("wait", "must be 0..60000 ms");

    // Check every folder before anything is shown, so a refusal leaves no trace.
    check_capture_folders(sequence, directories, options.resume);
    const size_t frame_count = sequence.frames.size();
    std::vector<std::vector<bool>> present;
    for (const std::string& directory : directories) present.push_back(frames_present(sequence, directory));
    // The manifest goes first: a capture interrupted at any point is then recognisable.
    for (const std::string& directory : directories) {
        std::error_code ignored;
        fs::create_directories(directory, ignored);
        if (!fs::is_directory(directory)) throw Error(directory, "cannot create the capture folder");
        const std::string manifest = (fs::path(directory) / "sequence.json").string();
        if (!fs::exists(manifest)) write_manifest(sequence, manifest);
    }

    CaptureReport report;
    std::vector<cv::Size> frame_sizes(cameras.size());
    for (size_t camera = 0; camera < cameras.size(); ++camera)
        for (size_t index = 0; index < frame_count && frame_sizes[camera].empty(); ++index)
            if (present[camera][index])
                frame_sizes[camera] = detail::imread((fs::path(directories[camera]) / sequence.frames[index].file).string(),
                                                 cv::IMREAD_UNCHANGED)
                                          .size();
    for (size_t index = 0; index < frame_count; ++index) {
        bool needed = false;
        for (size_t camera = 0; camera < cameras.size(); ++camera) needed = needed || !present[camera][index];
        if (!needed) {
            ++report.already_present;
            continue;
        }
        const Frame& frame = sequence.frames[index];
        display.show(render_pattern(sequence, frame, options.projector_inverse_response));
        display.wait(options.wait_ms);
        // Frames buffered during the wait may predate the pattern: drop them.
        for (Camera* camera : cameras) camera->flush();
        for (size_t camera = 0; camera < cameras.size(); ++camera) {
            const cv::Mat image = stored_image(frame, grab_average(*cameras[camera], options.frames_per_pattern));
            if (frame_sizes[camera].empty()) frame_sizes[camera] = image.size();
            if (image.size() != frame_sizes[camera])
                throw Error(cameras[camera]->name(), "gives " + size_text(image.size()) + " frames but the capture in " +
                                                         directories[camera] + " has " + size_text(frame_sizes[camera]));
            if (!present[camera][index]) write_capture_frame(frame, image, directories[camera]);
        }
        ++report.captured;
        if (progress && !progress(double(index + 1) / frame_count, "capture"))
            throw Error("cancelled", "capture stopped after frame " + std::to_string(index + 1) + " of " +
                                         std::to_string(frame_count) + "; resume to complete it");
    }
    return report;
}

// ---- latency -------------------------------------------------------------------------------

LatencyMeasurement measure_latency(PatternDisplay& display, Camera& camera, const LatencyOptions& options) {
    if (options.trials < 1 || options.trials > 20) throw Error("latency trials", "must be 1..20");
    const cv::Mat black = cv::Mat::zeros(display.size(), CV_8U);
    const cv::Mat white(display.size(), CV_8U, cv::Scalar(255));
    auto settled_level = [&](const cv::Mat& pattern) {
        display.show(pattern);
        display.wait(options.settle_ms);
        camera.flush();
        return mean_level(camera.grab());
    };
    LatencyMeasurement result;
    result.black_level_dn = settled_level(black);
    result.white_level_dn = settled_level(white);
    const double contrast = result.white_level_dn - result.black_level_dn;
    if (contrast < options.min_contrast_dn)
        throw Error(camera.name(), "sees no change between a black and a white projector (mean level " +
                                       cv::format("%.1f -> %.1f", result.black_level_dn, result.white_level_dn) +
                                       "); point it at the projected area and check the exposure");
    const double threshold = result.black_level_dn + 0.5 * contrast;
    for (int trial = 0; trial < options.trials; ++trial) {
        display.show(black);
        display.wait(options.settle_ms);
        camera.flush();
        const auto start = Clock::now();
        display.show(white);
        double seen_ms = -1.0;
        while (milliseconds_since(start) < options.timeout_ms) {
            display.wait(0);  // lets a window paint
            if (mean_level(camera.grab()) > threshold) {
                seen_ms = milliseconds_since(start);
                break;
            }
        }
        if (seen_ms < 0)
            throw Error(camera.name(), cv::format("did not see the white flash within %.0f ms", options.timeout_ms));
        result.trials_ms.push_back(seen_ms);
    }
    display.show(black);
    result.latency_ms = *std::max_element(result.trials_ms.begin(), result.trials_ms.end());
    return result;
}

}  // namespace picoscan
