// Shape checks shared by the cloud and mesh builders.
#pragma once

#include "picoscan/cloud.h"

#include <cmath>
#include <string>

namespace picoscan::detail {

// Which optional layers of a view are usable (present with the points' size and the
// documented type). Throws Error(name, ...) for points or a layer of the wrong size or type.
struct ViewLayers {
    bool normals = false;
    bool colours = false;
    bool quality = false;
};
ViewLayers check_view(const ScanView& view, const std::string& name = "scan view");

// A view measures a part within a few metres of the camera. Coordinates far beyond would
// overflow the registration's integer cell keys (undefined behaviour, found by UBSan on a view
// at 1e15 mm) and mean nothing at float precision anyway. Within this reach every cell key
// stays below 2^63 for the smallest sample spacing (0.1 mm).
constexpr double kFarthestViewPointMm = 1e6;

// Whether a point has a coordinate beyond kFarthestViewPointMm (an infinite one too; NaN: no).
inline bool beyond_reach(const cv::Vec3f& p) {
    return std::abs(p[0]) > kFarthestViewPointMm || std::abs(p[1]) > kFarthestViewPointMm ||
           std::abs(p[2]) > kFarthestViewPointMm;
}

// check_view, then throws Error(name, "point at pixel (x, y) lies beyond 1 km ...") for the first measured
// point with a coordinate beyond kFarthestViewPointMm. Unmeasured points (NaN, inf) are
// skipped, as every stage skips them. read_view_ply checks the same reach per vertex.
void check_view_reach(const ScanView& view, const std::string& name);

}  // namespace picoscan::detail
