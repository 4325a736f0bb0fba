// Shape checks shared by the cloud and mesh builders.
#pragma once

#include "picoscan/cloud.h"

#include <cmath>

namespace picoscan::detail {

// Which optional layers of a view are usable (present with the points' size and the
// documented type). Throws Error("scan view", ...) for a layer of the wrong size or type.
struct ViewLayers {
    bool normals = false;
    bool colours = false;
    bool quality = false;
};
ViewLayers check_view(const ScanView& view);

}  // namespace picoscan::detail
