// Normals of an organised view, shared by every stage that triangulates.
#pragma once

#include "picoscan/cloud.h"

namespace picoscan::detail {

// Normals from the organised grid: cross product of the horizontal and vertical neighbour
// differences (central where both neighbours exist), turned towards the camera. NaN where a
// pixel has no point or no usable neighbour.
void estimate_normals(ScanView& view);

}  // namespace picoscan::detail
