// The sequencer with the simulated display and the virtual camera: latency measurement and
// the wait, frame order, folders it refuses, a camera lost mid-sequence and resuming.
#include "capture_test_util.h"

#include "picoscan/capture.h"
#include "picoscan/virtual_camera.h"
#include "picoscan/capture_set.h"
#include "picoscan/error.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using namespace picoscan;
using namespace picoscan::capture_test;
using picoscan::test_support::make_temp_dir;

using picoscan::test_support::error_of;

namespace {

PatternSequence short_sequence() {
    PatternOptions options;
    options.projector_size = seed_rig_calibration().projector_size;
    options.shifts = 4;
    options.rows = false;
    return make_pattern_sequence(options);  // white, black, 10 bit pairs, 4 shifts: 26 frames
}

SimulationOptions noiseless() {
    SimulationOptions options;
    options.noise_sigma_dn = 0.0;
    return options;
}

size_t file_count(const std::string& directory) {
    return size_t(std::distance(fs::directory_iterator(directory), fs::directory_iterator()));
}

}  // namespace

TEST(Sequencer, MeasuredLatencyMakesEveryFrameShowItsOwnPattern) {
    const Calibration rig = small_rig(0.25);
    const PatternSequence sequence = short_sequence();
    SimulatedDisplay projector(rig.projector_size);
    DelayedDisplay display(projector, 100.0);  // the projector shows a pattern 100 ms late
    VirtualCamera camera(rig, demo_scene(), noiseless(), display);

    LatencyOptions latency_options;
    latency_options.settle_ms = 150;
    const LatencyMeasurement latency = measure_latency(display, camera, latency_options);
    ASSERT_EQ(latency.trials_ms.size(), 3u);
    for (double trial : latency.trials_ms) EXPECT_GE(trial, 100.0);
    EXPECT_GT(latency.white_level_dn - latency.black_level_dn, 50.0);

    const std::string directory = make_temp_dir("sequencer-latency");
    CaptureOptions options;
    options.wait_ms = latency.recommended_wait_ms();
    const CaptureReport report = capture_sequence(sequence, display, {&camera}, {directory}, options);
    EXPECT_EQ(report.captured, int(sequence.frames.size()));

    // Each stored frame is the noiseless render of its own pattern: none skipped, none repeated.
    const CaptureSet captured = load_capture_set(directory);
    const Simulator simulator(rig, demo_scene(), noiseless());
    for (size_t index = 0; index < sequence.frames.size(); ++index) {
        const cv::Mat expected = simulator.render(render_pattern(sequence, sequence.frames[index]), 0);
        EXPECT_EQ(differing_pixels(captured.images[index], expected), 0) << sequence.frames[index].file;
    }
}

TEST(Sequencer, WithoutTheWaitALateProjectorGivesWrongFrames) {
    // The failure the wait prevents: grabbing at once catches the previous pattern.
    const Calibration rig = small_rig(0.25);
    const PatternSequence sequence = short_sequence();
    SimulatedDisplay projector(rig.projector_size);
    DelayedDisplay display(projector, 300.0);
    VirtualCamera camera(rig, demo_scene(), noiseless(), display);
    const std::string directory = make_temp_dir("sequencer-no-wait");
    PatternSequence first_frames = sequence;
    first_frames.frames.resize(6);
    capture_sequence(first_frames, display, {&camera}, {directory}, CaptureOptions{});
    const Simulator simulator(rig, demo_scene(), noiseless());
    int wrong = 0;
    for (const Frame& frame : first_frames.frames) {
        const cv::Mat stored = cv::imread((fs::path(directory) / frame.file).string(), cv::IMREAD_GRAYSCALE);
        wrong += differing_pixels(stored, simulator.render(render_pattern(sequence, frame), 0)) > 0;
    }
    EXPECT_GE(wrong, 5);
}

TEST(Sequencer, RefusesFoldersThatHoldSomethingElseAndDeletesNothing) {
    const Calibration rig = small_rig(0.125);
    const PatternSequence sequence = short_sequence();
    SimulatedDisplay display(rig.projector_size);
    VirtualCamera camera(rig, demo_scene(), noiseless(), display);

    // A folder with other files.
    const std::string other = make_temp_dir("sequencer-other");
    std::ofstream(fs::path(other) / "holiday.jpg") << "photo";
    std::string message = error_of([&] { capture_sequence(sequence, display, {&camera}, {other}, {}); });
    EXPECT_NE(message.find(other + ": holds files but no capture"), std::string::npos) << message;
    EXPECT_EQ(file_count(other), 1u);

    // A capture of a different sequence, even with resume.
    const std::string different = make_temp_dir("sequencer-different");
    PatternSequence shorter = sequence;
    shorter.frames.resize(3);
    capture_sequence(shorter, display, {&camera}, {different}, {});
    CaptureOptions resume;
    resume.resume = true;
    message = error_of([&] { capture_sequence(sequence, display, {&camera}, {different}, resume); });
    EXPECT_NE(message.find("already holds a different capture"), std::string::npos) << message;
    EXPECT_EQ(file_count(different), 4u);

    // The same sequence again without resume.
    message = error_of([&] { capture_sequence(shorter, display, {&camera}, {different}, {}); });
    EXPECT_NE(message.find("already holds a capture of this sequence (3 of 3 frames)"), std::string::npos) << message;

    // Not writable: a path through a file.
    const std::string blocked = (fs::path(other) / "holiday.jpg" / "scan").string();
    message = error_of([&] { capture_sequence(sequence, display, {&camera}, {blocked}, {}); });
    EXPECT_NE(message.find("is not a folder"), std::string::npos) << message;

    // A display of another size than the patterns.
    SimulatedDisplay wrong_size(cv::Size(800, 600));
    message = error_of([&] { capture_sequence(sequence, wrong_size, {&camera}, {make_temp_dir("s")}, {}); });
    EXPECT_NE(message.find("projector: the display is 800x600"), std::string::npos) << message;
}

TEST(Sequencer, ACameraLostMidSequenceKeepsItsFramesAndResumeCompletes) {
    const Calibration rig = small_rig(0.125);
    const PatternSequence sequence = short_sequence();
    SimulatedDisplay display(rig.projector_size);
    VirtualCamera virtual_camera(rig, demo_scene(), noiseless(), display);
    const std::string directory = make_temp_dir("sequencer-unplugged");

    // A webcam that stops after 10 frames: OpenCV's image-sequence backend over the first 10
    // renders (plus the frame the camera reads when it opens), then no more files.
    const std::string frames = make_temp_dir("sequencer-unplugged-frames");
    const Simulator simulator(rig, demo_scene(), noiseless());
    for (int index = -1; index < 10; ++index) {
        const cv::Mat render = simulator.render(render_pattern(sequence, sequence.frames[std::max(index, 0)]), 0);
        cv::imwrite(frames + cv::format("/frame_%03d.png", index + 1), render);
    }
    CameraSettings no_flush;
    no_flush.flush_frames = 0;
    const std::string source = frames + "/frame_%03d.png";
    VideoCaptureCamera unplugged(source, no_flush);
    const std::string message = error_of([&] { capture_sequence(sequence, display, {&unplugged}, {directory}, {}); });
    EXPECT_NE(message.find(source + ": delivered no frame"), std::string::npos) << message;
    const std::vector<bool> present = frames_present(sequence, directory);
    EXPECT_EQ(std::count(present.begin(), present.end(), true), 10);
    for (int index = 0; index < 10; ++index) EXPECT_TRUE(present[index]) << index;
    // The partial set says what is missing.
    const std::string load_message = error_of([&] { load_capture_set(directory); });
    EXPECT_NE(load_message.find("missing frame 10"), std::string::npos) << load_message;

    CaptureOptions resume;
    resume.resume = true;
    const CaptureReport report = capture_sequence(sequence, display, {&virtual_camera}, {directory}, resume);
    EXPECT_EQ(report.already_present, 10);
    EXPECT_EQ(report.captured, int(sequence.frames.size()) - 10);
    const CaptureSet completed = load_capture_set(directory);
    for (size_t index = 0; index < sequence.frames.size(); ++index)
        EXPECT_EQ(differing_pixels(completed.images[index],
                                   simulator.render(render_pattern(sequence, sequence.frames[index]), 0)),
                  0)
            << index;
}

TEST(Sequencer, TwoCamerasCaptureTheSamePatternIntoTheirOwnSets) {
    const Calibration rig = small_rig(0.125);
    PatternSequence sequence = short_sequence();
    SimulatedDisplay display(rig.projector_size);
    VirtualCamera first(rig, demo_scene(), noiseless(), display);
    VirtualCamera second(rig, demo_scene(), noiseless(), display);
    const std::string out = make_temp_dir("sequencer-two");
    const std::vector<std::string> folders{out + "/camera_1", out + "/camera_2"};
    CaptureOptions options;
    options.frames_per_pattern = 3;
    capture_sequence(sequence, display, {&first, &second}, folders, options);
    const CaptureSet a = load_capture_set(folders[0]);
    const CaptureSet b = load_capture_set(folders[1]);
    for (size_t index = 0; index < sequence.frames.size(); ++index)
        EXPECT_EQ(differing_pixels(a.images[index], b.images[index]), 0) << index;
    EXPECT_NE(error_of([&] { capture_sequence(sequence, display, {&first, &second}, {out, out}, {}); })
                  .find("given for two cameras"),
              std::string::npos);
}
