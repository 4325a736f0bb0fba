// Pattern sequences: PicoScan's own and those of other systems, and their rendering.
#include "picoscan/patterns.h"

#include "picoscan/error.h"

#include <opencv2/core.hpp>

#include <cmath>
#include <cstdio>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string frame_name(int index, const std::string& description) {
    char prefix[16];
    std::snprintf(prefix, sizeof prefix, "%03d_", index);
    return prefix + description + ".png";
}

std::string two_digits(int value) {
    char text[16];
    std::snprintf(text, sizeof text, "%02d", value);
    return text;
}

void add_axis_frames(PatternSequence& sequence, Axis axis, bool with_inverses) {
    const AxisCode& code = sequence.code(axis);
    const std::string axis_name = axis == Axis::Columns ? "col" : "row";
    for (int bit = 0; bit < code.gray_bits; ++bit) {
        const int index = static_cast<int>(sequence.frames.size());
        sequence.frames.push_back({frame_name(index, axis_name + "_gray" + two_digits(bit)), FrameKind::Gray, axis, bit, 0});
        if (with_inverses)
            sequence.frames.push_back({frame_name(index + 1, axis_name + "_gray" + two_digits(bit) + "_inv"),
                                       FrameKind::GrayInverse, axis, bit, 0});
    }
    for (int shift = 0; shift < code.shifts; ++shift) {
        const int index = static_cast<int>(sequence.frames.size());
        sequence.frames.push_back({frame_name(index, axis_name + "_phase" + two_digits(shift)), FrameKind::Phase, axis, 0, shift});
    }
}

}  // namespace

int gray_bits_for(int pixels) {
    int bits = 1;
    while ((1LL << bits) < pixels) ++bits;
    return bits;
}

PatternSequence make_pattern_sequence(const PatternOptions& options) {
    const cv::Size size = options.projector_size;
    if (size.width < 2 || size.height < 2 || size.width > 16384 || size.height > 16384)
        throw Error("--projector", "projector size must be between 2x2 and 16384x16384, got " +
                                       std::to_string(size.width) + "x" + std::to_string(size.height));
    if (options.shifts < 3 || options.shifts > 64)
        throw Error("--shifts", "phase shifts must be 3..64, got " + std::to_string(options.shifts));
    const int smallest_side = options.rows ? std::min(size.width, size.height) : size.width;
    if (options.period_bits < 1 || (1 << options.period_bits) > smallest_side)
        throw Error("--period-bits", "fringe period 2^N must be 2.." + std::to_string(smallest_side) +
                                         " projector pixels, got N=" + std::to_string(options.period_bits));

    PatternSequence sequence;
    sequence.projector_size = size;
    sequence.origin = "picoscan";
    auto make_code = [&](int pixels) {
        AxisCode code;
        code.gray_bits = gray_bits_for(pixels);
        code.gray_unit_px = 1.0;
        code.shifts = options.shifts;
        code.period_px = double(1 << options.period_bits);
        code.phase_offset_rad = 0.0;
        code.shift_sign = -1;  // fringes move towards +x (or +y) as the shift index grows
        return code;
    };
    sequence.columns = make_code(size.width);
    if (options.rows) sequence.rows = make_code(size.height);

    sequence.frames.push_back({frame_name(0, "white"), FrameKind::White, Axis::Columns, 0, 0});
    sequence.frames.push_back({frame_name(1, "black"), FrameKind::Black, Axis::Columns, 0, 0});
    add_axis_frames(sequence, Axis::Columns, true);
    if (options.rows) add_axis_frames(sequence, Axis::Rows, true);
    return sequence;
}

PatternSequence make_opencv_graycode_sequence(cv::Size projector_size, const std::string& prefix,
                                              const std::string& suffix, int first_index) {
    PatternSequence sequence;
    sequence.projector_size = projector_size;
    sequence.origin = "opencv-graycode";
    sequence.columns.gray_bits = gray_bits_for(projector_size.width);
    sequence.rows.gray_bits = gray_bits_for(projector_size.height);
    int index = first_index;
    auto file = [&]() { return prefix + std::to_string(index++) + suffix; };
    for (Axis axis : {Axis::Columns, Axis::Rows}) {
        for (int bit = 0; bit < sequence.code(axis).gray_bits; ++bit) {
            sequence.frames.push_back({file(), FrameKind::Gray, axis, bit, 0});
            sequence.frames.push_back({file(), FrameKind::GrayInverse, axis, bit, 0});
        }
    }
    sequence.frames.push_back({file(), FrameKind::White, Axis::Columns, 0, 0});
    sequence.frames.push_back({file(), FrameKind::Black, Axis::Columns, 0, 0});
    return sequence;
}

PatternSequence make_slstudio_gray_sequence(cv::Size projector_size, int bits) {
    const int full_bits = gray_bits_for(projector_size.width);
    if (bits < 1 || bits > full_bits)
        throw Error("bits", "SLStudio Gray code needs 1.." + std::to_string(full_bits) + " bits");
    PatternSequence sequence;
    sequence.projector_size = projector_size;
    sequence.origin = "slstudio-gray";
    sequence.columns.gray_bits = bits;
    sequence.columns.gray_unit_px = double(1 << (full_bits - bits));  // unprojected low bits widen the stripes
    int index = 0;
    auto file = [&]() { return "frameSeq_" + two_digits(index++) + ".bmp"; };
    sequence.frames.push_back({file(), FrameKind::White, Axis::Columns, 0, 0});
    sequence.frames.push_back({file(), FrameKind::Black, Axis::Columns, 0, 0});
    for (int bit = 0; bit < bits; ++bit) sequence.frames.push_back({file(), FrameKind::Gray, Axis::Columns, bit, 0});
    return sequence;
}

PatternSequence make_slstudio_phase_cue_sequence(cv::Size projector_size, int periods) {
    if (periods < 2 || periods > 256) throw Error("periods", "SLStudio phase sequences need 2..256 periods");
    PatternSequence sequence;
    sequence.projector_size = projector_size;
    sequence.origin = "slstudio-phase-cue";
    int index = 0;
    auto file = [&]() { return "frameSeq_" + two_digits(index++) + ".bmp"; };
    for (Axis axis : {Axis::Columns, Axis::Rows}) {
        AxisCode& code = axis == Axis::Columns ? sequence.columns : sequence.rows;
        const double length = axis == Axis::Columns ? projector_size.width : projector_size.height;
        code.shifts = 3;
        code.period_px = length / periods;
        code.shift_sign = -1;  // I = 0.5 (1 + cos(2 pi x / pitch - shift))
        code.cue_shifts = 3;
        code.cue_period_px = length;
        for (int shift = 0; shift < 3; ++shift) sequence.frames.push_back({file(), FrameKind::Phase, axis, 0, shift});
        for (int shift = 0; shift < 3; ++shift) sequence.frames.push_back({file(), FrameKind::Cue, axis, 0, shift});
    }
    return sequence;
}

PatternSequence make_slmaster_cgc_sequence(cv::Size projector_size, int shifts, int periods) {
    int period_bits = 0;
    while ((1 << period_bits) < periods) ++period_bits;
    if (periods < 2 || (1 << period_bits) != periods || projector_size.width % (2 * periods) != 0)
        throw Error("periods", "SLMaster CGC needs a power-of-two period count dividing the width twice");
    PatternSequence sequence;
    sequence.projector_size = projector_size;
    sequence.origin = "slmaster-cgc";
    AxisCode& code = sequence.columns;
    code.shifts = shifts;
    code.period_px = double(projector_size.width) / periods;
    code.phase_offset_rad = -kPi;  // I = 127.5 + 127.5 cos(2 pi x / P - pi + 2 pi k / K)
    code.shift_sign = 1;
    code.gray_bits = period_bits + 1;  // the extra complementary bit splits each period in two
    code.gray_unit_px = code.period_px / 2;
    int index = 0;
    auto file = [&]() { return std::to_string(index++) + ".bmp"; };
    for (int shift = 0; shift < shifts; ++shift) sequence.frames.push_back({file(), FrameKind::Phase, Axis::Columns, 0, shift});
    for (int bit = 0; bit < code.gray_bits; ++bit) sequence.frames.push_back({file(), FrameKind::Gray, Axis::Columns, bit, 0});
    return sequence;
}

cv::Mat render_pattern(const PatternSequence& sequence, const Frame& frame, const cv::Mat& response_lut) {
    const cv::Size size = sequence.projector_size;
    cv::Mat image(size, CV_8U);
    const AxisCode& code = sequence.code(frame.axis);
    const bool along_columns = frame.axis == Axis::Columns;
    const int length = along_columns ? size.width : size.height;

    // Levels along the coding axis; the image repeats them across the other axis.
    std::vector<uint8_t> levels(length);
    for (int x = 0; x < length; ++x) {
        switch (frame.kind) {
        case FrameKind::White: levels[x] = 255; break;
        case FrameKind::Black: levels[x] = 0; break;
        case FrameKind::Gray:
        case FrameKind::GrayInverse: {
            const long code_value = static_cast<long>(std::floor(x / code.gray_unit_px));
            const long gray = code_value ^ (code_value >> 1);
            const bool on = (gray >> (code.gray_bits - 1 - frame.bit)) & 1;
            levels[x] = (on != (frame.kind == FrameKind::GrayInverse)) ? 255 : 0;
            break;
        }
        case FrameKind::Phase:
        case FrameKind::Cue: {
            const bool cue = frame.kind == FrameKind::Cue;
            const double phase = 2 * kPi * x / (cue ? code.cue_period_px : code.period_px) + code.phase_offset_rad +
                                 code.shift_sign * 2 * kPi * frame.shift / (cue ? code.cue_shifts : code.shifts);
            levels[x] = cv::saturate_cast<uint8_t>(std::lround(127.5 + 127.5 * std::cos(phase)));
            break;
        }
        }
    }
    if (!response_lut.empty()) {
        if (response_lut.total() != 256 || response_lut.type() != CV_8U)
            throw Error("response_lut", "projector response table must be 256 CV_8U entries");
        for (auto& level : levels) level = response_lut.at<uint8_t>(level);
    }
    for (int y = 0; y < size.height; ++y) {
        auto* row = image.ptr<uint8_t>(y);
        if (along_columns)
            std::copy(levels.begin(), levels.end(), row);
        else
            std::fill(row, row + size.width, levels[y]);
    }
    return image;
}

std::string to_string(FrameKind kind) {
    switch (kind) {
    case FrameKind::White: return "white";
    case FrameKind::Black: return "black";
    case FrameKind::Gray: return "gray";
    case FrameKind::GrayInverse: return "gray_inverse";
    case FrameKind::Phase: return "phase";
    case FrameKind::Cue: return "cue";
    }
    return "?";
}

std::string to_string(Axis axis) { return axis == Axis::Columns ? "columns" : "rows"; }

}  // namespace picoscan
