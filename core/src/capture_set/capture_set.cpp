// Loading and writing capture sets.
#include "picoscan/capture_set.h"

#include "picoscan/calibration.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"

#include "capture_set/image_header.h"
#include "common/memory_budget.h"
#include "common/parallel.h"
#include "common/progress_reporter.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <mutex>
#include <set>

namespace fs = std::filesystem;

namespace picoscan {

namespace {

bool is_image_file(const fs::path& path) {
    std::string extension = path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), ::tolower);
    static const std::set<std::string> extensions{".png", ".bmp", ".jpg", ".jpeg", ".tif", ".tiff"};
    return extensions.count(extension) > 0;
}

std::string describe(const Frame& frame, size_t index) {
    std::string text = "frame " + std::to_string(index) + " (" + to_string(frame.kind);
    if (frame.kind == FrameKind::Gray || frame.kind == FrameKind::GrayInverse)
        text += " " + to_string(frame.axis) + " bit " + std::to_string(frame.bit);
    if (frame.kind == FrameKind::Phase || frame.kind == FrameKind::Cue) text += " " + to_string(frame.axis) + " shift " + std::to_string(frame.shift);
    return text + ")";
}

std::string size_text(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

// Every image's size from its header, compared with the first image's, the expected size
// and the limits, and the whole set with the memory budget, before any image is decoded.
void check_image_headers(const std::string& directory, const std::vector<Frame>& frames, cv::Size expected_size) {
    double bytes = 0;
    cv::Size first_size;
    for (size_t index = 0; index < frames.size(); ++index) {
        const std::string file = (fs::path(directory) / frames[index].file).string();
        const detail::ImageHeader header = detail::read_image_header(file);
        if (!expected_size.empty() && header.size != expected_size)
            throw Error(file, "image is " + size_text(header.size) + " but the calibration's camera_size is " +
                                  size_text(expected_size));
        if (index == 0) first_size = header.size;
        else if (header.size != first_size)
            throw Error(file, "image is " + size_text(header.size) + " but " + frames[0].file + " is " +
                                  size_text(first_size));
        if (header.size.width > kLargestImageSide || header.size.height > kLargestImageSide ||
            int64_t(header.size.width) * header.size.height > kLargestImagePixels)
            throw Error(file, "image is " + size_text(header.size) + ", larger than " +
                                  std::to_string(kLargestImageSide) + " pixels a side or " +
                                  std::to_string(kLargestImagePixels >> 20) + " Mpixel");
        bytes += double(header.size.width) * header.size.height * header.bytes_per_sample;
    }
    // Decoding holds a colour image per worker beside the grey frames.
    detail::check_memory_budget(bytes * 1.5, directory,
                                "decoding " + std::to_string(frames.size()) + " frames of " + size_text(first_size));
}

}  // namespace

CaptureSet load_capture_set(const std::string& directory, const std::string& manifest_path,
                            const ProgressCallback& progress, cv::Size expected_size) {
    if (std::error_code error; !fs::is_directory(directory, error)) throw Error(directory, "capture directory not found");
    const bool own_manifest = manifest_path.empty();
    const std::string manifest = own_manifest ? (fs::path(directory) / "sequence.json").string() : manifest_path;

    CaptureSet captures;
    captures.directory = directory;
    captures.sequence = read_manifest(manifest);
    const auto& frames = captures.sequence.frames;

    for (size_t index = 0; index < frames.size(); ++index) {
        const fs::path file = fs::path(directory) / frames[index].file;
        if (std::error_code error; !fs::is_regular_file(file, error))
            throw Error(file.string(), "missing " + describe(frames[index], index) + " listed in " + manifest);
    }
    if (own_manifest) {
        // A stray image usually means a capture of another sequence was mixed in.
        std::set<std::string> listed;
        for (const Frame& frame : frames) listed.insert(frame.file);
        // Entries that cannot be examined (a symlink loop, a dangling link) are not images.
        std::error_code error;
        for (auto entry = fs::directory_iterator(directory, error); !error && entry != fs::directory_iterator();
             entry.increment(error))
            if (std::error_code ignored; entry->is_regular_file(ignored) && is_image_file(entry->path()) &&
                                         !listed.count(entry->path().filename().string()))
                throw Error(entry->path().string(), "extra image not listed in " + manifest);
    }

    check_image_headers(directory, frames, expected_size);

    captures.images.resize(frames.size());
    int first_white = -1;  // its colour image colours the cloud
    for (size_t index = 0; index < frames.size() && first_white < 0; ++index)
        if (frames[index].kind == FrameKind::White) first_white = int(index);
    std::vector<std::string> errors(frames.size());
    detail::ProgressReporter reporter(progress, "load", int(frames.size()));
    detail::parallel_rows(static_cast<int>(frames.size()), [&](int begin, int end) {
        for (int index = begin; index < end && !reporter.cancelled(); ++index) {
            const std::string file = (fs::path(directory) / frames[index].file).string();
            cv::Mat image;
            try {
                image = read_image_file(file, cv::IMREAD_UNCHANGED);
            } catch (const Error& error) {
                errors[index] = error.what();
                continue;
            }
            if (image.depth() != CV_8U && image.depth() != CV_16U) {
                errors[index] = file + ": images must be 8 or 16 bit per channel";
                continue;
            }
            if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
            if (index == first_white && image.channels() == 3 && image.depth() == CV_8U) captures.white_colour = image.clone();
            if (image.channels() == 3) cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);
            captures.images[index] = image;
            reporter.advance();
        }
    });
    if (reporter.cancelled()) throw Error("cancelled", "loading of " + directory + " cancelled");
    for (const std::string& error : errors)
        if (!error.empty()) throw Error("", error);

    const cv::Mat& first = captures.images.front();
    for (size_t index = 1; index < frames.size(); ++index) {
        const cv::Mat& image = captures.images[index];
        const std::string file = (fs::path(directory) / frames[index].file).string();
        if (image.size() != first.size())
            throw Error(file, "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                  " but " + frames[0].file + " is " + std::to_string(first.cols) + "x" +
                                  std::to_string(first.rows));
        if (image.depth() != first.depth())
            throw Error(file, "bit depth differs from " + frames[0].file);
    }
    if (captures.white_colour.empty()) {
        for (size_t index = 0; index < frames.size(); ++index)
            if (frames[index].kind == FrameKind::White && captures.images[index].depth() == CV_8U)
                cv::cvtColor(captures.images[index], captures.white_colour, cv::COLOR_GRAY2BGR);
    }
    return captures;
}

void write_capture_frame(const Frame& frame, const cv::Mat& image, const std::string& directory) {
    write_image_file(image, (fs::path(directory) / frame.file).string());
}

void write_capture_set(const CaptureSet& captures, const std::string& directory) {
    const auto& frames = captures.sequence.frames;
    if (frames.size() != captures.images.size())
        throw Error(directory, "capture set has " + std::to_string(captures.images.size()) + " images for " +
                                   std::to_string(frames.size()) + " frames");
    std::error_code error;
    fs::create_directories(directory, error);
    if (!fs::is_directory(directory)) throw Error(directory, "cannot create the capture directory");
    std::vector<std::string> errors(frames.size());
    detail::parallel_rows(static_cast<int>(frames.size()), [&](int begin, int end) {
        for (int index = begin; index < end; ++index) {
            try {
                write_capture_frame(frames[index], captures.images[index], directory);
            } catch (const std::exception& failure) {
                errors[index] = failure.what();
            }
        }
    });
    for (const std::string& message : errors)
        if (!message.empty()) throw Error("", message);
    write_manifest(captures.sequence, (fs::path(directory) / "sequence.json").string());
}

}  // namespace picoscan
