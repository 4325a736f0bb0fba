// Board poses seen by both cameras of the simulated two-camera rig, for the stereo tests.
#pragma once

#include "picoscan/simulate.h"
#include "picoscan/stereo.h"

#include <vector>

namespace picoscan::test_support {

// The first `count` (up to 12) of twelve 9x6 chessboard poses (12 mm squares), each the board's
// white-lit image in both cameras; camera noise seeded from `seed`.
std::vector<StereoBoardView> board_views(const SeedStereoRig& rig, int count, uint64_t seed);

}  // namespace picoscan::test_support
