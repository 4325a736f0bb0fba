// Board poses seen by both cameras of the simulated two-camera rig, for the stereo tests.
#pragma once

#include "picoscan/simulate.h"
#include "picoscan/stereo.h"

#include <vector>

namespace picoscan::test_support {

// The board: 14x9 inner corners of 10 mm squares (130 x 80 mm between the outer corners; an
// odd count one way, so that both cameras number the corners alike).
// A 9x6 board of 12 mm squares, about a third of the image across, fixes the principal points
// only to ~0.5 px, which turns the cameras' relative rotation by ~0.018 degrees.
constexpr const char* kStereoBoardSpec = "chessboard:14x9:10";
BoardSpec stereo_board();

// Twelve poses of that board in the first camera's frame, spread over the common field and
// tilted every way.
std::vector<CalibrationBoard> board_poses();

// The white-lit image of each pose in both cameras (blur 0.5 px, noise), rendered once per
// test process and shared by every stereo test.
const std::vector<StereoBoardView>& twelve_board_views();

}  // namespace picoscan::test_support
