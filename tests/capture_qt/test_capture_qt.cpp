// The projector window and the screen camera on a real (virtual) X display with two screens.
// Run by CTest under: xvfb-run -a -s "-screen 0 1024x768x24 -screen 1 854x480x24"
// (two X screens; Qt 5 lists each as a QScreen. Xvfb's +xinerama shows Qt only one screen.)
#include "picoscan/capture.h"
#include "picoscan/virtual_camera.h"
#include "picoscan/capture_qt.h"
#include "picoscan/capture_set.h"
#include "picoscan/error.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <filesystem>

namespace fs = std::filesystem;
using namespace picoscan;
using picoscan::test_support::cli_path;
using picoscan::test_support::make_temp_dir;
using picoscan::test_support::run_command;

using picoscan::test_support::error_of;

namespace {

constexpr int kProjectorScreen = 1;
const cv::Size kProjectorSize{854, 480};

int differing_pixels(const cv::Mat& a, const cv::Mat& b) {
    if (a.size() != b.size() || a.type() != b.type()) return int(std::max(a.total(), b.total()));
    cv::Mat difference;
    cv::compare(a, b, difference, cv::CMP_NE);
    return cv::countNonZero(difference.reshape(1));
}

// Every stored frame must equal its pattern file pixel for pixel and differ from the patterns
// before and after it (so a skipped or repeated frame cannot pass).
void expect_frames_are_the_patterns(const std::string& captures, const std::string& patterns,
                                    const PatternSequence& sequence) {
    const CaptureSet set = load_capture_set(captures);
    ASSERT_EQ(set.images.size(), sequence.frames.size());
    for (size_t index = 0; index < sequence.frames.size(); ++index) {
        const cv::Mat pattern = cv::imread(patterns + "/" + sequence.frames[index].file, cv::IMREAD_GRAYSCALE);
        EXPECT_EQ(differing_pixels(set.images[index], pattern), 0) << sequence.frames[index].file;
        if (index > 0) {
            const cv::Mat previous = cv::imread(patterns + "/" + sequence.frames[index - 1].file, cv::IMREAD_GRAYSCALE);
            EXPECT_GT(differing_pixels(set.images[index], previous), 0) << sequence.frames[index].file;
        }
    }
}

}  // namespace

TEST(ProjectorWindowOnXvfb, ListsBothScreens) {
    const std::vector<ScreenInfo> screens = list_screens();
    ASSERT_EQ(screens.size(), 2u) << "run under xvfb-run -s \"-screen 0 1024x768x24 -screen 1 854x480x24\"";
    EXPECT_EQ(screens[0].geometry.size(), cv::Size(1024, 768));
    EXPECT_EQ(screens[1].geometry.size(), kProjectorSize);
    std::string output;
    ASSERT_EQ(run_command(cli_path() + " screens", &output), 0) << output;
    EXPECT_NE(output.find("1: 854x480"), std::string::npos) << output;
}

TEST(ProjectorWindowOnXvfb, ShowsEveryPatternExactlyAndTheScreenCameraCapturesThemInOrder) {
    PatternOptions options;
    options.projector_size = kProjectorSize;
    options.shifts = 6;
    const PatternSequence sequence = make_pattern_sequence(options);
    const std::string patterns = make_temp_dir("qt-patterns");
    write_pattern_images(sequence, patterns);

    ProjectorWindow projector(kProjectorScreen);
    DelayedDisplay window(projector, 100.0);  // a projector 100 ms late
    ScreenCamera camera(kProjectorScreen);
    LatencyOptions latency_options;
    latency_options.settle_ms = 200;
    const LatencyMeasurement latency = measure_latency(window, camera, latency_options);
    for (double trial : latency.trials_ms) EXPECT_GE(trial, 100.0);
    EXPECT_NEAR(latency.black_level_dn, 0.0, 0.01);
    EXPECT_NEAR(latency.white_level_dn, 255.0, 0.01);
    std::printf("screen camera latency trials:");
    for (double trial : latency.trials_ms) std::printf(" %.1f", trial);
    std::printf(" ms -> wait %.1f ms\n", latency.recommended_wait_ms());

    const std::string captures = make_temp_dir("qt-captures");
    CaptureOptions capture_options;
    capture_options.wait_ms = latency.recommended_wait_ms();
    capture_sequence(sequence, window, {&camera}, {captures}, capture_options);
    expect_frames_are_the_patterns(captures, patterns, sequence);
}

TEST(ProjectorWindowOnXvfb, CliCapturesWithTheScreenAndTheVirtualCameraTogether) {
    // The virtual camera renders what the window shows; the screen camera checks the window.
    const std::string work = make_temp_dir("qt-cli");
    std::string output;
    const std::string command = cli_path() + " capture --projector-screen 1 --camera virtual --camera screen --noise 0" +
                                " --shifts 4 --no-rows --out " + work + "/set";
    ASSERT_EQ(run_command(command, &output), 0) << output;
    EXPECT_NE(output.find("latency of virtual camera"), std::string::npos) << output;
    PatternOptions options;
    options.projector_size = kProjectorSize;
    options.shifts = 4;
    options.rows = false;
    const PatternSequence sequence = make_pattern_sequence(options);
    const std::string patterns = make_temp_dir("qt-cli-patterns");
    write_pattern_images(sequence, patterns);
    expect_frames_are_the_patterns(work + "/set/camera_2", patterns, sequence);

    const CaptureSet seen = load_capture_set(work + "/set/camera_1");
    SimulationOptions noiseless;
    noiseless.noise_sigma_dn = 0;
    noiseless.blur_sigma_px = 0.7;
    const Simulator simulator(seed_rig_calibration(), demo_scene(), noiseless);
    for (size_t index = 0; index < sequence.frames.size(); ++index)
        EXPECT_EQ(differing_pixels(seen.images[index], simulator.render(render_pattern(sequence, sequence.frames[index]), 0)), 0)
            << index;
}

TEST(ProjectorWindowOnXvfb, RefusesAMissingScreenAndAScreenOfTheWrongSize) {
    EXPECT_NE(error_of([] { ProjectorWindow window(5); }).find("screen 5 does not exist (there are 2 screens"),
              std::string::npos);
    const std::string work = make_temp_dir("qt-wrong");
    std::string output;
    // Screen 0 is 1024x768; the seed rig's projector is 854x480.
    EXPECT_EQ(run_command(cli_path() + " capture --projector-screen 0 --camera virtual --latency-ms 0 --out " + work + "/a",
                          &output),
              1);
    EXPECT_NE(output.find("the calibration's projector is 854x480 but screen 0 is 1024x768"), std::string::npos) << output;
    EXPECT_EQ(run_command(cli_path() + " capture --projector-screen 2 --camera screen --out " + work + "/b", &output), 1);
    EXPECT_NE(output.find("screen 2 does not exist"), std::string::npos) << output;
    EXPECT_FALSE(fs::exists(work + "/a"));
    EXPECT_FALSE(fs::exists(work + "/b"));
}
