#include "picoscan/decode.h"
#include "picoscan/error.h"
#include "picoscan/patterns.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

using namespace picoscan;

namespace {

// A camera whose pixel (x, y) sees projector column u(x) and row v(y); frames are rendered
// from the pattern model directly, so the true correspondence is known exactly.
struct SyntheticView {
    cv::Size camera_size{400, 60};
    std::function<double(int)> u_of_x = [](int x) { return 100.3 + 0.77 * x; };
    std::function<double(int)> v_of_y = [](int y) { return 50.6 + 1.3 * y; };
    double dark = 20, bright = 200;  // camera levels for projector black and white
    double noise = 0;
    int depth = CV_8U;
};

CaptureSet render(const PatternSequence& sequence, const SyntheticView& view) {
    CaptureSet captures;
    captures.sequence = sequence;
    std::mt19937 random(7);
    std::normal_distribution<double> unit_noise;  // scaled: its deviation must be positive, and view.noise may be 0
    const auto noise = [&](auto& engine) { return view.noise * unit_noise(engine); };
    const double scale = view.depth == CV_16U ? 257.0 : 1.0;
    for (const Frame& frame : sequence.frames) {
        const cv::Mat pattern = render_pattern(sequence, frame);
        const AxisCode& code = sequence.code(frame.axis);
        cv::Mat image(view.camera_size, view.depth);
        for (int y = 0; y < image.rows; ++y)
            for (int x = 0; x < image.cols; ++x) {
                const double u = view.u_of_x(x), v = view.v_of_y(y);
                double level;
                if (frame.kind == FrameKind::Phase) {
                    const double position = frame.axis == Axis::Columns ? u : v;
                    level = 0.5 + 0.5 * std::cos(2 * M_PI * position / code.period_px + code.phase_offset_rad +
                                                 code.shift_sign * 2 * M_PI * frame.shift / code.shifts);
                } else {
                    const int px = std::clamp(int(std::lround(u)), 0, pattern.cols - 1);
                    const int py = std::clamp(int(std::lround(v)), 0, pattern.rows - 1);
                    level = pattern.at<uint8_t>(py, px) / 255.0;
                }
                const double value = (view.dark + (view.bright - view.dark) * level + (view.noise > 0 ? noise(random) : 0)) * scale;
                if (view.depth == CV_16U) image.at<uint16_t>(y, x) = cv::saturate_cast<uint16_t>(value);
                else image.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(value);
            }
        captures.images.push_back(image);
    }
    return captures;
}

PatternSequence small_sequence(int shifts = 8) {
    PatternOptions options;
    options.projector_size = {854, 480};
    options.shifts = shifts;
    return make_pattern_sequence(options);
}

}  // namespace

TEST(Decode, HybridRecoversSubPixelColumnsAndRows) {
    const SyntheticView view;
    const CorrespondenceMap map = decode(render(small_sequence(), view));
    double worst_u = 0, worst_v = 0;
    for (int y = 0; y < view.camera_size.height; ++y)
        for (int x = 0; x < view.camera_size.width; ++x) {
            ASSERT_EQ(map.status.at<uint8_t>(y, x), kValid) << x << "," << y;
            worst_u = std::max(worst_u, std::abs(map.projector_u.at<float>(y, x) - view.u_of_x(x)));
            worst_v = std::max(worst_v, std::abs(map.projector_v.at<float>(y, x) - view.v_of_y(y)));
        }
    // Quantisation of 8-bit camera levels alone limits the phase to a few hundredths of a pixel.
    EXPECT_LT(worst_u, 0.03);
    EXPECT_LT(worst_v, 0.03);
    EXPECT_EQ(cv::countNonZero(map.mask), view.camera_size.area());
}

TEST(Decode, BinaryOnlyGivesTheStripeCentre) {
    const SyntheticView view;
    DecodeOptions options;
    options.binary_only = true;
    const CorrespondenceMap map = decode(render(small_sequence(), view), options);
    for (int x = 0; x < view.camera_size.width; ++x)
        ASSERT_NEAR(map.projector_u.at<float>(5, x), std::lround(view.u_of_x(x)), 1e-6) << x;
}

TEST(Decode, GrayCodeErrorsAtFringeEdgesAreCorrectedByThePhase) {
    // The Gray code is read one projector pixel off (e.g. blur, misregistration): the fringe
    // order is then wrong near every period edge, and the unwrapping must correct it.
    SyntheticView truth;
    const PatternSequence sequence = small_sequence();
    CaptureSet captures = render(sequence, truth);
    SyntheticView shifted = truth;
    shifted.u_of_x = [&](int x) { return truth.u_of_x(x) + 1.4; };
    const CaptureSet wrong_gray = render(sequence, shifted);
    for (size_t index = 0; index < sequence.frames.size(); ++index)
        if (sequence.frames[index].kind == FrameKind::Gray || sequence.frames[index].kind == FrameKind::GrayInverse)
            captures.images[index] = wrong_gray.images[index];
    const CorrespondenceMap map = decode(captures);
    EXPECT_GT(map.order_corrections, 0);
    for (int x = 0; x < truth.camera_size.width; ++x)
        ASSERT_NEAR(map.projector_u.at<float>(3, x), truth.u_of_x(x), 0.03) << x;
}

TEST(Decode, SixteenBitImagesDecodeLikeEightBit) {
    SyntheticView view;
    view.depth = CV_16U;
    const CorrespondenceMap map = decode(render(small_sequence(), view));
    for (int x = 0; x < view.camera_size.width; x += 3)
        ASSERT_NEAR(map.projector_u.at<float>(10, x), view.u_of_x(x), 0.01) << x;
}

TEST(Decode, NoisyCapturesStayWithinTheTheoreticalPhaseNoise) {
    SyntheticView view;
    view.noise = 1.0;
    view.camera_size = {400, 200};
    const CorrespondenceMap map = decode(render(small_sequence(24), view));
    double sum_squares = 0;
    int count = 0;
    for (int y = 0; y < view.camera_size.height; ++y)
        for (int x = 0; x < view.camera_size.width; ++x) {
            const float u = map.projector_u.at<float>(y, x);
            ASSERT_TRUE(std::isfinite(u));
            sum_squares += std::pow(u - view.u_of_x(x), 2);
            ++count;
        }
    // sigma_phase = sigma / B * sqrt(2 / K) rad; B = 90 DN, K = 24, period 16 px.
    const double expected = 1.0 / 90 * std::sqrt(2.0 / 24) / (2 * M_PI) * 16;
    const double measured = std::sqrt(sum_squares / count);
    EXPECT_LT(measured, 1.5 * expected);
    EXPECT_GT(measured, 0.5 * expected);
}

TEST(Decode, DarkSaturatedAndUndecidedPixelsAreMarkedNotGuessed) {
    SyntheticView view;
    const PatternSequence sequence = small_sequence();
    CaptureSet captures = render(sequence, view);
    for (cv::Mat& image : captures.images) {
        image(cv::Rect(0, 0, 10, 60)).setTo(30);  // shadow: no contrast
    }
    captures.images[0](cv::Rect(20, 0, 10, 60)).setTo(255);  // white frame saturated
    // Two Gray bits equal to their inverses: undecidable (one weak bit is a stripe edge).
    captures.images[4](cv::Rect(40, 0, 10, 60)).setTo(100);
    captures.images[5](cv::Rect(40, 0, 10, 60)).setTo(100);
    captures.images[6](cv::Rect(40, 0, 10, 60)).setTo(100);
    captures.images[7](cv::Rect(40, 0, 10, 60)).setTo(100);
    const CorrespondenceMap map = decode(captures);
    EXPECT_EQ(map.status.at<uint8_t>(30, 5), kDark);
    EXPECT_EQ(map.status.at<uint8_t>(30, 25), kSaturated);
    EXPECT_EQ(map.status.at<uint8_t>(30, 45), kUndecidedBit);
    EXPECT_TRUE(std::isnan(map.projector_u.at<float>(30, 5)));
    EXPECT_EQ(map.mask.at<uint8_t>(30, 45), 0);
    EXPECT_EQ(map.status.at<uint8_t>(30, 100), kValid);
}

TEST(Decode, LowModulationIsRejected) {
    SyntheticView view;
    const PatternSequence sequence = small_sequence();
    CaptureSet captures = render(sequence, view);
    for (size_t index = 0; index < sequence.frames.size(); ++index)
        if (sequence.frames[index].kind == FrameKind::Phase && sequence.frames[index].axis == Axis::Columns)
            captures.images[index](cv::Rect(200, 0, 10, 60)).setTo(110);
    const CorrespondenceMap map = decode(captures);
    EXPECT_EQ(map.status.at<uint8_t>(30, 205), kLowModulation);
}

TEST(Decode, ThresholdWithoutInversesAndWithoutWhiteBlack) {
    // SLStudio style: no inverses, threshold at (white + black) / 2.
    SyntheticView view;
    const PatternSequence slstudio = make_slstudio_gray_sequence({1824, 1140}, 10);
    const CorrespondenceMap map = decode(render(slstudio, view));
    for (int x = 0; x < view.camera_size.width; x += 5) {
        const double u = view.u_of_x(x);
        // 2 px stripes: the stripe centre lies within 0.5 px of every pixel it covers.
        ASSERT_NEAR(map.projector_u.at<float>(8, x), u, 1.0) << x;
    }
    // SLMaster style: no white/black frames; the fringe mean is the threshold.
    const PatternSequence slmaster = make_slmaster_cgc_sequence({1920, 1080}, 12, 32);
    SyntheticView wide;
    wide.u_of_x = [](int x) { return 30.2 + 4.7 * x; };
    const CorrespondenceMap hybrid = decode(render(slmaster, wide));
    for (int x = 0; x < wide.camera_size.width; ++x)
        ASSERT_NEAR(hybrid.projector_u.at<float>(8, x), wide.u_of_x(x), 0.05) << x;
}

TEST(Decode, AllDarkCapturesAreAnError) {
    SyntheticView view;
    CaptureSet captures = render(small_sequence(), view);
    captures.directory = "/some/scan";
    for (cv::Mat& image : captures.images) image.setTo(3);
    try {
        decode(captures);
        FAIL() << "decoded an all-dark capture";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("/some/scan"), std::string::npos);
        EXPECT_NE(std::string(error.what()).find("dark"), std::string::npos);
    }
}

TEST(Decode, MismatchedImagesAreAnError) {
    SyntheticView view;
    CaptureSet captures = render(small_sequence(), view);
    captures.images[7] = cv::Mat(10, 10, CV_8U, cv::Scalar(0));
    EXPECT_THROW(decode(captures), Error);
    captures.images.pop_back();
    EXPECT_THROW(decode(captures), Error);
}
