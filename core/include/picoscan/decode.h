// Decoding a capture set into camera -> projector correspondences.
//
// Gray code: each bit compares the pattern with its inverse (or with (white+black)/2
// where there is none). Phase: closed-form least squares over K equally spaced shifts.
// Hybrid unwrapping: the Gray code gives the fringe order, the phase the sub-pixel
// position; where the two disagree by more than half a period the order is corrected
// by one period.
#pragma once

#include "picoscan/capture_set.h"

#include <opencv2/core.hpp>

namespace picoscan {

// Why a pixel has no correspondence (stored per pixel in CorrespondenceMap::status).
enum PixelStatus : uint8_t {
    kValid = 0,
    kDark = 1,           // white - black contrast below min_contrast (shadow or background)
    kSaturated = 2,      // white frame at or above the saturation level
    kUndecidedBit = 3,   // two or more Gray bits too close to their thresholds, or a code off the projector
    kLowModulation = 4,  // fringe modulation below min_modulation
};

struct DecodeOptions {
    // Thresholds in units of 8-bit grey levels (DN); 16-bit images are scaled by 1/257.
    double min_contrast = 15.0;      // white - black
    double min_bit_margin = 2.0;     // a Gray bit with |pattern - inverse| (or |I - threshold|) below this is weak
    double saturation_level = 254.5; // white >= this is saturated
    double min_modulation = 4.0;     // fringe amplitude B in I = A + B cos(...)
    bool binary_only = false;        // ignore phase frames: Gray code only
};

struct CorrespondenceMap {
    cv::Mat projector_u;  // CV_32F, projector column per camera pixel, NaN where unknown
    cv::Mat projector_v;  // CV_32F, projector row, NaN where unknown or rows not encoded
    cv::Mat quality;      // CV_32F, fringe modulation (DN), or white - black contrast when binary only
    cv::Mat mask;         // CV_8U, 255 where projector_u is valid
    cv::Mat status;       // CV_8U, PixelStatus per pixel
    int order_corrections = 0;  // pixels whose fringe order the Gray code corrected by a period
};

// Decodes every axis the sequence encodes. Throws Error for all-dark captures.
CorrespondenceMap decode(const CaptureSet& captures, const DecodeOptions& options = {},
                         const ProgressCallback& progress = nullptr);

// The same, writing into `map` and reusing its buffers when their size and type fit (as
// cv::Mat::create does): for scanning in a loop without reallocating ~40 MB per scan.
void decode_into(const CaptureSet& captures, const DecodeOptions& options, CorrespondenceMap& map,
                 const ProgressCallback& progress = nullptr);

}  // namespace picoscan
