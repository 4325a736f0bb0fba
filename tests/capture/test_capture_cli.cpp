// 'picoscan capture' and 'picoscan scan' run as a user would, with the virtual camera: the
// one-step scan against the simulator's direct render, a capture killed halfway and resumed,
// and bad input.
#include "capture_test_util.h"

#include "picoscan/capture.h"
#include "picoscan/virtual_camera.h"
#include "picoscan/capture_set.h"
#include "picoscan/decode.h"
#include "picoscan/io.h"
#include "picoscan/triangulate.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>
#include <thread>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace picoscan;
using namespace picoscan::capture_test;
using picoscan::test_support::cli_path;
using picoscan::test_support::make_temp_dir;
using picoscan::test_support::run_command;

namespace {

int run_picoscan(const std::string& arguments, std::string* output = nullptr) {
    return run_command(cli_path() + " " + arguments, output);
}

std::string write_small_rig(const std::string& directory, double factor) {
    const std::string path = (fs::path(directory) / "rig.yml").string();
    write_calibration(small_rig(factor), path);
    return path;
}

}  // namespace

TEST(CaptureCli, ScanWithTheVirtualCameraMatchesTheSimulatorsDirectRender) {
    const std::string work = make_temp_dir("scan-virtual");
    const std::string rig_path = write_small_rig(work, 0.5);  // 800x600 camera
    const std::string out = (fs::path(work) / "scan").string();
    std::string output;
    ASSERT_EQ(run_picoscan("scan --camera virtual --calibration " + rig_path + " --latency-ms 0 --out " + out, &output), 0)
        << output;

    // The same scene rendered directly, with the same patterns and camera model (another noise draw).
    const Calibration rig = read_calibration(rig_path);
    PatternOptions patterns;
    patterns.projector_size = rig.projector_size;
    SimulationOptions simulation;
    simulation.blur_sigma_px = 0.7;  // the CLI's default
    const CaptureSet direct = simulate_capture(make_pattern_sequence(patterns), rig, demo_scene(), simulation);
    const CaptureSet scanned = load_capture_set(out + "/captures");
    ASSERT_EQ(scanned.images.size(), direct.images.size());

    const CorrespondenceMap expected = decode(direct);
    const CorrespondenceMap actual = decode(scanned);
    // A pixel agrees when both decode it to the same projector pixel (within half a pixel on
    // both axes), or neither decodes it.
    int agree = 0, either_valid = 0, agree_valid = 0;
    const int total = int(expected.mask.total());
    for (int y = 0; y < expected.mask.rows; ++y)
        for (int x = 0; x < expected.mask.cols; ++x) {
            const bool a = expected.mask.at<uchar>(y, x), b = actual.mask.at<uchar>(y, x);
            if (!a && !b) {
                ++agree;
                continue;
            }
            ++either_valid;
            if (a && b && std::abs(expected.projector_u.at<float>(y, x) - actual.projector_u.at<float>(y, x)) < 0.5f &&
                std::abs(expected.projector_v.at<float>(y, x) - actual.projector_v.at<float>(y, x)) < 0.5f) {
                ++agree;
                ++agree_valid;
            }
        }
    const double agreement = double(agree) / total;
    const double valid_agreement = double(agree_valid) / either_valid;
    std::printf("scan vs direct render: codes agree on %.4f %% of pixels (%.4f %% of %d decoded pixels)\n",
                100 * agreement, 100 * valid_agreement, either_valid);
    EXPECT_GE(agreement, 0.999);
    EXPECT_GE(valid_agreement, 0.999);

    // The cloud has the points of the direct render's decode, to within the same 0.1 %.
    const Mesh cloud = read_ply(out + "/cloud.ply");
    const PointCloud direct_cloud = to_point_cloud(triangulate(expected, rig, direct.white_colour));
    EXPECT_NEAR(double(cloud.vertices.size()), double(direct_cloud.points.size()), 0.001 * direct_cloud.points.size());
    EXPECT_TRUE(fs::is_regular_file(out + "/preview.png"));
}

TEST(CaptureCli, ACaptureKilledHalfwayLeavesAValidPartialSetThatResumeCompletes) {
    const std::string work = make_temp_dir("capture-kill");
    const std::string rig_path = write_small_rig(work, 0.25);
    const std::string out = (fs::path(work) / "set").string();
    const std::string options = "--camera virtual --calibration " + rig_path + " --noise 0 --shifts 8 --no-rows";
    const PatternSequence sequence = [] {
        PatternOptions patterns;
        patterns.shifts = 8;
        patterns.rows = false;
        return make_pattern_sequence(patterns);
    }();
    const int frame_count = int(sequence.frames.size());

    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        const std::string command = cli_path() + " capture " + options + " --latency-ms 40 --out " + out + " >/dev/null 2>&1";
        execl("/bin/sh", "sh", "-c", ("exec " + command).c_str(), (char*)nullptr);
        _exit(127);
    }
    // Kill it (SIGKILL: no chance to tidy up) once half the frames are on disk.
    int present = 0;
    for (int attempt = 0; attempt < 3000 && present < frame_count / 2; ++attempt) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        if (fs::exists(out + "/sequence.json")) {
            const std::vector<bool> frames = frames_present(sequence, out);
            present = int(std::count(frames.begin(), frames.end(), true));
        }
    }
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the capture ended before it could be killed";

    // The partial set: the manifest and a run of complete frames from the first, nothing else.
    const std::vector<bool> frames = frames_present(sequence, out);
    const int kept = int(std::count(frames.begin(), frames.end(), true));
    EXPECT_GE(kept, frame_count / 2);
    EXPECT_LT(kept, frame_count);
    for (int index = 0; index < kept; ++index) {
        ASSERT_TRUE(frames[index]) << index;
        EXPECT_FALSE(cv::imread(out + "/" + sequence.frames[index].file, cv::IMREAD_UNCHANGED).empty()) << index;
    }
    EXPECT_EQ(read_manifest(out + "/sequence.json").frames.size(), size_t(frame_count));

    std::string output;
    ASSERT_NE(run_picoscan("capture " + options + " --latency-ms 0 --out " + out, &output), 0);
    EXPECT_NE(output.find("already holds a capture of this sequence (" + std::to_string(kept) + " of " +
                          std::to_string(frame_count) + " frames)"),
              std::string::npos)
        << output;
    ASSERT_EQ(run_picoscan("capture " + options + " --latency-ms 0 --resume --out " + out, &output), 0) << output;
    EXPECT_NE(output.find("(" + std::to_string(kept) + " were already there)"), std::string::npos) << output;

    // Complete, and every frame is the one an uninterrupted capture takes.
    const CaptureSet resumed = load_capture_set(out);
    const std::string reference = (fs::path(work) / "reference").string();
    ASSERT_EQ(run_picoscan("capture " + options + " --latency-ms 0 --out " + reference, &output), 0) << output;
    const CaptureSet uninterrupted = load_capture_set(reference);
    for (int index = 0; index < frame_count; ++index)
        EXPECT_EQ(differing_pixels(resumed.images[index], uninterrupted.images[index]), 0) << index;
}

TEST(CaptureCli, BadInputGivesOneClearLineAndKeepsWhatExists) {
    const std::string work = make_temp_dir("capture-bad");
    std::string output;
    EXPECT_EQ(run_picoscan("capture --camera /dev/video97 --out " + work + "/a --latency-ms 0 --projector-screen 0", &output), 1);
    EXPECT_NE(output.find("/dev/video97: no such camera"), std::string::npos) << output;
    EXPECT_FALSE(fs::exists(work + "/a"));

    EXPECT_EQ(run_picoscan("capture --camera 0 --out " + work + "/a", &output), 1);
    EXPECT_NE(output.find("--projector-screen: is required with a real camera"), std::string::npos) << output;

    // A folder holding someone's files is refused and left as it was.
    std::ofstream(work + "/notes.txt") << "keep me";
    EXPECT_EQ(run_picoscan("capture --camera virtual --latency-ms 0 --out " + work, &output), 1);
    EXPECT_NE(output.find(work + ": holds files but no capture"), std::string::npos) << output;
    EXPECT_EQ(std::distance(fs::directory_iterator(work), fs::directory_iterator()), 1);

    // Not writable: a path under a file.
    EXPECT_EQ(run_picoscan("capture --camera virtual --latency-ms 0 --out " + work + "/notes.txt/set", &output), 1);
    EXPECT_NE(output.find("is not a folder"), std::string::npos) << output;

    // Without a display the projector window cannot open: a message, not a crash.
    EXPECT_EQ(run_command("env -u DISPLAY -u WAYLAND_DISPLAY -u QT_QPA_PLATFORM " + cli_path() +
                              " capture --camera virtual --projector-screen 1 --latency-ms 0 --out " + work + "/b",
                          &output),
              1);
    EXPECT_NE(output.find("display"), std::string::npos) << output;

    EXPECT_EQ(run_picoscan("scan --camera 0 --out " + work + "/c", &output), 1);
    EXPECT_NE(output.find("--calibration: is required with a real camera"), std::string::npos) << output;

    EXPECT_EQ(run_picoscan("capture --help", &output), 0);
    EXPECT_NE(output.find("--resume"), std::string::npos);
}
