// Projector pattern sequences: reflected-binary (Gray) code and phase-shifted fringes.
//
// A PatternSequence describes every frame of a scan in projection order. It can be
// PicoScan's own sequence or describe capture sets made by other systems (OpenCV
// structured_light GrayCodePattern, SLStudio Gray code, SLMaster sinusoid + CGC).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

// Cue: a phase-shifted fringe of a long period (e.g. one period across the projector) that
// unwraps the fine fringes instead of a Gray code (two-frequency temporal unwrapping).
enum class FrameKind { White, Black, Gray, GrayInverse, Phase, Cue };
enum class Axis { Columns, Rows };  // Columns encodes projector u (x), Rows projector v (y)

struct Frame {
    std::string file;  // image file name inside the capture directory
    FrameKind kind = FrameKind::White;
    Axis axis = Axis::Columns;
    int bit = 0;    // Gray frames: 0 = most significant bit
    int shift = 0;  // Phase and Cue frames: shift index 0..shifts-1 (or cue_shifts-1)
};

// How one projector axis is encoded.
//   Gray: `gray_bits` reflected-binary bits, MSB first; code value c covers projector
//         pixels [c*gray_unit_px, (c+1)*gray_unit_px).
//   Phase: I_k(x) = 0.5 + 0.5*cos(2*pi*x/period_px + phase_offset_rad + shift_sign*2*pi*k/shifts)
//   Cue:   the same with cue_period_px and cue_shifts; it gives the fringe order where there is
//          no Gray code.
struct AxisCode {
    int gray_bits = 0;
    double gray_unit_px = 1.0;
    int shifts = 0;
    double period_px = 0.0;
    double phase_offset_rad = 0.0;
    int shift_sign = 1;
    int cue_shifts = 0;
    double cue_period_px = 0.0;

    bool used() const { return gray_bits > 0 || shifts > 0; }
};

struct PatternSequence {
    cv::Size projector_size;
    std::string origin = "picoscan";  // which system made it: picoscan, opencv-graycode, slstudio-gray, slmaster-cgc
    AxisCode columns;
    AxisCode rows;
    std::vector<Frame> frames;

    const AxisCode& code(Axis axis) const { return axis == Axis::Columns ? columns : rows; }
};

struct PatternOptions {
    cv::Size projector_size{854, 480};
    int shifts = 24;        // phase shifts per axis, 3..64
    int period_bits = 4;    // fringe period = 2^period_bits projector pixels
    bool rows = true;       // also encode projector rows (v)
};

// Number of Gray bits needed to give every one of `pixels` projector pixels its own code.
int gray_bits_for(int pixels);

// PicoScan's own sequence: white, black, then per axis (columns, then rows) Gray bits
// each followed by its inverse, then the phase shifts. Throws Error on bad options.
PatternSequence make_pattern_sequence(const PatternOptions& options);

// Sequences made by other systems (file names as those systems wrote them).
// OpenCV GrayCodePattern: (pattern, inverse) pairs, columns then rows, then white, black;
// files "<prefix><K><suffix>" with K starting at `first_index`.
PatternSequence make_opencv_graycode_sequence(cv::Size projector_size, const std::string& prefix,
                                              const std::string& suffix, int first_index);
// SLStudio Gray code: white, black, then `bits` column bits without inverses (frameSeq_NN.bmp).
PatternSequence make_slstudio_gray_sequence(cv::Size projector_size, int bits);
// SLStudio's calibration sequence: 3-step fringes of `periods` periods and a 3-step
// one-period cue, columns then rows (frameSeq_NN.bmp).
PatternSequence make_slstudio_phase_cue_sequence(cv::Size projector_size, int periods);
// SLMaster: `shifts`-step phase shift with `periods` periods across the width, then
// `periods_log2 + 1` complementary Gray code images (<index>.bmp).
PatternSequence make_slmaster_cgc_sequence(cv::Size projector_size, int shifts, int periods);

// The 8-bit image the projector shows for one frame. `response_lut`, if not empty, is a
// 256-entry CV_8U inverse projector response applied to every level.
cv::Mat render_pattern(const PatternSequence& sequence, const Frame& frame,
                       const cv::Mat& response_lut = cv::Mat());

// Manifest (sequence.json) reading and writing. Writing goes through a temporary file.
void write_manifest(const PatternSequence& sequence, const std::string& path);
PatternSequence read_manifest(const std::string& path);

// Writes every frame as an 8-bit PNG plus sequence.json into `directory` (created if needed).
void write_pattern_images(const PatternSequence& sequence, const std::string& directory,
                          const cv::Mat& response_lut = cv::Mat());

std::string to_string(FrameKind kind);
std::string to_string(Axis axis);

}  // namespace picoscan
