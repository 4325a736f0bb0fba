#include "picoscan/calibration.h"
#include "picoscan/error.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

using namespace picoscan;

TEST(CalibrationFile, RoundTripsExactly) {
    const std::string path = test_support::make_temp_dir("calib") + "/calibration.yml";
    const Calibration written = seed_rig_calibration();
    write_calibration(written, path);
    const Calibration read = read_calibration(path);
    EXPECT_EQ(read.camera_size, written.camera_size);
    EXPECT_EQ(read.projector_size, written.projector_size);
    EXPECT_EQ(cv::norm(cv::Mat(read.camera_matrix), cv::Mat(written.camera_matrix), cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(read.projector_distortion, written.projector_distortion, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(cv::Mat(read.R), cv::Mat(written.R), cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(cv::Mat(read.T), cv::Mat(written.T), cv::NORM_INF), 0.0);
}

TEST(CalibrationFile, MissingOrMalformedKeysNameTheFileAndKey) {
    const std::string directory = test_support::make_temp_dir("badcalib");
    const std::string path = directory + "/calibration.yml";
    write_calibration(seed_rig_calibration(), path);
    std::ifstream in(path);
    const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    auto expect_error = [&](const std::string& text, const std::string& expected) {
        const std::string bad = directory + "/bad.yml";
        std::ofstream(bad) << text;
        try {
            read_calibration(bad);
            ADD_FAILURE() << "accepted: " << expected;
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find(bad), std::string::npos) << error.what();
            EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
        }
    };
    auto replaced = [&](const std::string& from, const std::string& to) {
        std::string text = good;
        const size_t at = text.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        return text.replace(at, from.size(), to);
    };
    expect_error(replaced("projector_matrix:", "projector_matrixx:"), "projector_matrix");
    expect_error(replaced("camera_size: [ 1600, 1200 ]", "camera_size: [ 1600 ]"), "camera_size");
    expect_error(replaced("camera_size: [ 1600, 1200 ]", "camera_size: \"big\""), "camera_size");
    expect_error("%YAML:1.0\n---\nR: [1, 2\n", "");
    expect_error("not yaml at all {{{", "");
    EXPECT_THROW(read_calibration(directory + "/absent.yml"), Error);
}

TEST(CalibrationFile, ForeignFormatsAreRead) {
    PICOSCAN_REQUIRE_DATASETS();
    const Calibration slmaster = read_calibration(test_support::datasets_dir() + "/slmaster-sinuscgc/monocularCamera/caliInfo.yml");
    EXPECT_EQ(slmaster.camera_size, cv::Size(1280, 1024));
    EXPECT_NEAR(cv::norm(slmaster.T), 109, 2);
    const Calibration slstudio = read_calibration(test_support::datasets_dir() + "/slstudio-skull/calibration/calibration.xml");
    EXPECT_EQ(slstudio.camera_size, cv::Size(1688, 1352));
    EXPECT_EQ(slstudio.projector_size, cv::Size(1824, 1140));
    EXPECT_NEAR(slstudio.camera_matrix(0, 0), 2195.12, 0.01);
}

TEST(CalibrationFile, WindowsLineEndingsAndTrailingSpacesAreRead) {
    const std::string directory = test_support::make_temp_dir("crlf");
    write_calibration(seed_rig_calibration(), directory + "/calibration.yml");
    std::ifstream in(directory + "/calibration.yml");
    std::string line, converted;
    while (std::getline(in, line)) converted += line + "  \r\n";
    std::ofstream(directory + "/crlf.yml") << converted;
    const Calibration read = read_calibration(directory + "/crlf.yml");
    EXPECT_EQ(cv::norm(cv::Mat(read.camera_matrix), cv::Mat(seed_rig_calibration().camera_matrix), cv::NORM_INF), 0.0);
}
