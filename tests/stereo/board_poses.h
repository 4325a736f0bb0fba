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

// The white-lit image of the first `count` poses in both cameras (blur 0.5 px, noise): each
// pose is rendered once for the whole suite and kept as PNG files in the build's test cache
// (CTest runs every test in its own process), then read from there.
std::vector<StereoBoardView> board_views(int count = 12);

}  // namespace picoscan::test_support
