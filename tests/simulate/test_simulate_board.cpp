// Chessboard calibration targets in the virtual rig: corners land where OpenCV projects them,
// the printed pattern is where the board frame says, boards clip at the image edge, and bad
// boards are errors naming the field.
#include "picoscan/error.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <fstream>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;

// R = Rz * Ry * Rx, the scene files' rotation_deg convention.
cv::Matx33d rotation_deg(double rx, double ry, double rz) {
    const double k = kPi / 180.0;
    const double cx = std::cos(rx * k), sx = std::sin(rx * k), cy = std::cos(ry * k), sy = std::sin(ry * k);
    const double cz = std::cos(rz * k), sz = std::sin(rz * k);
    return cv::Matx33d(cz, -sz, 0, sz, cz, 0, 0, 0, 1) * cv::Matx33d(cy, 0, sy, 0, 1, 0, -sy, 0, cy) *
           cv::Matx33d(1, 0, 0, 0, cx, -sx, 0, sx, cx);
}

// A 9x6 board of 18 mm squares turned by `rotation` about its pattern's centre, which sits at `centre`.
CalibrationBoard board_at(const cv::Matx33d& rotation, const cv::Vec3d& centre) {
    CalibrationBoard board;
    board.inner_corners = cv::Size(9, 6);
    board.square_mm = 18;
    board.margin_mm = 12;
    board.rotation = rotation;
    const cv::Vec3d pattern_centre(board.square_mm * (board.inner_corners.width - 1) / 2.0,
                                   board.square_mm * (board.inner_corners.height - 1) / 2.0, 0);
    board.translation = centre - rotation * pattern_centre;
    return board;
}

std::vector<cv::Point2f> projected_corners(const Calibration& rig, const CalibrationBoard& board) {
    cv::Vec3d rvec;
    cv::Rodrigues(cv::Mat(board.rotation), rvec);
    std::vector<cv::Point2f> pixels;
    cv::projectPoints(chessboard_corners(board), rvec, board.translation, cv::Mat(rig.camera_matrix),
                      rig.camera_distortion, pixels);
    return pixels;
}

// RMS distance between detected and expected corners, allowing the detector to start the grid
// at any of its four outer corners (it does not look at the square colours).
double rms_error(const std::vector<cv::Point2f>& detected, const std::vector<cv::Point2f>& expected, cv::Size grid) {
    double best = std::numeric_limits<double>::infinity();
    for (int flip = 0; flip < 4; ++flip) {
        double sum = 0;
        for (int row = 0; row < grid.height; ++row)
            for (int col = 0; col < grid.width; ++col) {
                const int r = (flip & 1) ? grid.height - 1 - row : row;
                const int c = (flip & 2) ? grid.width - 1 - col : col;
                const cv::Point2f d = detected[r * grid.width + c] - expected[row * grid.width + col];
                sum += d.dot(d);
            }
        best = std::min(best, std::sqrt(sum / expected.size()));
    }
    return best;
}

cv::Mat white_frame(const Calibration& rig, const Scene& scene, double blur) {
    SimulationOptions options;
    options.noise_sigma_dn = 0;
    options.blur_sigma_px = blur;
    const Simulator simulator(rig, scene, options);
    return simulator.render(cv::Mat(rig.projector_size, CV_8U, cv::Scalar(255)), 0);
}

// Board-frame (x, y) of a camera-frame point.
cv::Vec2d on_board(const CalibrationBoard& board, const cv::Vec3f& point) {
    const cv::Vec3d local = board.rotation.t() * (cv::Vec3d(point) - board.translation);
    return {local[0], local[1]};
}

}  // namespace

TEST(SimulateBoard, CornersAreOpenCVCorners) {
    const CalibrationBoard board;
    const std::vector<cv::Point3f> corners = chessboard_corners(board);
    ASSERT_EQ(corners.size(), 54u);
    EXPECT_EQ(corners[0], cv::Point3f(0, 0, 0));
    EXPECT_EQ(corners[1], cv::Point3f(10, 0, 0));   // along a row first
    EXPECT_EQ(corners[9], cv::Point3f(0, 10, 0));   // then the next row
    EXPECT_EQ(corners[53], cv::Point3f(80, 50, 0));
}

TEST(SimulateBoard, DetectedCornersMatchProjectedCornersOnATiltedBoard) {
    const Calibration rig = seed_rig_calibration();
    Scene scene;
    scene.boards.push_back(board_at(rotation_deg(-10, 30, 5), cv::Vec3d(0, 0, 400)));
    const CalibrationBoard& board = scene.boards[0];
    const cv::Mat image = white_frame(rig, scene, 0.7);
    const std::vector<cv::Point2f> expected = projected_corners(rig, board);
    for (const cv::Point2f& p : expected) {
        ASSERT_GT(p.x, 50);
        ASSERT_LT(p.x, rig.camera_size.width - 50);
        ASSERT_GT(p.y, 50);
        ASSERT_LT(p.y, rig.camera_size.height - 50);
    }

    std::vector<cv::Point2f> sb;
    ASSERT_TRUE(cv::findChessboardCornersSB(image, board.inner_corners, sb, cv::CALIB_CB_ACCURACY));
    const double sb_rms = rms_error(sb, expected, board.inner_corners);

    std::vector<cv::Point2f> classic;
    ASSERT_TRUE(cv::findChessboardCorners(image, board.inner_corners, classic));
    cv::cornerSubPix(image, classic, cv::Size(7, 7), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 100, 1e-4));
    const double subpix_rms = rms_error(classic, expected, board.inner_corners);

    std::cout << "corner RMS vs projectPoints: findChessboardCornersSB " << sb_rms << " px, cornerSubPix "
              << subpix_rms << " px\n";
    EXPECT_LT(sb_rms, 0.1);
    EXPECT_LT(subpix_rms, 0.1);
}

TEST(SimulateBoard, AlbedoMapShowsTheSquaresWhereTheBoardFrameSays) {
    const Calibration rig = seed_rig_calibration();
    Scene scene;
    scene.boards.push_back(board_at(rotation_deg(-10, 30, 5), cv::Vec3d(0, 0, 400)));
    const CalibrationBoard& board = scene.boards[0];
    SimulationOptions options;
    options.noise_sigma_dn = 0;
    const Simulator simulator(rig, scene, options);
    const SimulatedGeometry& g = simulator.geometry();

    const double s = board.square_mm;
    const int w = board.inner_corners.width, h = board.inner_corners.height;
    int inside_square = 0, wrong = 0, in_margin = 0, on_edge = 0, edge_not_mixed = 0, dark = 0;
    for (int row = 0; row < g.points.rows; ++row)
        for (int col = 0; col < g.points.cols; ++col) {
            const cv::Vec3f point = g.points.at<cv::Vec3f>(row, col);
            if (!std::isfinite(point[0])) continue;
            const cv::Vec2d xy = on_board(board, point);
            const float albedo = g.albedo.at<float>(row, col);
            // Every hit is on the board's rectangle.
            ASSERT_GE(xy[0], -s - board.margin_mm - 1e-3);
            ASSERT_LE(xy[0], w * s + board.margin_mm + 1e-3);
            ASSERT_GE(xy[1], -s - board.margin_mm - 1e-3);
            ASSERT_LE(xy[1], h * s + board.margin_mm + 1e-3);

            const double fx = xy[0] / s, fy = xy[1] / s;
            const bool in_squares = fx > -1 && fx < w && fy > -1 && fy < h;
            // A pixel covers ~0.17 mm here: 0.5 mm from every line keeps its footprint in one cell.
            const double to_line_x = std::abs(fx - std::round(fx)) * s, to_line_y = std::abs(fy - std::round(fy)) * s;
            if (!in_squares) {
                if (fx < -1 - 0.5 / s || fx > w + 0.5 / s || fy < -1 - 0.5 / s || fy > h + 0.5 / s) {
                    ++in_margin;
                    if (std::abs(albedo - board.light_albedo) > 1e-6) ++wrong;
                }
                continue;
            }
            if (to_line_x > 0.5 && to_line_y > 0.5) {
                ++inside_square;
                // The square with top-left corner (-s, -s) is dark; colours alternate from there.
                const bool is_dark = (static_cast<int>(std::floor(fx)) + static_cast<int>(std::floor(fy))) % 2 == 0;
                dark += is_dark;
                if (std::abs(albedo - (is_dark ? board.dark_albedo : board.light_albedo)) > 1e-6) ++wrong;
            } else if ((to_line_x < 0.02 && to_line_y > 0.5 && std::round(fx) >= 0 && std::round(fx) < w) ||
                       (to_line_y < 0.02 && to_line_x > 0.5 && std::round(fy) >= 0 && std::round(fy) < h)) {
                // Centre on an edge between squares, away from corners: about half of each colour.
                ++on_edge;
                const double fraction = (albedo - board.dark_albedo) / (board.light_albedo - board.dark_albedo);
                if (std::abs(fraction - 0.5) > 0.25) ++edge_not_mixed;
            }
        }
    EXPECT_GT(inside_square, 500000);
    EXPECT_GT(in_margin, 50000);
    EXPECT_NEAR(static_cast<double>(dark) / inside_square, 0.5, 0.05);
    EXPECT_EQ(wrong, 0);
    EXPECT_GT(on_edge, 1000);
    EXPECT_EQ(edge_not_mixed, 0);

    // The image follows the albedo map: lit by the same white, dark squares render darker.
    const cv::Mat image = simulator.render(cv::Mat(rig.projector_size, CV_8U, cv::Scalar(255)), 0);
    const std::vector<cv::Point2f> corners = projected_corners(rig, board);
    // Just inside the first square (dark) and the next one along the row (light).
    const cv::Point2f to_next = corners[1] - corners[0], to_below = corners[9] - corners[0];
    const cv::Point dark_pixel = corners[0] - 0.5f * to_next - 0.5f * to_below;
    const cv::Point light_pixel = corners[0] + 0.5f * to_next - 0.5f * to_below;
    const double dark_level = image.at<uint8_t>(dark_pixel), light_level = image.at<uint8_t>(light_pixel);
    EXPECT_NEAR(dark_level / light_level, board.dark_albedo / board.light_albedo, 0.03);
}

TEST(SimulateBoard, BoardPartlyOutOfViewIsRenderedWhereVisible) {
    const Calibration rig = seed_rig_calibration();
    Scene scene;
    // Shifted left so about a third of the board lies beyond the image's left edge,
    // in front of a background plane.
    scene.boards.push_back(board_at(rotation_deg(0, -20, 0), cv::Vec3d(-100, 10, 400)));
    scene.planes.push_back({cv::Vec3d(0, 0, 600), cv::Vec3d(0, 0, -1), 0.3});
    const CalibrationBoard& board = scene.boards[0];
    SimulationOptions options;
    options.noise_sigma_dn = 0;
    const Simulator simulator(rig, scene, options);
    const SimulatedGeometry& g = simulator.geometry();

    const std::vector<cv::Point2f> expected = projected_corners(rig, board);
    int corners_in_view = 0, corners_out_of_view = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
        const cv::Point pixel(cvRound(expected[i].x), cvRound(expected[i].y));
        if (pixel.x < 0) {
            ++corners_out_of_view;
            continue;
        }
        ASSERT_LT(pixel.x, rig.camera_size.width);
        ++corners_in_view;
        // The nearest pixel's ray meets the board within a pixel's footprint of the corner.
        const cv::Vec3f point = g.points.at<cv::Vec3f>(pixel);
        ASSERT_TRUE(std::isfinite(point[0])) << "corner " << i;
        EXPECT_LT(cv::norm(on_board(board, point) - cv::Vec2d(chessboard_corners(board)[i].x,
                                                             chessboard_corners(board)[i].y)),
                  0.2)
            << "corner " << i;
    }
    EXPECT_GT(corners_in_view, 20);
    EXPECT_GT(corners_out_of_view, 10);

    // The board reaches the left edge of the image: those pixels see the board, not the plane.
    int left_edge_on_board = 0;
    for (int row = 0; row < g.points.rows; ++row) {
        const cv::Vec3f point = g.points.at<cv::Vec3f>(row, 0);
        if (std::isfinite(point[0]) && point[2] < 590) ++left_edge_on_board;
    }
    EXPECT_GT(left_edge_on_board, 500);
    // Far right sees the plane behind.
    EXPECT_NEAR(g.points.at<cv::Vec3f>(600, 1590)[2], 600.0f, 1e-3);
    EXPECT_FLOAT_EQ(g.albedo.at<float>(600, 1590), 0.3f);

    // The visible part renders as a chessboard: OpenCV finds a partial grid of corners where projected.
    const cv::Mat image = simulator.render(cv::Mat(rig.projector_size, CV_8U, cv::Scalar(255)), 0);
    std::vector<cv::Point2f> found;
    cv::Mat crop = image(cv::Rect(0, 0, 1000, 1200));
    ASSERT_TRUE(cv::findChessboardCornersSB(crop, cv::Size(4, 6), found, cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY));
    int matched = 0;
    for (const cv::Point2f& f : found)
        for (const cv::Point2f& e : expected)
            if (cv::norm(f - e) < 0.3) ++matched;
    EXPECT_EQ(matched, static_cast<int>(found.size()));
}

TEST(SimulateBoard, BadBoardsAreErrorsNamingTheField) {
    const Calibration rig = seed_rig_calibration();
    auto expect_error = [&](const CalibrationBoard& board, const std::string& field) {
        Scene scene;
        scene.boards.push_back(CalibrationBoard{});
        scene.boards.push_back(board);
        try {
            Simulator simulator(rig, scene);
            ADD_FAILURE() << "no error for a bad " << field;
        } catch (const Error& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find("boards[1]"), std::string::npos) << message;
            EXPECT_NE(message.find(field), std::string::npos) << message;
        }
    };
    CalibrationBoard b;
    b.inner_corners = cv::Size(1, 6);
    expect_error(b, "inner_corners");
    b = CalibrationBoard{};
    b.square_mm = 0;
    expect_error(b, "square_mm");
    b = CalibrationBoard{};
    b.margin_mm = -1;
    expect_error(b, "margin_mm");
    b = CalibrationBoard{};
    b.dark_albedo = -0.1;
    expect_error(b, "dark_albedo");
    b = CalibrationBoard{};
    b.light_albedo = 1.5;
    expect_error(b, "light_albedo");
    b = CalibrationBoard{};
    b.rotation = cv::Matx33d(1, 0, 0, 0, 1, 0, 0, 0, -1);  // a mirror
    expect_error(b, "rotation");
    b = CalibrationBoard{};
    b.translation[2] = std::numeric_limits<double>::quiet_NaN();
    expect_error(b, "translation");
}

TEST(SimulateBoard, SceneFilesReadBoardsAndNameBadKeys) {
    const std::string folder = test_support::make_temp_dir("scene-boards");
    std::ofstream(folder + "/boards.yml") << "boards:\n"
                                             "  - { translation: [-50, -30, 420], rotation_deg: [0, 30, 0], "
                                             "inner_corners: [7, 5], square_mm: 15, margin_mm: 8, "
                                             "dark_albedo: 0.05, light_albedo: 0.9 }\n"
                                             "  - { translation: [0, 0, 500], rotation: [[0, -1, 0], [1, 0, 0], [0, 0, 1]] }\n";
    const Scene scene = read_scene(folder + "/boards.yml");
    ASSERT_EQ(scene.boards.size(), 2u);
    const CalibrationBoard& a = scene.boards[0];
    EXPECT_EQ(a.translation, cv::Vec3d(-50, -30, 420));
    EXPECT_LT(cv::norm(a.rotation - rotation_deg(0, 30, 0)), 1e-12);
    EXPECT_EQ(a.inner_corners, cv::Size(7, 5));
    EXPECT_DOUBLE_EQ(a.square_mm, 15);
    EXPECT_DOUBLE_EQ(a.margin_mm, 8);
    EXPECT_DOUBLE_EQ(a.dark_albedo, 0.05);
    EXPECT_DOUBLE_EQ(a.light_albedo, 0.9);
    const CalibrationBoard& b = scene.boards[1];
    const CalibrationBoard defaults;
    EXPECT_LT(cv::norm(b.rotation * cv::Vec3d(1, 0, 0) - cv::Vec3d(0, 1, 0)), 1e-12);
    EXPECT_EQ(b.inner_corners, defaults.inner_corners);
    EXPECT_DOUBLE_EQ(b.square_mm, defaults.square_mm);
    EXPECT_DOUBLE_EQ(b.light_albedo, defaults.light_albedo);

    auto expect_error = [&](const std::string& text, const std::string& needle) {
        const std::string path = folder + "/bad.json";
        std::ofstream(path) << text;
        try {
            read_scene(path);
            ADD_FAILURE() << "no error for " << text;
        } catch (const Error& e) {
            EXPECT_EQ(e.subject(), path);
            const std::string message = e.what();
            EXPECT_NE(message.find("boards[0]"), std::string::npos) << message;
            EXPECT_NE(message.find(needle), std::string::npos) << message;
        }
    };
    expect_error(R"({"boards": [{"inner_corners": [9, 6]}]})", "translation");
    expect_error(R"({"boards": [{"translation": [0, 0, 400], "inner_corners": [9]}]})", "inner_corners");
    expect_error(R"({"boards": [{"translation": [0, 0, 400], "inner_corners": [1, 6]}]})", "inner_corners");
    expect_error(R"({"boards": [{"translation": [0, 0, 400], "inner_corners": [9.5, 6]}]})", "inner_corners");
    expect_error(R"({"boards": [{"translation": [0, 0, 400], "square_mm": 0}]})", "square_mm");
    expect_error(R"({"boards": [{"translation": [0, 0, 400], "margin_mm": -2}]})", "margin_mm");
    expect_error(R"({"boards": [{"translation": [0, 0, 400], "dark_albedo": 2}]})", "dark_albedo");
    expect_error(R"({"boards": [{"translation": [0, 0, 400], "light_albedo": -1}]})", "light_albedo");
    expect_error(R"({"boards": [{"translation": [0, 0, 400], "rotation_deg": [0, 30]}]})", "rotation_deg");
    expect_error(R"({"boards": [{"translation": [0, 0, 400], "rotation": [1, 2, 3, 4, 5, 6, 7, 8, 9]}]})", "rotation");
}
