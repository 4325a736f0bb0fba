// Stereo calibration files: PicoScan's keys and those of other tools, with errors naming the key.
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"
#include "picoscan/simulate.h"
#include "picoscan/stereo.h"

#include "support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

using namespace picoscan;
using picoscan::test_support::error_of;

namespace {

const char* kIntrinsics = "[ 2500., 0., 800., 0., 2490., 600., 0., 0., 1. ]";
const char* kRotation = "[ 0.99, 0., 0.1410673597966588, 0., 1., 0., -0.1410673597966588, 0., 0.99 ]";

std::string matrix(int rows, int cols, const std::string& data) {
    return "!!opencv-matrix\n   rows: " + std::to_string(rows) + "\n   cols: " + std::to_string(cols) +
           "\n   dt: d\n   data: " + data + "\n";
}

std::string write_text(const std::string& name, const std::string& text) {
    static const std::string folder = test_support::make_temp_dir("stereo_file");
    const std::string path = folder + "/" + name;
    write_file_atomically(path, text);
    return path;
}

// OpenCV's stereo calibration sample (intrinsics + extrinsics in one file) with a size entry.
std::string opencv_sample(const std::string& size_entry, const std::string& rotation_key = "R",
                          const std::string& translation_key = "T") {
    return "%YAML:1.0\nM1: " + matrix(3, 3, kIntrinsics) + "D1: " + matrix(1, 5, "[ -0.08, 0.12, 0.0005, -0.0003, 0. ]") +
           "M2: " + matrix(3, 3, kIntrinsics) + "D2: " + matrix(1, 5, "[ -0.07, 0.1, 0., 0., 0. ]") + rotation_key + ": " +
           matrix(3, 3, kRotation) + translation_key + ": " + matrix(3, 1, "[ -200., 1., 28. ]") +
           "R1: " + matrix(3, 3, "[ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]") + size_entry;
}

}  // namespace

TEST(StereoFile, OpenCvSampleKeysWithAnImageSize) {
    const StereoCalibration c = read_stereo_calibration(write_text("sample.yml", opencv_sample("image_size: [ 1600, 1200 ]\n")));
    EXPECT_EQ(c.left_size, cv::Size(1600, 1200));
    EXPECT_EQ(c.right_size, cv::Size(1600, 1200));
    EXPECT_DOUBLE_EQ(c.left_matrix(1, 1), 2490);
    EXPECT_DOUBLE_EQ(c.right_distortion.at<double>(0), -0.07);
    EXPECT_DOUBLE_EQ(c.T[0], -200);
    EXPECT_NEAR(c.baseline_mm(), std::sqrt(200.0 * 200 + 1 + 28 * 28), 1e-9);
    EXPECT_EQ(calibration_kind(write_text("sample_kind.yml", opencv_sample("S: [ 1600, 1200 ]\n"))), CalibrationKind::Stereo);
}

TEST(StereoFile, OtherScannersKeys) {
    // Rlr/Tlr and an S matrix, as SLMaster's binocular files write them.
    const StereoCalibration c = read_stereo_calibration(
        write_text("slmaster.yml", opencv_sample("S: " + matrix(2, 1, "[ 1280., 1024. ]"), "Rlr", "Tlr")));
    EXPECT_EQ(c.left_size, cv::Size(1280, 1024));
    EXPECT_DOUBLE_EQ(c.R(0, 2), 0.1410673597966588);
}

TEST(StereoFile, MissingAmbiguousAndMalformedKeysAreNamed) {
    const std::string no_size = write_text("no_size.yml", opencv_sample(""));
    EXPECT_NE(error_of([&] { read_stereo_calibration(no_size); }).find("missing key 'camera1_size'"), std::string::npos);
    EXPECT_NE(error_of([&] { read_stereo_calibration(no_size); }).find("'image_size'"), std::string::npos);
    std::string text = opencv_sample("image_size: [ 1600, 1200 ]\n");
    text.erase(text.find("D2:"), text.find("R:") - text.find("D2:"));
    const std::string no_d2 = write_text("no_d2.yml", text);
    EXPECT_NE(error_of([&] { read_stereo_calibration(no_d2); }).find("missing key 'camera2_distortion'"), std::string::npos)
        << error_of([&] { read_stereo_calibration(no_d2); });
    const std::string both = write_text("both.yml", opencv_sample("image_size: [ 1600, 1200 ]\nRlr: " + matrix(3, 3, kRotation)));
    EXPECT_NE(error_of([&] { read_stereo_calibration(both); }).find("both 'R' and 'Rlr'"), std::string::npos);
    const std::string sizes = write_text("sizes.yml", opencv_sample("image_size: [ 1600, 1200 ]\ncam1_size: [ 1280, 1024 ]\n"));
    EXPECT_NE(error_of([&] { read_stereo_calibration(sizes); }).find("different image sizes"), std::string::npos);
    std::string bad_rotation = opencv_sample("image_size: [ 1600, 1200 ]\n");
    bad_rotation.replace(bad_rotation.find("0.99"), 4, "0.80");
    EXPECT_NE(error_of([&] { read_stereo_calibration(write_text("rotation.yml", bad_rotation)); }).find("'R' must be a rotation"),
              std::string::npos);
    // A camera-projector file is not a stereo file.
    const std::string rig = write_text("rig.yml", "");
    std::filesystem::remove(rig);
    write_calibration(seed_rig_calibration(), rig);
    EXPECT_EQ(calibration_kind(rig), CalibrationKind::CameraProjector);
    EXPECT_NE(error_of([&] { read_stereo_calibration(rig); }).find("missing key 'camera1_matrix'"), std::string::npos);
}

TEST(StereoFile, WriteAndReadBack) {
    const StereoCalibration original = seed_stereo_rig().stereo;
    const std::string path = write_text("own.yml", "");
    write_stereo_calibration(original, path);
    const StereoCalibration read = read_stereo_calibration(path);
    EXPECT_EQ(read.left_size, original.left_size);
    EXPECT_LT(cv::norm(read.R - original.R), 1e-12);
    EXPECT_LT(cv::norm(read.T - original.T), 1e-9);
    EXPECT_LT(cv::norm(read.right_matrix - original.right_matrix), 1e-9);
    EXPECT_NEAR(read.baseline_mm(), 200, 1e-9);
}

TEST(StereoFile, OpenCvStructuredLightTutorialFile) {
    PICOSCAN_REQUIRE_DATASETS();
    const StereoCalibration c =
        read_stereo_calibration(test_support::datasets_dir() + "/gsoc2015-statue/calibrationParameters.yml");
    EXPECT_EQ(c.left_size, cv::Size(1920, 1280));
    EXPECT_EQ(c.right_size, cv::Size(1920, 1280));
    EXPECT_NEAR(c.left_matrix(0, 0), 2968.62, 0.01);
    EXPECT_NEAR(c.left_distortion.at<double>(4), 9.5432, 1e-4);
    EXPECT_NEAR(c.baseline_mm(), 1414.57, 0.01);  // |T| of the file
}
