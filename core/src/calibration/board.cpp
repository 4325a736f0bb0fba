// Calibration boards: specification, model points and detection.
#include "picoscan/board.h"
#include "picoscan/calibration.h"
#include "picoscan/error.h"

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <sstream>

namespace picoscan {

namespace {

const char* kBoardForms =
    "expected chessboard:COLSxROWS:SQUARE_MM, circles:COLSxROWS:SPACING_MM, acircles:COLSxROWS:SPACING_MM "
    "or charuco:COLSxROWS:SQUARE_MM:MARKER_MM[:DICTIONARY]";

std::vector<std::string> split(const std::string& text, char separator) {
    std::vector<std::string> parts;
    std::stringstream stream(text);
    for (std::string part; std::getline(stream, part, separator);) parts.push_back(part);
    return parts;
}

double positive_number(const std::string& text, const std::string& what) {
    try {
        size_t end = 0;
        const double value = std::stod(text, &end);
        if (end == text.size() && value > 0 && value < 1e5) return value;
    } catch (const std::exception&) {
    }
    throw Error("--board", what + " must be a positive number of millimetres, got '" + text + "'");
}

}  // namespace

BoardSpec parse_board_spec(const std::string& text) {
    const std::vector<std::string> parts = split(text, ':');
    if (parts.size() < 3) throw Error("--board", std::string(kBoardForms) + ", got '" + text + "'");
    BoardSpec board;
    if (parts[0] == "chessboard") board.kind = BoardKind::Chessboard;
    else if (parts[0] == "circles") board.kind = BoardKind::Circles;
    else if (parts[0] == "acircles") board.kind = BoardKind::AsymmetricCircles;
    else if (parts[0] == "charuco") board.kind = BoardKind::Charuco;
    else throw Error("--board", "unknown board '" + parts[0] + "': " + kBoardForms);
    int columns = 0, rows = 0;
    char separator = 0, extra = 0;
    if (std::sscanf(parts[1].c_str(), "%d%c%d%c", &columns, &separator, &rows, &extra) != 3 || separator != 'x' ||
        columns < 2 || rows < 2 || columns > 200 || rows > 200)
        throw Error("--board", "size must be COLSxROWS with at least 2x2, got '" + parts[1] + "'");
    board.size = {columns, rows};
    board.square_mm = positive_number(parts[2], "square size");
    const size_t expected = board.kind == BoardKind::Charuco ? 4 : 3;
    if (parts.size() < expected || parts.size() > expected + (board.kind == BoardKind::Charuco ? 1 : 0))
        throw Error("--board", std::string(kBoardForms) + ", got '" + text + "'");
    if (board.kind == BoardKind::Charuco) {
        board.marker_mm = positive_number(parts[3], "marker size");
        if (board.marker_mm >= board.square_mm) throw Error("--board", "ChArUco markers must be smaller than the squares");
        board.dictionary = cv::aruco::DICT_5X5_100;
        if (parts.size() == 5) {
            try {
                board.dictionary = std::stoi(parts[4]);
            } catch (const std::exception&) {
                throw Error("--board", "ArUco dictionary must be OpenCV's number for it, got '" + parts[4] + "'");
            }
            if (board.dictionary < 0 || board.dictionary > cv::aruco::DICT_APRILTAG_36h11)
                throw Error("--board", "unknown ArUco dictionary " + parts[4]);
        }
    }
    return board;
}

std::vector<cv::Point3f> board_points(const BoardSpec& board) {
    std::vector<cv::Point3f> points;
    const float pitch = float(board.square_mm);
    switch (board.kind) {
    case BoardKind::Chessboard:
    case BoardKind::Circles:
        for (int row = 0; row < board.size.height; ++row)
            for (int column = 0; column < board.size.width; ++column) points.emplace_back(column * pitch, row * pitch, 0.f);
        break;
    case BoardKind::AsymmetricCircles:
        // OpenCV's layout: every other row shifted by half the spacing.
        for (int row = 0; row < board.size.height; ++row)
            for (int column = 0; column < board.size.width; ++column)
                points.emplace_back((2 * column + row % 2) * pitch, row * pitch, 0.f);
        break;
    case BoardKind::Charuco:
        // Inner chessboard corners of a COLS x ROWS squares board, row by row.
        for (int row = 1; row < board.size.height; ++row)
            for (int column = 1; column < board.size.width; ++column) points.emplace_back(column * pitch, row * pitch, 0.f);
        break;
    }
    return points;
}

bool detect_board(const cv::Mat& grey, const BoardSpec& board, BoardDetection& detection) {
    detection = {};
    cv::Mat image;
    if (grey.depth() == CV_16U) grey.convertTo(image, CV_8U, 1.0 / 257);
    else image = grey;
    std::vector<cv::Point2f> points;
    bool found = false;
    switch (board.kind) {
    case BoardKind::Chessboard:
        // The sector-based detector finds boards most reliably (with uneven lighting it needs
        // the image normalised first, so that is the second try), but its corners share an
        // offset of ~0.02 px within a pose (measured on simulated boards), which does not
        // average out over the corners and turned a stereo rig's rotation by 0.013 degrees.
        // cornerSubPix's error is larger per corner but independent (per-pose offsets ~0.004
        // px), so every corner is refined by it, in a window inside its neighbouring squares.
        found = cv::findChessboardCornersSB(image, board.size, points, cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY) ||
                cv::findChessboardCornersSB(image, board.size, points,
                                            cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY) ||
                cv::findChessboardCorners(image, board.size, points, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
        if (found) {
            double spacing = 1e9;  // the shortest distance between neighbouring corners, pixels
            for (int row = 0; row < board.size.height; ++row)
                for (int column = 0; column < board.size.width; ++column) {
                    const cv::Point2f& corner = points[size_t(row * board.size.width + column)];
                    if (column + 1 < board.size.width) spacing = std::min(spacing, cv::norm(points[size_t(row * board.size.width + column + 1)] - corner));
                    if (row + 1 < board.size.height) spacing = std::min(spacing, cv::norm(points[size_t((row + 1) * board.size.width + column)] - corner));
                }
            const int half_window = std::min(5, int(spacing / 3));
            if (half_window >= 2)
                cv::cornerSubPix(image, points, cv::Size(half_window, half_window), cv::Size(-1, -1),
                                 cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-5));
        }
        break;
    case BoardKind::Circles:
        found = cv::findCirclesGrid(image, board.size, points, cv::CALIB_CB_SYMMETRIC_GRID);
        break;
    case BoardKind::AsymmetricCircles:
        found = cv::findCirclesGrid(image, board.size, points, cv::CALIB_CB_ASYMMETRIC_GRID);
        break;
    case BoardKind::Charuco: {
        const auto dictionary = cv::aruco::getPredefinedDictionary(board.dictionary);
        const auto charuco = cv::aruco::CharucoBoard::create(board.size.width, board.size.height, float(board.square_mm),
                                                             float(board.marker_mm), dictionary);
        std::vector<std::vector<cv::Point2f>> marker_corners;
        std::vector<int> marker_ids;
        cv::aruco::detectMarkers(image, dictionary, marker_corners, marker_ids);
        if (marker_ids.empty()) return false;
        std::vector<int> corner_ids;
        cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, image, charuco, points, corner_ids);
        detection.image_points = points;
        detection.point_ids = corner_ids;
        return points.size() >= 6;  // a partly seen ChArUco board still counts
    }
    }
    if (!found) return false;
    detection.image_points = points;
    detection.point_ids.resize(points.size());
    for (size_t index = 0; index < points.size(); ++index) detection.point_ids[index] = int(index);
    return true;
}

}  // namespace picoscan
