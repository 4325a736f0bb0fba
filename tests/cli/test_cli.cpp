// The `picoscan` command line, run as a user would, on good and bad input.
#include "picoscan/response.h"
#include "picoscan/calibration.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using picoscan::test_support::cli_path;
using picoscan::test_support::make_temp_dir;
using picoscan::test_support::run_command;
using picoscan::test_support::run_picoscan;
using Result = picoscan::test_support::CliResult;

namespace {

int line_count(const std::string& text) {
    int lines = 0;
    for (char c : text) lines += c == '\n';
    return lines;
}

std::string read_file(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
}

// A snapshot of every file under a folder, to prove inputs are never touched.
std::map<std::string, std::string> snapshot(const fs::path& folder) {
    std::map<std::string, std::string> files;
    for (const auto& entry : fs::recursive_directory_iterator(folder))
        if (entry.is_regular_file()) files[entry.path().string()] = read_file(entry.path());
    return files;
}

// One simulated capture set shared by the tests (small projector: fast).
class Cli : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        scan_ = make_temp_dir("cli-scan") + "/scan";
        const Result result = run_picoscan("simulate --out " + scan_ + " --shifts 4 --no-rows --noise 1");
        ASSERT_EQ(result.exit_code, 0) << result.output;
    }
    // A private copy of the scan to damage.
    std::string copy_scan() {
        const std::string copy = make_temp_dir("cli-copy") + "/scan";
        fs::copy(scan_, copy, fs::copy_options::recursive);
        return copy;
    }
    // Expects a one-line error naming `expected`, exit code != 0, no output file, inputs intact.
    void expect_refused(const std::string& scan, const std::string& extra, const std::string& expected) {
        const fs::path out = fs::path(make_temp_dir("cli-out")) / "cloud.ply";
        const auto before = snapshot(scan);
        const Result result = run_picoscan("reconstruct --calibration " + scan + "/calibration.yml --captures " + scan +
                                       " --out " + out.string() + " " + extra);
        EXPECT_NE(result.exit_code, 0) << result.output;
        EXPECT_EQ(line_count(result.output), 1) << result.output;
        EXPECT_NE(result.output.find(expected), std::string::npos) << "expected '" << expected << "' in: " << result.output;
        EXPECT_FALSE(fs::exists(out)) << "output written despite the error";
        for (const auto& entry : fs::directory_iterator(out.parent_path()))
            ADD_FAILURE() << "left behind: " << entry.path();
        EXPECT_EQ(snapshot(scan), before) << "an input was modified";
    }
    static std::string scan_;
};
std::string Cli::scan_;

}  // namespace

TEST_F(Cli, HelpTeachesAndUsageErrorsExit2) {
    Result result = run_picoscan("--help");
    EXPECT_EQ(result.exit_code, 0);
    EXPECT_NE(result.output.find("reconstruct"), std::string::npos);
    EXPECT_NE(result.output.find("typical session"), std::string::npos);
    // Every command listed teaches by an example: a line of its own that runs it.
    std::istringstream listing(result.output.substr(result.output.find("Commands:")));
    std::string line;
    int commands = 0;
    for (std::getline(listing, line); std::getline(listing, line) && line.rfind("  ", 0) == 0; ++commands) {
        const std::string command = line.substr(2, line.find(' ', 2) - 2);
        const Result help = run_picoscan(command + " --help");
        EXPECT_EQ(help.exit_code, 0) << command;
        EXPECT_EQ(help.output.rfind("picoscan " + command, 0), 0u) << command << " --help starts with its usage";
        EXPECT_NE(help.output.find("\nExample"), std::string::npos) << command << " --help has no example";
        const std::string example = "\n  picoscan " + command;
        const size_t at = help.output.find(example);
        EXPECT_TRUE(at != std::string::npos && std::isspace(help.output[at + example.size()])) << command << ": no example runs it";
    }
    EXPECT_EQ(commands, 14) << result.output;
    EXPECT_EQ(run_picoscan("").exit_code, 2);
    EXPECT_EQ(run_picoscan("frobnicate").exit_code, 2);
    result = run_picoscan("patterns --projector 854x480 --out /tmp/x --shifs 4");
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("--shifs: unknown option"), std::string::npos) << result.output;
}

TEST_F(Cli, PatternsCommandWritesTheSequence) {
    const std::string out = make_temp_dir("cli-patterns") + "/patterns";
    const Result result = run_picoscan("patterns --projector 854x480 --shifts 8 --period-bits 5 --out " + out);
    ASSERT_EQ(result.exit_code, 0) << result.output;
    size_t pngs = 0;
    for (const auto& entry : fs::directory_iterator(out)) pngs += entry.path().extension() == ".png";
    EXPECT_EQ(pngs, size_t(2 + 2 * (10 + 9) + 2 * 8));
    const cv::Mat first = cv::imread(out + "/000_white.png", cv::IMREAD_UNCHANGED);
    EXPECT_EQ(first.size(), cv::Size(854, 480));
    EXPECT_EQ(first.type(), CV_8UC1);
    const Result bad = run_picoscan("patterns --projector 854by480 --out " + out);
    EXPECT_EQ(bad.exit_code, 1);
    EXPECT_NE(bad.output.find("--projector"), std::string::npos) << bad.output;
}

TEST_F(Cli, ReconstructWritesCloudMeshAndPreview) {
    const std::string out = make_temp_dir("cli-rec");
    const Result result = run_picoscan("reconstruct --calibration " + scan_ + "/calibration.yml --captures " + scan_ +
                                   " --out " + out + "/cloud.ply --mesh " + out + "/part.stl --preview " + out + "/p.png --clean");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_NE(result.output.find("cleaning removed"), std::string::npos) << result.output;
    EXPECT_GT(fs::file_size(out + "/cloud.ply"), 1000000u);
    EXPECT_GT(fs::file_size(out + "/part.stl"), 1000000u);
    const cv::Mat preview = cv::imread(out + "/p.png");
    EXPECT_EQ(preview.size(), cv::Size(1600, 1200));
}

TEST_F(Cli, MissingFrame) {
    const std::string scan = copy_scan();
    fs::remove(scan + "/010_col_gray04.png");
    expect_refused(scan, "", "010_col_gray04.png: missing frame");
}

TEST_F(Cli, ExtraFrame) {
    const std::string scan = copy_scan();
    fs::copy_file(scan + "/000_white.png", scan + "/999_stray.png");
    expect_refused(scan, "", "999_stray.png: extra image");
}

TEST_F(Cli, MismatchedSize) {
    const std::string scan = copy_scan();
    cv::imwrite(scan + "/005_col_gray01_inv.png", cv::Mat(600, 800, CV_8U, cv::Scalar(0)));
    expect_refused(scan, "", "005_col_gray01_inv.png: image is 800x600");
}

TEST_F(Cli, CorruptImage) {
    const std::string scan = copy_scan();
    std::ofstream(scan + "/003_col_gray00_inv.png", std::ios::trunc) << "this is not a PNG";
    // Caught in the header, before any frame is decoded.
    expect_refused(scan, "", "003_col_gray00_inv.png: not a PNG, BMP, JPEG or TIFF image");
}

TEST_F(Cli, ManifestWithMissingKey) {
    const std::string scan = copy_scan();
    std::string manifest = read_file(scan + "/sequence.json");
    manifest.replace(manifest.find("\"projector_height\""), 18, "\"projector_h\"");
    std::ofstream(scan + "/sequence.json", std::ios::trunc) << manifest;
    expect_refused(scan, "", "sequence.json: missing key 'projector_height'");
}

TEST_F(Cli, CalibrationWithWrongType) {
    const std::string scan = copy_scan();
    std::string calibration = read_file(scan + "/calibration.yml");
    const size_t at = calibration.find("projector_size:");
    calibration.replace(at, calibration.find('\n', at) - at, "projector_size: \"wide\"");
    std::ofstream(scan + "/calibration.yml", std::ios::trunc) << calibration;
    expect_refused(scan, "", "calibration.yml: 'projector_size' must be [width, height]");
}

TEST_F(Cli, CalibrationOfAnotherCamera) {
    const std::string scan = copy_scan();
    picoscan::Calibration calibration = picoscan::read_calibration(scan + "/calibration.yml");
    calibration.camera_size = {1280, 1024};
    picoscan::write_calibration(calibration, scan + "/calibration.yml");
    // The first frame's header is compared with camera_size before any frame is decoded.
    expect_refused(scan, "", "000_white.png: image is 1600x1200 but the calibration's camera_size is 1280x1024");
}

TEST_F(Cli, AllDarkCaptures) {
    const std::string scan = copy_scan();
    for (const auto& entry : fs::directory_iterator(scan))
        if (entry.path().extension() == ".png") {
            const cv::Mat image = cv::imread(entry.path().string(), cv::IMREAD_UNCHANGED);
            cv::imwrite(entry.path().string(), cv::Mat(image.size(), image.type(), cv::Scalar(2)));
        }
    expect_refused(scan, "", "all captures are dark");
}

TEST_F(Cli, OutputInsideTheCaptureDirectory) {
    const std::string scan = copy_scan();
    const auto before = snapshot(scan);
    const Result result = run_picoscan("reconstruct --calibration " + scan + "/calibration.yml --captures " + scan +
                                   " --out " + scan + "/cloud.ply");
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("must not be written into the capture directory"), std::string::npos) << result.output;
    EXPECT_EQ(snapshot(scan), before);
}

TEST_F(Cli, MissingCaptureDirectoryAndBadMeshName) {
    const fs::path out = fs::path(make_temp_dir("cli-missing")) / "cloud.ply";
    const Result missing = run_picoscan("reconstruct --calibration " + scan_ + "/calibration.yml --captures "
                                        "/nonexistent/scan --out " + out.string());
    EXPECT_EQ(missing.exit_code, 1) << missing.output;
    EXPECT_NE(missing.output.find("/nonexistent/scan: capture directory not found"), std::string::npos) << missing.output;
    EXPECT_FALSE(fs::exists(out));
    // An option given twice is a mistake, not "the last one wins".
    expect_refused(scan_, "--captures /nonexistent/scan", "--captures: is given more than once");
    expect_refused(scan_, "--mesh /tmp/part.xyz", "/tmp/part.xyz: mesh file must end in");
}

TEST_F(Cli, SimulateRefusesANonEmptyFolder) {
    const Result result = run_picoscan("simulate --out " + scan_);
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("not empty"), std::string::npos) << result.output;
}

TEST(CliCalibrate, SimulatedPosesCalibrateAndAFailedRunKeepsTheOldFile) {
    const std::string root = make_temp_dir("cli-calibrate");
    const double tilts[][2] = {{20, 15}, {-20, 15}, {20, -15}, {-20, -15}};
    std::string poses;
    for (int index = 0; index < 4; ++index) {
        const std::string scene = root + "/board" + std::to_string(index) + ".yml";
        std::ofstream(scene) << "boards:\n  - rotation_deg: [" << tilts[index][0] << ", " << tilts[index][1]
                             << ", 0]\n    translation: [-70, -45, 400]\n    inner_corners: [9, 6]\n"
                                "    square_mm: 18\n    margin_mm: 12\n";
        const std::string pose = root + "/pose" + std::to_string(index);
        const Result simulated = run_picoscan("simulate --scene " + scene + " --out " + pose + " --shifts 4");
        ASSERT_EQ(simulated.exit_code, 0) << simulated.output;
        poses += " " + pose;
    }
    const std::string out = root + "/calibration.yml";
    Result result = run_picoscan("calibrate --board chessboard:9x6:18 --captures" + poses + " --out " + out +
                                 " --report " + root + "/report.html");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_NE(result.output.find("camera: f = "), std::string::npos) << result.output;
    const std::string report = read_file(root + "/report.html");
    EXPECT_NE(report.find("<h1>Calibration report</h1>"), std::string::npos);
    size_t pictures = 0;
    for (size_t at = report.find("data:image/png;base64,"); at != std::string::npos; at = report.find("data:image/png;base64,", at + 1))
        ++pictures;
    EXPECT_EQ(pictures, 3u);
    EXPECT_NE(report.find("pose3"), std::string::npos);
    const picoscan::Calibration found = picoscan::read_calibration(out);
    EXPECT_NEAR(found.camera_matrix(0, 0), 2500, 25);  // 4 poses: within 1 %
    EXPECT_NEAR(cv::norm(found.T), 150, 3);

    // Two poses are too few, and no pose can meet a limit of 0 px: refused before the boards are
    // searched for, naming the option, and the existing file is untouched.
    const std::string before = read_file(out);
    result = run_picoscan("calibrate --board chessboard:9x6:18 --captures " + root + "/pose0 " + root + "/pose1 --out " + out);
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("--captures: gives 2 board pose(s); at least 3 are needed"), std::string::npos) << result.output;
    result = run_picoscan("calibrate --board chessboard:9x6:18 --captures" + poses + " --out " + out + " --max-pose-error 0");
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("--max-pose-error: must be a positive"), std::string::npos) << result.output;
    EXPECT_EQ(result.output.find("pose " + root), std::string::npos) << "boards were searched for: " << result.output;
    EXPECT_EQ(read_file(out), before);
    // A board that is not in the images.
    result = run_picoscan("calibrate --board chessboard:7x5:18 --captures" + poses + " --out " + root + "/other.yml");
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("board not found"), std::string::npos) << result.output;
    EXPECT_FALSE(fs::exists(root + "/other.yml"));
}

TEST(CliResponse, FlatFramesGiveAResponseCorrection) {
    const std::string root = make_temp_dir("cli-response");
    // Patterns for the measurement, then their captures by the simulated rig with gamma 2.2.
    Result result = run_picoscan("patterns --projector 854x480 --flat-levels 9 --out " + root + "/flats");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_TRUE(fs::exists(root + "/flats/level_128.png"));
    const std::string scan = root + "/scan";
    ASSERT_EQ(run_picoscan("simulate --out " + scan + " --shifts 4 --gamma 2.2").exit_code, 0);
    // Flat captures: render through the same rig as the simulate command did.
    picoscan::Scene scene = picoscan::demo_scene();
    picoscan::SimulationOptions options;
    options.projector_gamma = 2.2;
    options.blur_sigma_px = 0.7;
    const picoscan::Simulator simulator(picoscan::read_calibration(scan + "/calibration.yml"), scene, options);
    fs::create_directories(root + "/captured");
    for (int level : picoscan::response_levels(9)) {
        char name[32];
        std::snprintf(name, sizeof name, "level_%03d.png", level);
        const cv::Mat flat = cv::imread(root + "/flats/" + name, cv::IMREAD_GRAYSCALE);
        ASSERT_FALSE(flat.empty()) << level;
        cv::imwrite(root + "/captured/" + name, simulator.render(flat, level));
    }
    result = run_picoscan("response --captures " + root + "/captured --calibration " + scan + "/calibration.yml --out " +
                          root + "/corrected.yml");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    EXPECT_NE(result.output.find("gamma 2.2"), std::string::npos) << result.output;
    const picoscan::Calibration corrected = picoscan::read_calibration(root + "/corrected.yml");
    ASSERT_EQ(corrected.projector_inverse_response.total(), 256u);
    EXPECT_NEAR(corrected.projector_inverse_response.at<uint8_t>(128), 186, 5);
    // Corrected patterns: a mid-grey fringe level goes out brighter.
    result = run_picoscan("patterns --projector 854x480 --shifts 4 --calibration " + root + "/corrected.yml --out " + root + "/p");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    // Refuses to overwrite its input.
    result = run_picoscan("response --captures " + root + "/captured --calibration " + root + "/corrected.yml --out " +
                          root + "/corrected.yml");
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("would overwrite the input calibration"), std::string::npos) << result.output;
}

TEST(CliDemo, RefusesToReplaceCapturesItDidNotMake) {
    const std::string root = make_temp_dir("cli-demo");
    fs::create_directories(root + "/captures");
    std::ofstream(root + "/captures/sequence.json") << "{}";
    std::ofstream(root + "/captures/notes.txt") << "mine";
    const Result result = run_picoscan("demo --out " + root);
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("was not made by 'picoscan demo'"), std::string::npos) << result.output;
    EXPECT_EQ(read_file(root + "/captures/notes.txt"), "mine");
}

TEST_F(Cli, OutputInsideTheSecondCameraCaptures) {
    const std::string second = copy_scan();
    const auto before = snapshot(second);
    const Result result = run_picoscan("reconstruct --calibration " + scan_ + "/calibration.yml --captures " + scan_ +
                                       " --second-calibration " + second + "/calibration.yml --second-captures " + second +
                                       " --out " + make_temp_dir("cli-second") + "/cloud.ply --preview " + second + "/p.png");
    EXPECT_EQ(result.exit_code, 1);
    EXPECT_NE(result.output.find("must not be written into the capture directory"), std::string::npos) << result.output;
    EXPECT_EQ(snapshot(second), before);
}
