#include "picoscan/error.h"
#include "picoscan/patterns.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

using namespace picoscan;
namespace fs = std::filesystem;

namespace {

int count_kind(const PatternSequence& sequence, FrameKind kind, Axis axis) {
    int count = 0;
    for (const Frame& frame : sequence.frames) count += frame.kind == kind && frame.axis == axis;
    return count;
}

int decode_column_gray(const PatternSequence& sequence, int x) {
    int code = 0, previous = 0;
    for (int bit = 0; bit < sequence.columns.gray_bits; ++bit) {
        Frame frame{"", FrameKind::Gray, Axis::Columns, bit, 0};
        const int gray_bit = render_pattern(sequence, frame).at<uint8_t>(0, x) > 127;
        previous ^= gray_bit;
        code = code * 2 + previous;
    }
    return code;
}

}  // namespace

TEST(Patterns, BitCountsFollowProjectorSize) {
    EXPECT_EQ(gray_bits_for(854), 10);
    EXPECT_EQ(gray_bits_for(480), 9);
    EXPECT_EQ(gray_bits_for(1024), 10);
    EXPECT_EQ(gray_bits_for(1025), 11);
    const PatternSequence sequence = make_pattern_sequence({});
    EXPECT_EQ(sequence.columns.gray_bits, 10);
    EXPECT_EQ(sequence.rows.gray_bits, 9);
    EXPECT_EQ(sequence.frames.size(), size_t(2 + 2 * (10 + 9) + 2 * 24));
    EXPECT_EQ(count_kind(sequence, FrameKind::GrayInverse, Axis::Columns), 10);
    EXPECT_EQ(count_kind(sequence, FrameKind::Phase, Axis::Rows), 24);
    EXPECT_DOUBLE_EQ(sequence.columns.period_px, 16.0);
}

TEST(Patterns, NoRowsAndOptions) {
    PatternOptions options;
    options.rows = false;
    options.shifts = 4;
    options.period_bits = 5;
    const PatternSequence sequence = make_pattern_sequence(options);
    EXPECT_FALSE(sequence.rows.used());
    EXPECT_EQ(sequence.frames.size(), size_t(2 + 2 * 10 + 4));
    EXPECT_DOUBLE_EQ(sequence.columns.period_px, 32.0);
}

TEST(Patterns, BadOptionsAreRejectedWithTheParameterName) {
    PatternOptions options;
    options.shifts = 2;
    try {
        make_pattern_sequence(options);
        FAIL() << "accepted 2 shifts";
    } catch (const Error& error) {
        EXPECT_EQ(error.subject(), "--shifts");
    }
    options.shifts = 24;
    options.period_bits = 12;
    EXPECT_THROW(make_pattern_sequence(options), Error);
    options.period_bits = 4;
    options.projector_size = {0, 480};
    EXPECT_THROW(make_pattern_sequence(options), Error);
}

TEST(Patterns, GrayCodeGivesEveryColumnItsOwnCodeAndNeighboursDifferInOneBit) {
    const PatternSequence sequence = make_pattern_sequence({});
    for (int x = 0; x < 854; ++x) ASSERT_EQ(decode_column_gray(sequence, x), x);
    for (int x = 1; x < 854; ++x) {
        int changed = 0;
        for (int bit = 0; bit < 10; ++bit) {
            const cv::Mat image = render_pattern(sequence, {"", FrameKind::Gray, Axis::Columns, bit, 0});
            changed += image.at<uint8_t>(0, x) != image.at<uint8_t>(0, x - 1);
        }
        ASSERT_EQ(changed, 1) << "columns " << x - 1 << " and " << x;
    }
}

TEST(Patterns, InverseIsTheComplementAndPhaseFollowsTheModel) {
    const PatternSequence sequence = make_pattern_sequence({});
    const cv::Mat pattern = render_pattern(sequence, {"", FrameKind::Gray, Axis::Rows, 3, 0});
    const cv::Mat inverse = render_pattern(sequence, {"", FrameKind::GrayInverse, Axis::Rows, 3, 0});
    EXPECT_EQ(cv::countNonZero(pattern + inverse != 255), 0);
    const cv::Mat phase = render_pattern(sequence, {"", FrameKind::Phase, Axis::Columns, 0, 5});
    for (int x = 0; x < 854; x += 7) {
        const double expected = 127.5 + 127.5 * std::cos(2 * M_PI * x / 16.0 - 2 * M_PI * 5 / 24.0);
        EXPECT_NEAR(phase.at<uint8_t>(100, x), expected, 0.5 + 1e-9);
    }
    const cv::Mat row_phase = render_pattern(sequence, {"", FrameKind::Phase, Axis::Rows, 0, 0});
    EXPECT_EQ(row_phase.at<uint8_t>(8, 0), row_phase.at<uint8_t>(8, 853));
    EXPECT_EQ(row_phase.at<uint8_t>(0, 10), 255);
}

TEST(Patterns, ResponseTableIsApplied) {
    const PatternSequence sequence = make_pattern_sequence({});
    cv::Mat lut(1, 256, CV_8U);
    for (int level = 0; level < 256; ++level) lut.at<uint8_t>(level) = uint8_t(255 - level);
    const cv::Mat white = render_pattern(sequence, sequence.frames[0], lut);
    EXPECT_EQ(cv::countNonZero(white), 0);
}

TEST(Patterns, ForeignSequencesHaveTheirSystemsOrder) {
    const PatternSequence opencv = make_opencv_graycode_sequence({1280, 800}, "pattern_cam1_im", ".jpg", 1);
    ASSERT_EQ(opencv.frames.size(), 44u);
    EXPECT_EQ(opencv.frames[0].file, "pattern_cam1_im1.jpg");
    EXPECT_EQ(opencv.frames[1].kind, FrameKind::GrayInverse);
    EXPECT_EQ(opencv.frames[22].axis, Axis::Rows);
    EXPECT_EQ(opencv.frames[42].kind, FrameKind::White);
    EXPECT_EQ(opencv.frames[43].kind, FrameKind::Black);

    const PatternSequence slstudio = make_slstudio_gray_sequence({1824, 1140}, 10);
    ASSERT_EQ(slstudio.frames.size(), 12u);
    EXPECT_EQ(slstudio.frames[2].file, "frameSeq_02.bmp");
    EXPECT_DOUBLE_EQ(slstudio.columns.gray_unit_px, 2.0);

    const PatternSequence slmaster = make_slmaster_cgc_sequence({1920, 1080}, 12, 32);
    ASSERT_EQ(slmaster.frames.size(), 18u);
    EXPECT_DOUBLE_EQ(slmaster.columns.period_px, 60.0);
    EXPECT_EQ(slmaster.columns.gray_bits, 6);
    EXPECT_EQ(slmaster.frames[12].kind, FrameKind::Gray);
    // The complementary code's last image has 30 px blocks following the reflected Gray sequence.
    const cv::Mat last = render_pattern(slmaster, slmaster.frames[17]);
    EXPECT_EQ(last.at<uint8_t>(0, 0), 0);
    EXPECT_EQ(last.at<uint8_t>(0, 30), 255);
    EXPECT_EQ(last.at<uint8_t>(0, 60), 255);
    EXPECT_EQ(last.at<uint8_t>(0, 90), 0);
}

TEST(Manifest, RoundTripsEverySequence) {
    const std::string directory = test_support::make_temp_dir("manifest");
    for (const PatternSequence& sequence :
         {make_pattern_sequence({}), make_opencv_graycode_sequence({1280, 800}, "a", ".jpg", 1),
          make_slmaster_cgc_sequence({1920, 1080}, 12, 32)}) {
        const std::string path = directory + "/sequence.json";
        write_manifest(sequence, path);
        const PatternSequence read = read_manifest(path);
        EXPECT_EQ(read.origin, sequence.origin);
        EXPECT_EQ(read.projector_size, sequence.projector_size);
        EXPECT_EQ(read.columns.gray_bits, sequence.columns.gray_bits);
        EXPECT_DOUBLE_EQ(read.columns.phase_offset_rad, sequence.columns.phase_offset_rad);
        EXPECT_EQ(read.rows.shifts, sequence.rows.shifts);
        ASSERT_EQ(read.frames.size(), sequence.frames.size());
        for (size_t index = 0; index < read.frames.size(); ++index) {
            EXPECT_EQ(read.frames[index].file, sequence.frames[index].file);
            EXPECT_EQ(read.frames[index].kind, sequence.frames[index].kind);
            EXPECT_EQ(read.frames[index].axis, sequence.frames[index].axis);
            EXPECT_EQ(read.frames[index].bit, sequence.frames[index].bit);
            EXPECT_EQ(read.frames[index].shift, sequence.frames[index].shift);
        }
    }
}

TEST(Manifest, BadManifestsNameTheFileAndTheKey) {
    const std::string directory = test_support::make_temp_dir("badmanifest");
    const std::string path = directory + "/sequence.json";
    write_manifest(make_pattern_sequence({}), path);
    std::ifstream in(path);
    const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    auto expect_error = [&](std::string text, const std::string& expected) {
        std::ofstream(path) << text;
        try {
            read_manifest(path);
            ADD_FAILURE() << "accepted: " << expected;
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << error.what();
            EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
        }
    };
    auto replaced = [&](const std::string& from, const std::string& to) {
        std::string text = good;
        text.replace(text.find(from), from.size(), to);
        return text;
    };
    expect_error(replaced("\"projector_width\"", "\"projector_wide\""), "projector_width");
    expect_error(replaced("\"kind\": \"white\"", "\"kind\": \"purple\""), "unknown kind");
    expect_error(replaced("\"gray_bits\": 10", "\"gray_bits\": \"ten\""), "columns.gray_bits");
    expect_error("{ not json", "JSON");
    expect_error("", "");
    EXPECT_THROW(read_manifest(directory + "/absent.json"), Error);
}

TEST(Manifest, WritePatternImagesWritesEveryFrame) {
    const std::string directory = test_support::make_temp_dir("patterns");
    PatternOptions options;
    options.projector_size = {64, 32};
    options.shifts = 3;
    const PatternSequence sequence = make_pattern_sequence(options);
    write_pattern_images(sequence, directory);
    for (const Frame& frame : sequence.frames) {
        const cv::Mat image = cv::imread(directory + "/" + frame.file, cv::IMREAD_UNCHANGED);
        ASSERT_FALSE(image.empty()) << frame.file;
        EXPECT_EQ(image.type(), CV_8UC1);
        EXPECT_EQ(cv::norm(image, render_pattern(sequence, frame), cv::NORM_INF), 0.0) << frame.file;
    }
    EXPECT_TRUE(fs::exists(directory + "/sequence.json"));
    size_t files = 0;
    for (const auto& entry : fs::directory_iterator(directory)) files += entry.is_regular_file();
    EXPECT_EQ(files, sequence.frames.size() + 1) << "stray temporary files left behind";
}
