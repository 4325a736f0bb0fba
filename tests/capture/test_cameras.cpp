// The OpenCV VideoCapture camera, exercised through OpenCV's file backends standing in for a
// V4L2 device: image sequences (lossless, exact levels) and an MJPG AVI; flushing, averaging,
// settings the driver refuses and the error paths.
#include "picoscan/capture.h"
#include "picoscan/error.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <filesystem>

namespace fs = std::filesystem;
using namespace picoscan;
using picoscan::test_support::make_temp_dir;

namespace {

// Frame k of the fake camera is uniformly 10*k + 5, so a level tells which frame was read.
int level_of_frame(int k) { return 10 * k + 5; }

std::string write_numbered_frames(const std::string& directory, int count, cv::Size size = {64, 48}) {
    for (int k = 0; k < count; ++k) {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%03d.png", k);
        cv::imwrite((fs::path(directory) / name).string(), cv::Mat(size, CV_8UC3, cv::Scalar::all(level_of_frame(k))));
    }
    return (fs::path(directory) / "frame_%03d.png").string();
}

double level(const cv::Mat& frame) { return cv::mean(frame)[0]; }

std::string error_of(const std::function<void()>& action) {
    try {
        action();
    } catch (const Error& error) {
        return error.what();
    }
    return "";
}

}  // namespace

TEST(VideoCaptureCamera, FlushDropsBufferedFramesAndAveragingMeansFrames) {
    const std::string source = write_numbered_frames(make_temp_dir("camera-seq"), 12);
    CameraSettings settings;
    settings.flush_frames = 2;
    VideoCaptureCamera camera(source, settings);  // opening reads frame 0 to check the camera
    EXPECT_EQ(camera.frame_size(), cv::Size(64, 48));
    EXPECT_EQ(level(camera.grab()), level_of_frame(1));
    camera.flush();  // drops frames 2 and 3
    EXPECT_EQ(level(camera.grab()), level_of_frame(4));
    // Frames 5..8: (55 + 65 + 75 + 85) / 4 = 70.
    const cv::Mat mean = grab_average(camera, 4);
    EXPECT_EQ(mean.type(), CV_8UC3);
    EXPECT_EQ(level(mean), 70.0);
    // Frames 9, 10 average to 100 exactly; 11 is left.
    EXPECT_EQ(level(grab_average(camera, 2)), 100.0);
    EXPECT_EQ(level(camera.grab()), level_of_frame(11));
    // The end of the video is a camera that stopped delivering (unplugged).
    const std::string message = error_of([&] { camera.grab(); });
    EXPECT_NE(message.find(source), std::string::npos) << message;
    EXPECT_NE(message.find("delivered no frame"), std::string::npos) << message;
    EXPECT_NE(error_of([&] { camera.flush(); }).find("delivered no frame"), std::string::npos);
}

TEST(VideoCaptureCamera, MjpgVideoFileStandsInForAWebcam) {
    const std::string path = (fs::path(make_temp_dir("camera-avi")) / "webcam.avi").string();
    {
        cv::VideoWriter writer(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30, cv::Size(64, 48));
        ASSERT_TRUE(writer.isOpened()) << "OpenCV cannot write MJPG AVI here";
        for (int k = 0; k < 10; ++k) writer.write(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(level_of_frame(k))));
    }
    CameraSettings settings;
    settings.flush_frames = 3;
    VideoCaptureCamera camera(path, settings);  // frame 0
    camera.flush();                             // frames 1..3
    // JPEG keeps a flat grey level within a level or two.
    EXPECT_NEAR(level(camera.grab()), level_of_frame(4), 2.0);
    EXPECT_NEAR(level(grab_average(camera, 5)), level_of_frame(7), 2.0);  // frames 5..9
    EXPECT_NE(error_of([&] { camera.grab(); }).find("delivered no frame"), std::string::npos);
}

TEST(VideoCaptureCamera, RefusedSettingsAreReportedAndAWrongResolutionIsAnError) {
    const std::string source = write_numbered_frames(make_temp_dir("camera-settings"), 3);
    CameraSettings manual;
    manual.exposure = 100;
    manual.focus = 10;
    VideoCaptureCamera camera(source, manual);
    ASSERT_EQ(camera.warnings().size(), 2u);  // a file has neither manual exposure nor focus
    EXPECT_NE(camera.warnings()[0].find("exposure"), std::string::npos) << camera.warnings()[0];
    EXPECT_NE(camera.warnings()[1].find("focus"), std::string::npos) << camera.warnings()[1];

    CameraSettings large;
    large.resolution = cv::Size(1600, 1200);
    const std::string message = error_of([&] { VideoCaptureCamera wrong(source, large); });
    EXPECT_NE(message.find("asked for 1600x1200 but it delivers 64x48"), std::string::npos) << message;
}

TEST(VideoCaptureCamera, MissingCamerasAreClearErrors) {
    EXPECT_NE(error_of([] { VideoCaptureCamera camera("/dev/video97"); }).find("/dev/video97: no such camera"),
              std::string::npos);
    const std::string missing = (fs::path(make_temp_dir("camera-missing")) / "none.avi").string();
    EXPECT_NE(error_of([&] { VideoCaptureCamera camera(missing); }).find(missing + ": no such camera or video file"),
              std::string::npos);
    // An index with no device behind it (this machine has no webcam at 97).
    EXPECT_NE(error_of([] { VideoCaptureCamera camera("97"); }).find("camera 97: cannot open"), std::string::npos);
    // A file that is not a video.
    const std::string text = (fs::path(make_temp_dir("camera-text")) / "notes.avi").string();
    std::FILE* file = std::fopen(text.c_str(), "w");
    std::fputs("not a video\n", file);
    std::fclose(file);
    EXPECT_NE(error_of([&] { VideoCaptureCamera camera(text); }).find(text + ": cannot open"), std::string::npos);
}
