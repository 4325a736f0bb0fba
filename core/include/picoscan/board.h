// Planar calibration boards: their description, their points and their detection in an image.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

enum class BoardKind { Chessboard, Circles, AsymmetricCircles, Charuco };

// A printed planar target. Chessboard: inner corners (columns x rows), square side.
// Circles: grid of circles (columns x rows), centre spacing. ChArUco: squares (columns x rows),
// square side, marker side, ArUco dictionary (OpenCV's predefined dictionary number).
struct BoardSpec {
    BoardKind kind = BoardKind::Chessboard;
    cv::Size size{9, 6};
    double square_mm = 10;
    double marker_mm = 0;
    int dictionary = 0;
};

// Parses "chessboard:COLSxROWS:SQUARE_MM", "circles:COLSxROWS:SPACING_MM",
// "acircles:COLSxROWS:SPACING_MM" or "charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICTIONARY]".
// Throws Error("--board", ...) explaining the expected form.
BoardSpec parse_board_spec(const std::string& text);

// The board's feature points in its own frame (z = 0, mm), in the order detection returns them.
std::vector<cv::Point3f> board_points(const BoardSpec& board);

// Features of the board found in one grey image: image points and their board-point indices.
struct BoardDetection {
    std::vector<cv::Point2f> image_points;
    std::vector<int> point_ids;
};
// Returns false when the board is not found. Sub-pixel accurate.
bool detect_board(const cv::Mat& grey, const BoardSpec& board, BoardDetection& detection);

}  // namespace picoscan
