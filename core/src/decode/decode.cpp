// Gray code + phase-shift decoding with hybrid unwrapping.
#include "picoscan/decode.h"

#include "picoscan/error.h"

#include "common/parallel.h"
#include "common/progress_reporter.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Where each frame of one axis sits in the capture set.
struct AxisFrames {
    AxisCode code;
    std::vector<int> gray;          // per bit, frame index of the pattern
    std::vector<int> gray_inverse;  // per bit, frame index of the inverse or -1
    std::vector<int> phase;         // per shift, frame index
    std::vector<float> shift_cos, shift_sin;
    std::vector<int> cue;           // per cue shift, frame index
    std::vector<float> cue_cos, cue_sin;
    bool decode_phase = false;
};

struct Plan {
    int white = -1, black = -1;
    AxisFrames columns, rows;
    bool has_rows = false;
    float scale = 1.0f;  // thresholds are given for 8-bit levels
};

AxisFrames plan_axis(const PatternSequence& sequence, Axis axis, bool binary_only, const std::string& source) {
    AxisFrames frames;
    frames.code = sequence.code(axis);
    frames.gray.assign(frames.code.gray_bits, -1);
    frames.gray_inverse.assign(frames.code.gray_bits, -1);
    frames.phase.assign(frames.code.shifts, -1);
    frames.cue.assign(frames.code.cue_shifts, -1);
    for (size_t index = 0; index < sequence.frames.size(); ++index) {
        const Frame& frame = sequence.frames[index];
        if (frame.axis != axis) continue;
        if (frame.kind == FrameKind::Gray) frames.gray[frame.bit] = int(index);
        if (frame.kind == FrameKind::GrayInverse) frames.gray_inverse[frame.bit] = int(index);
        if (frame.kind == FrameKind::Phase) frames.phase[frame.shift] = int(index);
        if (frame.kind == FrameKind::Cue) frames.cue[frame.shift] = int(index);
    }
    const std::string axis_name = to_string(axis);
    for (int bit = 0; bit < frames.code.gray_bits; ++bit)
        if (frames.gray[bit] < 0)
            throw Error(source, "no frame for " + axis_name + " Gray bit " + std::to_string(bit));
    for (int shift = 0; shift < frames.code.shifts; ++shift)
        if (frames.phase[shift] < 0)
            throw Error(source, "no frame for " + axis_name + " phase shift " + std::to_string(shift));
    for (int shift = 0; shift < frames.code.cue_shifts; ++shift)
        if (frames.cue[shift] < 0)
            throw Error(source, "no frame for " + axis_name + " cue shift " + std::to_string(shift));
    if (frames.code.gray_bits == 0 && (frames.code.cue_shifts == 0 || frames.code.shifts == 0))
        throw Error(source, axis_name + " have neither a Gray code nor a phase cue to unwrap the fringes");
    if (frames.code.gray_bits == 0 && binary_only)
        throw Error(source, "binary-only decoding needs a Gray code, and the " + axis_name + " have none");
    frames.decode_phase = frames.code.shifts > 0 && !binary_only;
    auto shift_table = [&](int shifts, std::vector<float>& cosines, std::vector<float>& sines) {
        for (int shift = 0; shift < shifts; ++shift) {
            const double delta = frames.code.shift_sign * 2 * kPi * shift / shifts;
            cosines.push_back(float(std::cos(delta)));
            sines.push_back(float(std::sin(delta)));
        }
    };
    shift_table(frames.code.shifts, frames.shift_cos, frames.shift_sin);
    shift_table(frames.code.cue_shifts, frames.cue_cos, frames.cue_sin);
    return frames;
}

// Per-row scratch buffers, one set per worker chunk.
struct RowBuffers {
    std::vector<float> reference, contrast, brightest, sum_sin, sum_cos, sum, phase_fraction, modulation;
    std::vector<float> cue_fraction, cue_modulation;
    std::vector<uint32_t> weak_bits, code;
    explicit RowBuffers(int width)
        : reference(width), contrast(width), brightest(width), sum_sin(width), sum_cos(width), sum(width),
          phase_fraction(width), modulation(width), cue_fraction(width), cue_modulation(width), weak_bits(width),
          code(width) {}
};

template <typename Pixel>
const Pixel* row_of(const CaptureSet& captures, int frame, int y) {
    return captures.images[frame].ptr<Pixel>(y);
}

// The pixel loops take __restrict parameters (row buffers never overlap the images), so that
// GCC vectorises them without run-time overlap checks.
template <typename Pixel>
void add_four_shifts(const Pixel* __restrict i0, const Pixel* __restrict i1, const Pixel* __restrict i2,
                     const Pixel* __restrict i3, const float* shift_cos, const float* shift_sin, int width,
                     float* __restrict sum_sin, float* __restrict sum_cos, float* __restrict sum) {
    const float c0 = shift_cos[0], c1 = shift_cos[1], c2 = shift_cos[2], c3 = shift_cos[3];
    const float s0 = shift_sin[0], s1 = shift_sin[1], s2 = shift_sin[2], s3 = shift_sin[3];
    for (int x = 0; x < width; ++x) {
        const float v0 = float(i0[x]), v1 = float(i1[x]), v2 = float(i2[x]), v3 = float(i3[x]);
        sum_sin[x] += v0 * s0 + v1 * s1 + v2 * s2 + v3 * s3;
        sum_cos[x] += v0 * c0 + v1 * c1 + v2 * c2 + v3 * c3;
        sum[x] += (v0 + v1) + (v2 + v3);
    }
}

template <typename Pixel>
void add_one_shift(const Pixel* __restrict intensity, float shift_cos, float shift_sin, int width,
                   float* __restrict sum_sin, float* __restrict sum_cos, float* __restrict sum) {
    for (int x = 0; x < width; ++x) {
        const float value = float(intensity[x]);
        sum_sin[x] += value * shift_sin;
        sum_cos[x] += value * shift_cos;
        sum[x] += value;
    }
}

// Sums of I_k sin(delta_k), I_k cos(delta_k) and I_k over the shifts, for one row.
// `frames` are the fringe frames (phase or cue) with their shift cosines and sines.
template <typename Pixel>
void accumulate_phase(const CaptureSet& captures, const std::vector<int>& frames, const std::vector<float>& cosines,
                      const std::vector<float>& sines, int y, int width, RowBuffers& buffers) {
    float* sum_sin = buffers.sum_sin.data();
    float* sum_cos = buffers.sum_cos.data();
    float* sum = buffers.sum.data();
    std::fill_n(sum_sin, width, 0.0f);
    std::fill_n(sum_cos, width, 0.0f);
    std::fill_n(sum, width, 0.0f);
    // Four frames per pass, so the sums are loaded and stored a quarter as often.
    size_t shift = 0;
    for (; shift + 4 <= frames.size(); shift += 4)
        add_four_shifts<Pixel>(row_of<Pixel>(captures, frames[shift], y), row_of<Pixel>(captures, frames[shift + 1], y),
                               row_of<Pixel>(captures, frames[shift + 2], y), row_of<Pixel>(captures, frames[shift + 3], y),
                               &cosines[shift], &sines[shift], width, sum_sin, sum_cos, sum);
    for (; shift < frames.size(); ++shift)
        add_one_shift<Pixel>(row_of<Pixel>(captures, frames[shift], y), cosines[shift], sines[shift], width, sum_sin,
                             sum_cos, sum);
}

template <typename Pixel>
void add_gray_bit(const Pixel* __restrict pattern, const Pixel* __restrict inverse, const float* __restrict reference,
                  float min_margin, int width, uint32_t* __restrict code, uint32_t* __restrict weak_bits) {
    // Gray -> binary: each binary bit is the previous binary bit xor the Gray bit.
    if (inverse) {
        for (int x = 0; x < width; ++x) {
            const float difference = float(pattern[x]) - float(inverse[x]);
            code[x] = (code[x] << 1) | ((code[x] & 1u) ^ uint32_t(difference > 0.0f));
            weak_bits[x] += uint32_t(std::fabs(difference) < min_margin);
        }
    } else {
        for (int x = 0; x < width; ++x) {
            const float difference = float(pattern[x]) - reference[x];
            code[x] = (code[x] << 1) | ((code[x] & 1u) ^ uint32_t(difference > 0.0f));
            weak_bits[x] += uint32_t(std::fabs(difference) < min_margin);
        }
    }
}

// Binary stripe code of every pixel of one row, and how many of its bits were weak
// (closer to their threshold than min_margin).
template <typename Pixel>
void decode_gray_row(const CaptureSet& captures, const AxisFrames& axis, int y, int width, float min_margin,
                     RowBuffers& buffers) {
    uint32_t* code = buffers.code.data();
    uint32_t* weak_bits = buffers.weak_bits.data();
    std::fill_n(code, width, 0u);
    std::fill_n(weak_bits, width, 0u);
    for (int bit = 0; bit < axis.code.gray_bits; ++bit)
        add_gray_bit<Pixel>(row_of<Pixel>(captures, axis.gray[bit], y),
                            axis.gray_inverse[bit] >= 0 ? row_of<Pixel>(captures, axis.gray_inverse[bit], y) : nullptr,
                            buffers.reference.data(), min_margin, width, code, weak_bits);
}

// atan2 by a minimax polynomial (max error ~1e-5 rad, far below the phase noise of a
// real capture), written branch-free so that the row loop vectorises.
inline float fast_atan2(float y, float x) {
    const float ax = std::fabs(x), ay = std::fabs(y);
    const float small = std::min(ax, ay), large = std::max(ax, ay);
    const float a = small / (large + 1e-30f);  // no branch: 0/0 cannot happen
    const float s = a * a;
    float r = a * (0.99997726f + s * (-0.33262347f + s * (0.19354346f + s * (-0.11643287f + s * (0.05265332f + s * -0.01172120f)))));
    // Both sides of each choice are computed so that the choices compile to blends.
    const float complement = 1.57079633f - r;
    r = ay > ax ? complement : r;
    const float supplement = 3.14159265f - r;
    r = x < 0.0f ? supplement : r;
    const float negated = -r;
    return y < 0.0f ? negated : r;
}

// Fringe phase as a fraction of a period in [0, 1), and modulation, for a whole row.
void phase_row(const float* __restrict sum_sin, const float* __restrict sum_cos, float offset, float modulation_scale,
               int width, float* __restrict fraction, float* __restrict modulation) {
    for (int x = 0; x < width; ++x) {
        const float s = sum_sin[x], c = sum_cos[x];
        // I_k = A + B cos(theta + delta_k): sum I sin(delta) = -K/2 B sin(theta).
        float turns = fast_atan2(-s, c) * float(1.0 / (2 * kPi)) - offset;
        // Wrap into [0, 1) without std::floor, which is a library call (no vectorising) on SSE2.
        turns -= float(int(turns));
        const float wrapped = turns + 1.0f;
        turns = turns < 0.0f ? wrapped : turns;
        fraction[x] = turns;
        modulation[x] = modulation_scale * std::sqrt(s * s + c * c);
    }
}

// Decodes rows [row_begin, row_end); returns the largest white-black contrast seen there.
template <typename Pixel>
float decode_rows(const CaptureSet& captures, const Plan& plan, const DecodeOptions& options, int row_begin,
                  int row_end, CorrespondenceMap& map, std::atomic<int>& corrections, std::atomic<int>& valid_pixels) {
    const int width = captures.images.front().cols;
    RowBuffers buffers(width);
    const float min_contrast = float(options.min_contrast) * plan.scale;
    const float min_margin = float(options.min_bit_margin) * plan.scale;
    const float saturation = float(options.saturation_level) * plan.scale;
    const float min_modulation = float(options.min_modulation) * plan.scale;
    const bool has_white_black = plan.white >= 0 && plan.black >= 0;
    const AxisFrames* reference_axis = plan.columns.code.shifts > 0 ? &plan.columns
                                     : (plan.rows.code.shifts > 0 ? &plan.rows : nullptr);
    int local_corrections = 0, local_valid = 0;
    float local_max_contrast = 0;

    for (int y = row_begin; y < row_end; ++y) {
        float* reference = buffers.reference.data();
        float* contrast = buffers.contrast.data();
        float* brightest = buffers.brightest.data();
        if (has_white_black) {
            const Pixel* white = row_of<Pixel>(captures, plan.white, y);
            const Pixel* black = row_of<Pixel>(captures, plan.black, y);
            for (int x = 0; x < width; ++x) {
                reference[x] = 0.5f * (float(white[x]) + float(black[x]));
                contrast[x] = float(white[x]) - float(black[x]);
                brightest[x] = float(white[x]);
            }
        } else {
            // No white/black frames (e.g. SLMaster): the fringe mean and amplitude stand in.
            accumulate_phase<Pixel>(captures, reference_axis->phase, reference_axis->shift_cos, reference_axis->shift_sin, y,
                                    width, buffers);
            const float inverse_count = 1.0f / reference_axis->phase.size();
            for (int x = 0; x < width; ++x) {
                const float mean = buffers.sum[x] * inverse_count;
                const float amplitude = 2.0f * inverse_count * std::sqrt(buffers.sum_sin[x] * buffers.sum_sin[x] +
                                                                         buffers.sum_cos[x] * buffers.sum_cos[x]);
                reference[x] = mean;
                contrast[x] = 2.0f * amplitude;
                brightest[x] = mean + amplitude;
            }
        }

        uint8_t* status = map.status.ptr<uint8_t>(y);
        for (int x = 0; x < width; ++x) {
            local_max_contrast = std::max(local_max_contrast, contrast[x]);
            status[x] = contrast[x] < min_contrast ? kDark : (brightest[x] >= saturation ? kSaturated : kValid);
        }

        for (const AxisFrames* axis : {&plan.columns, &plan.rows}) {
            if (!axis->code.used()) continue;
            const bool is_columns = axis == &plan.columns;
            const int axis_length = is_columns ? captures.sequence.projector_size.width : captures.sequence.projector_size.height;
            float* position = (is_columns ? map.projector_u : map.projector_v).ptr<float>(y);
            float* quality = map.quality.ptr<float>(y);

            const bool has_gray = axis->code.gray_bits > 0;
            if (has_gray) {
                decode_gray_row<Pixel>(captures, *axis, y, width, min_margin, buffers);
            } else {
                std::fill_n(buffers.weak_bits.data(), width, 0u);
                accumulate_phase<Pixel>(captures, axis->cue, axis->cue_cos, axis->cue_sin, y, width, buffers);
                phase_row(buffers.sum_sin.data(), buffers.sum_cos.data(), float(axis->code.phase_offset_rad / (2 * kPi)),
                          2.0f / axis->cue.size(), width, buffers.cue_fraction.data(), buffers.cue_modulation.data());
            }
            if (axis->decode_phase) {
                accumulate_phase<Pixel>(captures, axis->phase, axis->shift_cos, axis->shift_sin, y, width, buffers);
                phase_row(buffers.sum_sin.data(), buffers.sum_cos.data(), float(axis->code.phase_offset_rad / (2 * kPi)),
                          2.0f / axis->phase.size(), width, buffers.phase_fraction.data(), buffers.modulation.data());
            }

            const double unit = axis->code.gray_unit_px;
            const double period = axis->code.period_px;
            const double inverse_period = period > 0 ? 1.0 / period : 0.0;
            for (int x = 0; x < width; ++x) {
                uint8_t pixel_status = status[x];
                float projector_position = kNaN;
                float pixel_quality = contrast[x];
                // At a stripe edge exactly one Gray bit changes, so one weak bit only means
                // "one of two neighbouring codes" (corrected by the phase); two or more mean noise.
                if (pixel_status == kValid && buffers.weak_bits[x] >= 2) pixel_status = kUndecidedBit;
                if (pixel_status == kValid) {
                    const double stripe_start = buffers.code[x] * unit;
                    const double stripe_centre = stripe_start + 0.5 * (unit - 1.0);
                    double decoded = stripe_centre;
                    if (!has_gray) {
                        // Two-frequency unwrapping: the cue's coarse position picks the fringe order.
                        pixel_quality = buffers.modulation[x];
                        const double phase_px = period * buffers.phase_fraction[x];
                        const double coarse_px = axis->code.cue_period_px * buffers.cue_fraction[x];
                        decoded = phase_px + period * std::nearbyint((coarse_px - phase_px) * inverse_period);
                        if (pixel_quality < min_modulation || buffers.cue_modulation[x] < min_modulation)
                            pixel_status = kLowModulation;
                    } else if (axis->decode_phase) {
                        pixel_quality = buffers.modulation[x];
                        const double phase_px = period * buffers.phase_fraction[x];
                        // Fringe order from the binary code, sub-pixel position from the phase; the
                        // two may disagree at a fringe edge, where one period is added or taken away.
                        // Codes are non-negative, so truncation is the floor.
                        decoded = double(int64_t(stripe_start * inverse_period)) * period + phase_px;
                        if (decoded - stripe_centre > 0.5 * period) {
                            decoded -= period;
                            ++local_corrections;
                        } else if (decoded - stripe_centre < -0.5 * period) {
                            decoded += period;
                            ++local_corrections;
                        }
                        if (pixel_quality < min_modulation) pixel_status = kLowModulation;
                    }
                    if (pixel_status == kValid && (decoded < -0.5 || decoded > axis_length - 0.5)) pixel_status = kUndecidedBit;
                    if (pixel_status == kValid) projector_position = float(decoded);
                }
                position[x] = projector_position;
                if (is_columns) {
                    status[x] = pixel_status;
                    quality[x] = pixel_quality;
                }
            }
        }
        uint8_t* mask = map.mask.ptr<uint8_t>(y);
        const float* projector_u = map.projector_u.ptr<float>(y);
        for (int x = 0; x < width; ++x) {
            mask[x] = std::isfinite(projector_u[x]) ? 255 : 0;
            local_valid += mask[x] != 0;
        }
    }
    corrections += local_corrections;
    valid_pixels += local_valid;
    return local_max_contrast;
}

}  // namespace

CorrespondenceMap decode(const CaptureSet& captures, const DecodeOptions& options, const ProgressCallback& progress) {
    CorrespondenceMap map;
    decode_into(captures, options, map, progress);
    return map;
}

void decode_into(const CaptureSet& captures, const DecodeOptions& options, CorrespondenceMap& map,
                 const ProgressCallback& progress) {
    const std::string source = captures.directory.empty() ? std::string("capture set") : captures.directory;
    const PatternSequence& sequence = captures.sequence;
    if (captures.images.size() != sequence.frames.size() || captures.images.empty())
        throw Error(source, "capture set has " + std::to_string(captures.images.size()) + " images for " +
                                std::to_string(sequence.frames.size()) + " frames");
    const cv::Mat& first = captures.images.front();
    for (size_t index = 0; index < captures.images.size(); ++index) {
        const cv::Mat& image = captures.images[index];
        if (image.size() != first.size() || image.type() != first.type() || image.channels() != 1 ||
            (image.depth() != CV_8U && image.depth() != CV_16U))
            throw Error(source + "/" + sequence.frames[index].file,
                        "every image must be single-channel 8 or 16 bit and of one size");
    }

    Plan plan;
    for (size_t index = 0; index < sequence.frames.size(); ++index) {
        if (sequence.frames[index].kind == FrameKind::White) plan.white = int(index);
        if (sequence.frames[index].kind == FrameKind::Black) plan.black = int(index);
    }
    plan.columns = plan_axis(sequence, Axis::Columns, options.binary_only, source);
    plan.has_rows = sequence.rows.used();
    if (plan.has_rows) plan.rows = plan_axis(sequence, Axis::Rows, options.binary_only, source);
    if ((plan.white < 0 || plan.black < 0) && plan.columns.code.shifts == 0 && plan.rows.code.shifts == 0)
        throw Error(source, "the sequence needs white and black frames, or phase frames, to set the Gray thresholds");
    plan.scale = first.depth() == CV_16U ? 257.0f : 1.0f;

    map.projector_u.create(first.size(), CV_32F);
    map.projector_v.create(first.size(), CV_32F);
    if (!plan.has_rows) map.projector_v.setTo(kNaN);
    map.quality.create(first.size(), CV_32F);
    map.mask.create(first.size(), CV_8U);
    map.status.create(first.size(), CV_8U);

    std::atomic<int> corrections{0}, valid_pixels{0};
    std::vector<float> chunk_max_contrast(first.rows, 0.0f);
    detail::ProgressReporter reporter(progress, "decode", first.rows);
    detail::parallel_rows(first.rows, [&](int begin, int end) {
        if (reporter.cancelled()) return;
        chunk_max_contrast[begin] =
            first.depth() == CV_8U ? decode_rows<uint8_t>(captures, plan, options, begin, end, map, corrections, valid_pixels)
                                   : decode_rows<uint16_t>(captures, plan, options, begin, end, map, corrections, valid_pixels);
        reporter.advance(end - begin);
    });
    if (reporter.cancelled()) throw Error("cancelled", "decoding cancelled");
    map.order_corrections = corrections;
    if (valid_pixels == 0) {
        const float max_contrast = *std::max_element(chunk_max_contrast.begin(), chunk_max_contrast.end()) / plan.scale;
        if (max_contrast < options.min_contrast)
            throw Error(source, "all captures are dark: the largest white-black contrast is " +
                                    std::to_string(int(max_contrast)) + " grey levels, below the minimum of " +
                                    std::to_string(int(options.min_contrast)));
    }
}

}  // namespace picoscan
