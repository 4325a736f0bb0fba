// The human-readable side of a calibration: plots and an HTML report.
#include "picoscan/board.h"
#include "picoscan/calibrate.h"
#include "picoscan/calibration_report.h"
#include "picoscan/calibration.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"

#include "io/image_codecs.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <sstream>

namespace picoscan {

namespace {

const cv::Scalar kInk(40, 40, 40), kGrid(225, 225, 225), kCameraColour(200, 90, 20), kProjectorColour(40, 40, 220);

cv::Scalar pose_colour(size_t index) {
    static const cv::Scalar palette[] = {{180, 119, 31}, {14, 127, 255}, {44, 160, 44}, {40, 39, 214}, {189, 103, 148},
                                         {75, 86, 140},  {194, 119, 227}, {127, 127, 127}, {34, 189, 188}, {207, 190, 23}};
    return palette[index % 10];
}

void text(cv::Mat& image, const std::string& words, cv::Point at, double scale = 0.5, cv::Scalar colour = kInk) {
    cv::putText(image, words, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

// One scatter panel of residuals (px), axes scaled to the largest residual.
void residual_panel(cv::Mat& image, cv::Rect area, const std::vector<cv::Point2f>& residuals, const std::string& title,
                    double rms, cv::Scalar colour) {
    double largest = 0.1;
    for (const auto& residual : residuals) largest = std::max({largest, std::abs(double(residual.x)), std::abs(double(residual.y))});
    const double half_range = std::ceil(largest * 10) / 10;
    const cv::Point centre(area.x + area.width / 2, area.y + area.height / 2);
    const double scale = (area.width / 2 - 10) / half_range;
    cv::rectangle(image, area, kGrid);
    cv::line(image, {area.x, centre.y}, {area.x + area.width, centre.y}, kGrid);
    cv::line(image, {centre.x, area.y}, {centre.x, area.y + area.height}, kGrid);
    cv::circle(image, centre, int(rms * scale), colour, 1, cv::LINE_AA);
    for (const auto& residual : residuals)
        cv::circle(image, centre + cv::Point(int(residual.x * scale), int(residual.y * scale)), 1, colour, cv::FILLED);
    char words[120];
    std::snprintf(words, sizeof words, "%s: RMS %.3f px (circle), axes +-%.1f px", title.c_str(), rms, half_range);
    text(image, words, {area.x, area.y - 8});
}

std::string base64(const std::vector<uint8_t>& bytes) {
    static const char alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string encoded;
    for (size_t index = 0; index < bytes.size(); index += 3) {
        const uint32_t chunk = (uint32_t(bytes[index]) << 16) | (index + 1 < bytes.size() ? uint32_t(bytes[index + 1]) << 8 : 0) |
                               (index + 2 < bytes.size() ? uint32_t(bytes[index + 2]) : 0);
        encoded += alphabet[(chunk >> 18) & 63];
        encoded += alphabet[(chunk >> 12) & 63];
        encoded += index + 1 < bytes.size() ? alphabet[(chunk >> 6) & 63] : '=';
        encoded += index + 2 < bytes.size() ? alphabet[chunk & 63] : '=';
    }
    return encoded;
}

std::string png_data_uri(const cv::Mat& image) {
    std::vector<uint8_t> png;
    if (!detail::imencode(".png", image, png)) throw Error("calibration report", "cannot encode a picture");
    return "data:image/png;base64," + base64(png);
}

std::string escape_html(const std::string& text) {
    std::string escaped;
    for (char c : text) {
        if (c == '<') escaped += "&lt;";
        else if (c == '>') escaped += "&gt;";
        else if (c == '&') escaped += "&amp;";
        else escaped += c;
    }
    return escaped;
}

}  // namespace

cv::Mat plot_calibration_residuals(const CalibrationReport& report) {
    cv::Mat image(460, 900, CV_8UC3, cv::Scalar::all(255));
    residual_panel(image, {30, 40, 400, 400}, report.camera_residuals, "camera", report.camera_rms_px, kCameraColour);
    residual_panel(image, {470, 40, 400, 400}, report.projector_residuals, "projector", report.projector_rms_px,
                   kProjectorColour);
    return image;
}

cv::Mat plot_calibration_coverage(const CalibrationReport& report) {
    const cv::Size camera = report.calibration.camera_size;
    const double scale = 800.0 / std::max(camera.width, camera.height);
    cv::Mat image(int(camera.height * scale), int(camera.width * scale), CV_8UC3, cv::Scalar::all(245));
    for (int cell = 1; cell < 4; ++cell) {
        cv::line(image, {image.cols * cell / 4, 0}, {image.cols * cell / 4, image.rows}, kGrid);
        cv::line(image, {0, image.rows * cell / 4}, {image.cols, image.rows * cell / 4}, kGrid);
    }
    size_t corner = 0, pose_index = 0;
    for (const CalibrationPoseReport& pose : report.poses) {
        if (!pose.used) continue;
        for (int index = 0; index < pose.corners && corner < report.camera_corners.size(); ++index, ++corner)
            cv::circle(image, report.camera_corners[corner] * scale, 2, pose_colour(pose_index), cv::FILLED, cv::LINE_AA);
        ++pose_index;
    }
    cv::rectangle(image, {0, 0, image.cols, image.rows}, kInk);
    return image;
}

cv::Mat draw_calibration_rig(const CalibrationReport& report, const BoardSpec& board) {
    const Calibration& calibration = report.calibration;
    // World = camera frame. Frusta drawn 120 mm deep; boards as their outline of corners.
    const cv::Matx33d projector_to_camera = calibration.R.t();
    const cv::Vec3d projector_centre = -(projector_to_camera * calibration.T);
    auto frustum = [&](const cv::Matx33d& matrix, cv::Size size, const cv::Matx33d& to_world, const cv::Vec3d& origin) {
        std::vector<cv::Vec3d> corners{origin};
        for (const cv::Point2d pixel : {cv::Point2d(0, 0), cv::Point2d(size.width, 0), cv::Point2d(size.width, size.height),
                                        cv::Point2d(0, size.height)}) {
            const cv::Vec3d ray((pixel.x - matrix(0, 2)) / matrix(0, 0), (pixel.y - matrix(1, 2)) / matrix(1, 1), 1.0);
            corners.push_back(origin + to_world * (ray * 120.0));
        }
        return corners;
    };
    const auto camera = frustum(calibration.camera_matrix, calibration.camera_size, cv::Matx33d::eye(), {0, 0, 0});
    const auto projector = frustum(calibration.projector_matrix, calibration.projector_size, projector_to_camera, projector_centre);
    const std::vector<cv::Point3f> points = board_points(board);
    std::vector<std::vector<cv::Vec3d>> boards;
    for (const cv::Matx44d& pose : report.board_poses) {
        float max_x = 0, max_y = 0;
        for (const auto& point : points) max_x = std::max(max_x, point.x), max_y = std::max(max_y, point.y);
        std::vector<cv::Vec3d> outline;
        for (const cv::Vec3d& corner : {cv::Vec3d(0, 0, 0), cv::Vec3d(max_x, 0, 0), cv::Vec3d(max_x, max_y, 0), cv::Vec3d(0, max_y, 0)}) {
            const cv::Vec4d world = pose * cv::Vec4d(corner[0], corner[1], corner[2], 1);
            outline.emplace_back(world[0], world[1], world[2]);
        }
        boards.push_back(outline);
    }

    cv::Mat image(520, 1040, CV_8UC3, cv::Scalar::all(255));
    // Two views: from above (x right, z up the page) and oblique (turned 35 deg, looking down 25 deg).
    auto draw_view = [&](cv::Rect area, const cv::Matx33d& view, const std::string& title) {
        std::vector<cv::Vec3d> all(camera.begin(), camera.end());
        all.insert(all.end(), projector.begin(), projector.end());
        for (const auto& outline : boards) all.insert(all.end(), outline.begin(), outline.end());
        cv::Vec2d low(1e9, 1e9), high(-1e9, -1e9);
        for (const auto& point : all) {
            const cv::Vec3d seen = view * point;
            low = {std::min(low[0], seen[0]), std::min(low[1], seen[1])};
            high = {std::max(high[0], seen[0]), std::max(high[1], seen[1])};
        }
        const double scale = std::min((area.width - 40) / (high[0] - low[0] + 1e-9), (area.height - 60) / (high[1] - low[1] + 1e-9));
        auto to_pixel = [&](const cv::Vec3d& point) {
            const cv::Vec3d seen = view * point;
            return cv::Point(area.x + 20 + int((seen[0] - low[0]) * scale), area.y + area.height - 20 - int((seen[1] - low[1]) * scale));
        };
        auto draw_frustum = [&](const std::vector<cv::Vec3d>& corners, cv::Scalar colour, const std::string& label) {
            for (int index = 1; index <= 4; ++index) {
                cv::line(image, to_pixel(corners[0]), to_pixel(corners[index]), colour, 1, cv::LINE_AA);
                cv::line(image, to_pixel(corners[index]), to_pixel(corners[index % 4 + 1]), colour, 1, cv::LINE_AA);
            }
            text(image, label, to_pixel(corners[0]) + cv::Point(5, 15), 0.45, colour);
        };
        for (size_t index = 0; index < boards.size(); ++index)
            for (int edge = 0; edge < 4; ++edge)
                cv::line(image, to_pixel(boards[index][edge]), to_pixel(boards[index][(edge + 1) % 4]), pose_colour(index), 1,
                         cv::LINE_AA);
        draw_frustum(camera, kCameraColour, "camera");
        draw_frustum(projector, kProjectorColour, "projector");
        text(image, title, {area.x + 10, area.y + 20});
    };
    const cv::Matx33d above(1, 0, 0, 0, 0, 1, 0, 1, 0);  // page x = x, page y = z
    const double turn = 35 * CV_PI / 180, tilt = 25 * CV_PI / 180;
    const cv::Matx33d turn_matrix(std::cos(turn), 0, std::sin(turn), 0, 1, 0, -std::sin(turn), 0, std::cos(turn));
    const cv::Matx33d tilt_matrix(1, 0, 0, 0, std::cos(tilt), -std::sin(tilt), 0, std::sin(tilt), std::cos(tilt));
    const cv::Matx33d flip_y(1, 0, 0, 0, -1, 0, 0, 0, 1);  // camera y points down; the page's up
    draw_view({0, 0, 520, 520}, above, "from above (x right, depth up)");
    draw_view({520, 0, 520, 520}, flip_y * tilt_matrix * turn_matrix, "oblique");
    cv::line(image, {520, 10}, {520, 510}, kGrid);
    return image;
}

void write_calibration_report(const CalibrationReport& report, const BoardSpec& board, const std::string& path) {
    const Calibration& c = report.calibration;
    std::ostringstream html;
    char line[400];
    html << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>PicoScan calibration report</title>\n"
            "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}"
            "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
            "td:first-child,th:first-child{text-align:left}.bad{color:#b00}</style></head><body>\n"
            "<h1>Calibration report</h1>\n";
    std::snprintf(line, sizeof line,
                  "<p>Camera RMS reprojection error <b>%.3f px</b>, projector <b>%.3f px</b>, joint (stereo) %.3f px; "
                  "%zu of %zu poses used.</p>\n",
                  report.camera_rms_px, report.projector_rms_px, report.stereo_rms_px, report.board_poses.size(),
                  report.poses.size());
    html << line;
    for (const std::string& warning : report.warnings) html << "<p class=\"bad\">Warning: " << escape_html(warning) << "</p>\n";
    html << "<h2>Poses</h2>\n<table><tr><th>pose</th><th>corners</th><th>with projector point</th><th>camera RMS (px)</th>"
            "<th>projector RMS (px)</th><th>used</th></tr>\n";
    for (const CalibrationPoseReport& pose : report.poses) {
        std::snprintf(line, sizeof line, "<td>%d</td><td>%d</td><td>%.3f</td><td>%.3f</td>", pose.corners,
                      pose.projector_corners, pose.camera_rms_px, pose.projector_rms_px);
        html << "<tr><td>" << escape_html(pose.name) << "</td>" << line << "<td"
             << (pose.used ? ">yes" : " class=\"bad\">no: " + escape_html(pose.reason)) << "</td></tr>\n";
    }
    html << "</table>\n<h2>Parameters</h2>\n<table><tr><th></th><th>camera</th><th>projector</th></tr>\n";
    std::snprintf(line, sizeof line, "<tr><td>size (px)</td><td>%dx%d</td><td>%dx%d</td></tr>\n", c.camera_size.width,
                  c.camera_size.height, c.projector_size.width, c.projector_size.height);
    html << line;
    std::snprintf(line, sizeof line, "<tr><td>focal length fx, fy (px)</td><td>%.2f, %.2f</td><td>%.2f, %.2f</td></tr>\n",
                  c.camera_matrix(0, 0), c.camera_matrix(1, 1), c.projector_matrix(0, 0), c.projector_matrix(1, 1));
    html << line;
    std::snprintf(line, sizeof line, "<tr><td>principal point (px)</td><td>%.2f, %.2f</td><td>%.2f, %.2f</td></tr>\n",
                  c.camera_matrix(0, 2), c.camera_matrix(1, 2), c.projector_matrix(0, 2), c.projector_matrix(1, 2));
    html << line;
    auto coefficients = [](const cv::Mat& values) {
        std::string joined;
        for (int index = 0; index < int(values.total()); ++index) {
            char number[32];
            std::snprintf(number, sizeof number, "%s%.5f", index ? ", " : "", values.at<double>(index));
            joined += number;
        }
        return joined;
    };
    html << "<tr><td>distortion</td><td>" << coefficients(c.camera_distortion) << "</td><td>"
         << coefficients(c.projector_distortion) << "</td></tr>\n</table>\n";
    cv::Mat rotation_vector;
    cv::Rodrigues(cv::Mat(c.R), rotation_vector);
    std::snprintf(line, sizeof line,
                  "<p>Projector pose: baseline %.3f mm, T = (%.3f, %.3f, %.3f) mm, rotation %.3f&deg;.</p>\n",
                  cv::norm(c.T), c.T[0], c.T[1], c.T[2], cv::norm(rotation_vector) * 180 / CV_PI);
    html << line;
    html << "<h2>Residuals of every corner</h2>\n<img src=\"" << png_data_uri(plot_calibration_residuals(report)) << "\">\n"
         << "<h2>Where corners were seen (camera image, one colour per pose)</h2>\n<img src=\""
         << png_data_uri(plot_calibration_coverage(report)) << "\">\n"
         << "<h2>The rig</h2>\n<img src=\"" << png_data_uri(draw_calibration_rig(report, board)) << "\">\n</body></html>\n";
    write_file_atomically(path, html.str());
}

}  // namespace picoscan
