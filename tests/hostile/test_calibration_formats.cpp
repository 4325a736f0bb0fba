// Calibration files written as YAML, XML and JSON (by the --out extension) read back exactly
// with PicoScan's strict reader, and malformed instances of each are refused naming the file.
#include "picoscan/calibration.h"
#include "picoscan/error.h"
#include "picoscan/simulate.h"
#include "picoscan/stereo.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace picoscan;

namespace {

void expect_same(const cv::Mat& a, const cv::Mat& b, const std::string& what) {
    ASSERT_EQ(a.total(), b.total()) << what;
    cv::Mat a64, b64;
    a.convertTo(a64, CV_64F);
    b.convertTo(b64, CV_64F);
    EXPECT_EQ(cv::norm(a64.reshape(1, 1), b64.reshape(1, 1), cv::NORM_INF), 0.0) << what;
}

// A rig whose numbers have many digits and a measured projector response.
Calibration awkward_rig() {
    Calibration rig = seed_rig_calibration();
    rig.camera_matrix(0, 1) = 0.123456789012345;  // skew
    rig.camera_distortion = (cv::Mat_<double>(1, 14) << -0.0812345678901234, 0.1, 5e-4, -3e-4, 1e-7, 0.01, 0.02, 0.03,
                             1e-3, 2e-3, 3e-3, 4e-3, 0, 0);
    rig.T = {149.99999999999997, -0.1, 1.0 / 3.0};
    rig.projector_inverse_response = cv::Mat(1, 256, CV_8U);
    for (int level = 0; level < 256; ++level) rig.projector_inverse_response.at<uint8_t>(level) = uint8_t(255 - level / 2);
    return rig;
}

TEST(CalibrationFormats, EveryOutExtensionReadsBackExactly) {
    const fs::path folder = test_support::make_temp_dir("calibration-formats");
    const Calibration rig = awkward_rig();
    for (const char* extension : {".yml", ".yaml", ".xml", ".json", ".JSON"}) {
        SCOPED_TRACE(extension);
        const fs::path path = folder / (std::string("rig") + extension);
        write_calibration(rig, path.string());
        const std::string text = test_support::read_file_bytes(path);
        const std::string ext = extension;
        const char first = text[text.find_first_not_of(" \r\n")];
        EXPECT_EQ(first, ext == ".xml" ? '<' : (ext == ".json" || ext == ".JSON") ? '{' : '%') << "written in the wrong format";
        const Calibration back = read_calibration(path.string());
        EXPECT_EQ(back.camera_size, rig.camera_size);
        EXPECT_EQ(back.projector_size, rig.projector_size);
        expect_same(cv::Mat(back.camera_matrix), cv::Mat(rig.camera_matrix), "camera_matrix");
        expect_same(cv::Mat(back.projector_matrix), cv::Mat(rig.projector_matrix), "projector_matrix");
        expect_same(back.camera_distortion, rig.camera_distortion, "camera_distortion");
        expect_same(back.projector_distortion, rig.projector_distortion, "projector_distortion");
        expect_same(cv::Mat(back.R), cv::Mat(rig.R), "R");
        expect_same(cv::Mat(back.T), cv::Mat(rig.T), "T");
        expect_same(back.projector_inverse_response, rig.projector_inverse_response, "projector_inverse_response");
    }
}

TEST(CalibrationFormats, StereoFileReadsBackFromEveryFormat) {
    const fs::path folder = test_support::make_temp_dir("stereo-formats");
    Calibration second = awkward_rig();
    second.T = {-150, 0.5, 2};
    const StereoCalibration stereo = stereo_from_projector_calibrations(awkward_rig(), second);
    for (const char* extension : {".yml", ".xml", ".json"}) {
        SCOPED_TRACE(extension);
        const fs::path path = folder / (std::string("stereo") + extension);
        write_stereo_calibration(stereo, path.string());
        ASSERT_EQ(calibration_kind(path.string()), CalibrationKind::Stereo);
        const StereoCalibration back = read_stereo_calibration(path.string());
        EXPECT_EQ(back.left_size, stereo.left_size);
        expect_same(cv::Mat(back.right_matrix), cv::Mat(stereo.right_matrix), "camera2_matrix");
        expect_same(back.right_distortion, stereo.right_distortion, "camera2_distortion");
        expect_same(cv::Mat(back.R), cv::Mat(stereo.R), "R");
        expect_same(cv::Mat(back.T), cv::Mat(stereo.T), "T");
    }
}

// Malformed JSON calibrations: each is refused, the error names the file (and the line).
TEST(CalibrationFormats, MalformedJsonIsRefusedNamingTheFile) {
    const fs::path folder = test_support::make_temp_dir("calibration-json-bad");
    const fs::path good = folder / "good.json";
    write_calibration(seed_rig_calibration(), good.string());
    const std::string text = test_support::read_file_bytes(good);
    auto replaced = [&](const std::string& from, const std::string& to) {
        std::string copy = text;
        const size_t at = copy.find(from);
        EXPECT_NE(at, std::string::npos) << from;
        return at == std::string::npos ? copy : copy.replace(at, from.size(), to);
    };
    const std::vector<std::pair<std::string, std::string>> cases{
        {"unclosed object", text.substr(0, text.rfind('}'))},
        {"nested map", replaced("\"camera_size\": [", "\"camera_size\": {\"a\": 1}, \"x\": [")},
        {"text after the end", text + "{}"},
        {"unclosed list", replaced("\"camera_size\": [ 1600, 1200 ]", "\"camera_size\": [ 1600, 1200")},
        {"a word in a list", replaced("\"camera_size\": [ 1600, 1200 ]", "\"camera_size\": [ 1600, \"x\" ]")},
        {"duplicate key", replaced("\"camera_size\"", "\"R\": 1, \"R\"")},
        {"matrix data short", replaced("\"rows\": 3", "\"rows\": 4")},
        {"deep nesting", "{\"camera_size\": " + std::string(100000, '[') + std::string(100000, ']') + "}"},
    };
    for (const auto& [name, bad] : cases) {
        SCOPED_TRACE(name);
        const fs::path path = folder / "bad.json";
        std::ofstream(path, std::ios::binary) << bad;
        try {
            read_calibration(path.string());
            ADD_FAILURE() << "accepted";
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find(path.string()), std::string::npos) << error.what();
        }
    }
}

TEST(CalibrationFormats, TiltedSensorTermsNameTheFileAndKey) {
    const fs::path folder = test_support::make_temp_dir("calibration-tilt");
    Calibration rig = seed_rig_calibration();
    rig.projector_distortion = cv::Mat::zeros(1, 14, CV_64F);
    const fs::path path = folder / "tilted.yml";
    write_calibration(rig, path.string());
    std::string text = test_support::read_file_bytes(path);
    // The last two projector coefficients (tau_x, tau_y) made non-zero in the file.
    const size_t data = text.find("data", text.find("projector_distortion"));
    const size_t close = text.find(']', data);
    const size_t last_comma = text.rfind(',', close);
    text.replace(last_comma + 1, close - last_comma - 1, " 1.0e-02 ");
    std::ofstream(path, std::ios::binary) << text;
    try {
        read_calibration(path.string());
        FAIL() << "a tilted sensor was accepted";
    } catch (const Error& error) {
        const std::string message = error.what();
        EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
        EXPECT_NE(message.find("'projector_distortion'"), std::string::npos) << message;
        EXPECT_NE(message.find("tilted-sensor"), std::string::npos) << message;
    }
}

}  // namespace
