// Rounding a computed image coordinate to a pixel index.
#pragma once

#include <cmath>

namespace picoscan::detail {

// The pixel `coordinate` rounds to (halves away from zero), when it lies in [0, size). Tested
// before the conversion: a projected or decoded coordinate can be anything (a point just in
// front of a camera, a diverged search, NaN), and one beyond int's range has no int, or wraps
// onto a pixel inside the image.
inline bool round_to_pixel(double coordinate, int size, int& pixel) {
    const double rounded = std::round(coordinate);
    if (!(rounded >= 0 && rounded < size)) return false;  // NaN too
    pixel = static_cast<int>(rounded);
    return true;
}

}  // namespace picoscan::detail
