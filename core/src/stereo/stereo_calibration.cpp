// Stereo calibration files (PicoScan's keys and those of other tools), and calibrating two
// cameras from board poses.
#include "picoscan/stereo.h"

#include "common/pose_spread.h"
#include "picoscan/capture_set.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"

#include "common/board_image.h"
#include "common/calibration_reader.h"
#include "common/progress_reporter.h"
#include "common/storage_file.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <sstream>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;

// The names other tools give each entry, PicoScan's first.
const std::initializer_list<const char*> kLeftMatrix = {"camera1_matrix", "M1", "cam1_intrinsics"};
const std::initializer_list<const char*> kLeftDistortion = {"camera1_distortion", "D1", "cam1_distorsion", "cam1_distortion"};
const std::initializer_list<const char*> kLeftSize = {"camera1_size", "cam1_size"};
const std::initializer_list<const char*> kRightMatrix = {"camera2_matrix", "M2", "cam2_intrinsics"};
const std::initializer_list<const char*> kRightDistortion = {"camera2_distortion", "D2", "cam2_distorsion", "cam2_distortion"};
const std::initializer_list<const char*> kRightSize = {"camera2_size", "cam2_size"};
const std::initializer_list<const char*> kSharedSize = {"image_size", "S", "imageSize"};
const std::initializer_list<const char*> kRotation = {"R", "Rlr"};
const std::initializer_list<const char*> kTranslation = {"T", "Tlr"};

std::string names(std::initializer_list<const char*> keys) {
    std::string text;
    for (const char* key : keys) text += std::string(text.empty() ? "'" : ", '") + key + "'";
    return text;
}

// The one key of `keys` the file holds; "" when it holds none. Two of them is ambiguous.
std::string present_key(const detail::CalibrationReader& reader, std::initializer_list<const char*> keys) {
    std::string found;
    for (const char* key : keys) {
        if (!reader.has(key)) continue;
        if (!found.empty()) reader.fail("both '" + found + "' and '" + key + "' are given; keep one");
        found = key;
    }
    return found;
}

std::string required_key(const detail::CalibrationReader& reader, std::initializer_list<const char*> keys,
                          const std::string& what) {
    const std::string key = present_key(reader, keys);
    if (key.empty()) reader.fail("missing key '" + std::string(*keys.begin()) + "' (" + what + "; also read as " + names(keys) + ")");
    return key;
}

cv::Size camera_size(const detail::CalibrationReader& reader, std::initializer_list<const char*> own_keys, const char* which) {
    const std::string own = present_key(reader, own_keys), shared = present_key(reader, kSharedSize);
    if (own.empty() && shared.empty())
        reader.fail("missing key '" + std::string(*own_keys.begin()) + "' (the " + which +
                    " camera's image size [width, height]; also read as " + names(own_keys) +
                    ", or one size for both cameras as " + names(kSharedSize) + ")");
    if (!own.empty() && !shared.empty() && reader.size(own) != reader.size(shared))
        reader.fail("'" + own + "' and '" + shared + "' give different image sizes");
    return reader.size(own.empty() ? shared : own);
}

std::string size_text(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

double rms(const std::vector<double>& squares) {
    double sum = 0;
    for (double value : squares) sum += value;
    return squares.empty() ? 0 : std::sqrt(sum / squares.size());
}

std::vector<double> squared_residuals(const std::vector<cv::Point3f>& board, const std::vector<cv::Point2f>& measured,
                                      const cv::Mat& rvec, const cv::Mat& tvec, const cv::Matx33d& matrix,
                                      const cv::Mat& distortion) {
    std::vector<cv::Point2f> projected;
    cv::projectPoints(board, rvec, tvec, matrix, distortion, projected);
    std::vector<double> squares(measured.size());
    for (size_t index = 0; index < measured.size(); ++index) {
        const cv::Point2f residual = measured[index] - projected[index];
        squares[index] = residual.dot(residual);
    }
    return squares;
}

// Squared distances of the right points from the epipolar lines of the left points, on
// undistorted pixels.
std::vector<double> squared_epipolar_errors(const StereoCalibration& c, const std::vector<cv::Point2f>& left,
                                            const std::vector<cv::Point2f>& right) {
    std::vector<cv::Point2f> left_undistorted, right_undistorted;
    cv::undistortPoints(left, left_undistorted, cv::Mat(c.left_matrix), c.left_distortion, cv::noArray(), cv::Mat(c.left_matrix));
    cv::undistortPoints(right, right_undistorted, cv::Mat(c.right_matrix), c.right_distortion, cv::noArray(),
                        cv::Mat(c.right_matrix));
    const cv::Matx33d t_cross(0, -c.T[2], c.T[1], c.T[2], 0, -c.T[0], -c.T[1], c.T[0], 0);
    const cv::Matx33d fundamental = c.right_matrix.inv().t() * t_cross * c.R * c.left_matrix.inv();
    std::vector<double> squares(left.size());
    for (size_t index = 0; index < left.size(); ++index) {
        const cv::Vec3d line = fundamental * cv::Vec3d(left_undistorted[index].x, left_undistorted[index].y, 1);
        const double distance = (line[0] * right_undistorted[index].x + line[1] * right_undistorted[index].y + line[2]) /
                                std::hypot(line[0], line[1]);
        squares[index] = distance * distance;
    }
    return squares;
}

// Board corners both cameras found in one pose.
struct PosePair {
    std::vector<cv::Point3f> board;
    std::vector<cv::Point2f> left, right;
};

}  // namespace

double StereoCalibration::baseline_mm() const { return cv::norm(R.t() * T); }

void validate_stereo_calibration(const StereoCalibration& c, const std::string& source) {
    auto fail = [&](const std::string& problem) { throw Error(source, problem); };
    auto check_size = [&](cv::Size size, const char* key) {
        if (size.width < 2 || size.height < 2 || size.width > 65536 || size.height > 65536)
            fail(std::string("'") + key + "' must be a positive image size");
    };
    check_size(c.left_size, "camera1_size");
    check_size(c.right_size, "camera2_size");
    auto check_intrinsics = [&](const cv::Matx33d& matrix, const char* key) {
        if (!(matrix(0, 0) > 0) || !(matrix(1, 1) > 0) || matrix(2, 0) != 0 || matrix(2, 1) != 0 || matrix(2, 2) != 1 ||
            !cv::checkRange(cv::Mat(matrix)))
            fail(std::string("'") + key + "' must be an intrinsic matrix [fx s cx; 0 fy cy; 0 0 1] with fx, fy > 0");
    };
    check_intrinsics(c.left_matrix, "camera1_matrix");
    check_intrinsics(c.right_matrix, "camera2_matrix");
    auto check_distortion = [&](const cv::Mat& coefficients, const char* key) {
        const int count = int(coefficients.total());
        if ((count != 4 && count != 5 && count != 8 && count != 12 && count != 14) || !cv::checkRange(coefficients))
            fail(std::string("'") + key + "' must hold 4, 5, 8, 12 or 14 finite coefficients");
        if (count == 14 && (coefficients.at<double>(12) != 0 || coefficients.at<double>(13) != 0))
            fail(std::string("'") + key + "': tilted-sensor terms (tau x, tau y) are not supported");
    };
    check_distortion(c.left_distortion, "camera1_distortion");
    check_distortion(c.right_distortion, "camera2_distortion");
    const cv::Matx33d should_be_identity = c.R.t() * c.R;
    if (cv::norm(should_be_identity - cv::Matx33d::eye()) > 1e-4 || cv::determinant(c.R) < 0)
        fail("'R' must be a rotation matrix");
    if (!cv::checkRange(cv::Mat(c.T)) || cv::norm(c.T) < 1e-9)
        fail("'T' must be a finite, non-zero translation (the baseline between the cameras)");
}

CalibrationKind calibration_kind(const std::string& path) {
    const detail::CalibrationReader reader(path, detail::parse_storage_text(detail::read_text_file(path, "calibration file"), path));
    return present_key(reader, kRightMatrix).empty() ? CalibrationKind::CameraProjector : CalibrationKind::Stereo;
}

StereoCalibration read_stereo_calibration(const std::string& path) {
    const detail::CalibrationReader reader(path, detail::parse_storage_text(detail::read_text_file(path, "calibration file"), path));
    StereoCalibration c;
    c.left_matrix = cv::Matx33d(reader.matrix(required_key(reader, kLeftMatrix, "the first camera's intrinsic matrix"), 3, 3));
    c.left_distortion = reader.distortion(required_key(reader, kLeftDistortion, "the first camera's distortion"));
    c.right_matrix = cv::Matx33d(reader.matrix(required_key(reader, kRightMatrix, "the second camera's intrinsic matrix"), 3, 3));
    c.right_distortion = reader.distortion(required_key(reader, kRightDistortion, "the second camera's distortion"));
    c.left_size = camera_size(reader, kLeftSize, "first");
    c.right_size = camera_size(reader, kRightSize, "second");
    c.R = cv::Matx33d(reader.matrix(required_key(reader, kRotation, "rotation from the first camera to the second"), 3, 3));
    c.T = cv::Vec3d(reader.matrix(required_key(reader, kTranslation, "translation from the first camera to the second, mm"), 3, 1));
    validate_stereo_calibration(c, path);
    return c;
}

void write_stereo_calibration(const StereoCalibration& c, const std::string& path) {
    validate_stereo_calibration(c, "stereo calibration");
    const int format = detail::storage_format_for(path);
    cv::FileStorage storage("stereo", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | format);
    if (format != cv::FileStorage::FORMAT_JSON)  // JSON has no comments
        storage.writeComment("PicoScan stereo calibration, millimetres. X_camera2 = R * X_camera1 + T.");
    storage << "camera1_size" << std::vector<int>{c.left_size.width, c.left_size.height};
    storage << "camera1_matrix" << cv::Mat(c.left_matrix);
    storage << "camera1_distortion" << c.left_distortion;
    storage << "camera2_size" << std::vector<int>{c.right_size.width, c.right_size.height};
    storage << "camera2_matrix" << cv::Mat(c.right_matrix);
    storage << "camera2_distortion" << c.right_distortion;
    storage << "R" << cv::Mat(c.R);
    storage << "T" << cv::Mat(c.T);
    write_file_atomically(path, storage.releaseAndGetString());
}

StereoCalibration stereo_from_projector_calibrations(const Calibration& left, const Calibration& right) {
    // X_p = R_l X_l + T_l = R_r X_r + T_r  =>  X_r = R_r^T R_l X_l + R_r^T (T_l - T_r)
    StereoCalibration c;
    c.left_size = left.camera_size;
    c.right_size = right.camera_size;
    c.left_matrix = left.camera_matrix;
    c.right_matrix = right.camera_matrix;
    c.left_distortion = left.camera_distortion.clone();
    c.right_distortion = right.camera_distortion.clone();
    c.R = right.R.t() * left.R;
    c.T = right.R.t() * (left.T - right.T);
    return c;
}

cv::Mat load_board_image(const std::string& directory, const std::string& manifest) {
    namespace fs = std::filesystem;
    if (!manifest.empty() || fs::exists(fs::path(directory) / "sequence.json")) {
        const cv::Mat image = detail::board_image(load_capture_set(directory, manifest));
        if (image.empty()) throw Error(directory, "has no white frame or phase frames to find the board in");
        return image;
    }
    std::error_code error;
    if (!fs::is_directory(directory, error)) throw Error(directory, "is not a folder");
    std::vector<fs::path> images;
    for (const auto& entry : fs::directory_iterator(directory, error)) {
        std::string extension = entry.path().extension().string();
        for (char& c : extension) c = char(std::tolower(static_cast<unsigned char>(c)));
        for (const char* known : {".png", ".bmp", ".jpg", ".jpeg", ".tif", ".tiff"})
            if (extension == known) images.push_back(entry.path());
    }
    if (images.size() != 1)
        throw Error(directory, "holds " + std::to_string(images.size()) +
                                   " images and no sequence.json; a pose folder needs one board image or a capture set");
    return read_image_file(images.front().string(), cv::IMREAD_UNCHANGED);
}

StereoCalibrationReport calibrate_stereo(const std::vector<StereoBoardView>& views, const BoardSpec& board,
                                         const StereoCalibrateOptions& options, const ProgressCallback& progress) {
    if (views.empty()) throw Error("--captures", "no board poses given");
    const cv::Size left_size = views.front().left.size(), right_size = views.front().right.size();
    for (const StereoBoardView& view : views) {
        if (view.left.empty() || view.right.empty()) throw Error(view.name, "a board image is missing");
        if (view.left.size() != left_size)
            throw Error(view.name, "first camera's image is " + size_text(view.left.size()) + " but " +
                                       views.front().name + "'s is " + size_text(left_size));
        if (view.right.size() != right_size)
            throw Error(view.name, "second camera's image is " + size_text(view.right.size()) + " but " +
                                       views.front().name + "'s is " + size_text(right_size));
    }
    detail::ProgressReporter reporter(progress, "calibrate", int(views.size()) + 2);
    auto advance = [&] {
        if (!reporter.advance()) throw Error("cancelled", "stereo calibration cancelled");
    };

    StereoCalibrationReport report;
    std::vector<PosePair> pairs;
    std::vector<size_t> pose_of;  // report index of each usable pose
    const std::vector<cv::Point3f> model = board_points(board);
    for (const StereoBoardView& view : views) {
        StereoPoseReport pose;
        pose.name = view.name;
        auto grey = [](const cv::Mat& image) {
            if (image.channels() == 1) return image;
            cv::Mat converted;
            cv::cvtColor(image, converted, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
            return converted;
        };
        BoardDetection left, right;
        if (!detect_board(grey(view.left), board, left)) pose.reason = "board not found in the first camera's image";
        else if (!detect_board(grey(view.right), board, right)) pose.reason = "board not found in the second camera's image";
        else {
            PosePair pair;
            for (size_t a = 0; a < left.point_ids.size(); ++a)
                for (size_t b = 0; b < right.point_ids.size(); ++b)
                    if (left.point_ids[a] == right.point_ids[b]) {
                        pair.board.push_back(model[size_t(left.point_ids[a])]);
                        pair.left.push_back(left.image_points[a]);
                        pair.right.push_back(right.image_points[b]);
                    }
            pose.corners = int(pair.board.size());
            if (pair.board.size() < 6) pose.reason = "only " + std::to_string(pair.board.size()) + " corners seen by both cameras";
            else {
                pose.used = true;
                pairs.push_back(std::move(pair));
                pose_of.push_back(report.poses.size());
            }
        }
        report.poses.push_back(pose);
        advance();
    }
    auto require_enough = [&](const std::string& stage) {
        if (int(pairs.size()) >= options.min_views) return;
        std::string problems;
        for (const auto& pose : report.poses)
            if (!pose.used) problems += "; " + pose.name + ": " + pose.reason;
        throw Error("--captures", "only " + std::to_string(pairs.size()) + " usable board poses" + stage + " (at least " +
                                      std::to_string(options.min_views) + " needed)" + problems);
    };
    require_enough("");

    StereoCalibration& c = report.calibration;
    c.left_size = left_size;
    c.right_size = right_size;
    const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12);
    const int lens_flags = options.radial_k3 ? 0 : cv::CALIB_FIX_K3;
    // Each camera alone first (Zhang), dropping poses whose error shows a bad detection.
    std::vector<cv::Mat> left_rotations, left_translations;
    for (int round = 0; round < 2; ++round) {
        std::vector<std::vector<cv::Point3f>> boards;
        std::vector<std::vector<cv::Point2f>> lefts, rights;
        for (const PosePair& pair : pairs) {
            boards.push_back(pair.board);
            lefts.push_back(pair.left);
            rights.push_back(pair.right);
        }
        cv::Mat left_matrix, left_distortion, right_matrix, right_distortion;
        std::vector<cv::Mat> right_rotations, right_translations;
        cv::calibrateCamera(boards, lefts, left_size, left_matrix, left_distortion, left_rotations, left_translations, lens_flags,
                            criteria);
        cv::calibrateCamera(boards, rights, right_size, right_matrix, right_distortion, right_rotations, right_translations,
                            lens_flags, criteria);
        c.left_matrix = cv::Matx33d(left_matrix);
        c.right_matrix = cv::Matx33d(right_matrix);
        c.left_distortion = left_distortion.reshape(1, 1);
        c.right_distortion = right_distortion.reshape(1, 1);
        std::vector<size_t> bad;
        for (size_t index = 0; index < pairs.size(); ++index) {
            StereoPoseReport& pose = report.poses[pose_of[index]];
            pose.left_rms_px = rms(squared_residuals(pairs[index].board, pairs[index].left, left_rotations[index],
                                                     left_translations[index], c.left_matrix, c.left_distortion));
            pose.right_rms_px = rms(squared_residuals(pairs[index].board, pairs[index].right, right_rotations[index],
                                                      right_translations[index], c.right_matrix, c.right_distortion));
            if (round == 0 && (pose.left_rms_px > options.max_view_rms_px || pose.right_rms_px > options.max_view_rms_px))
                bad.push_back(index);
        }
        if (bad.empty()) break;
        for (auto it = bad.rbegin(); it != bad.rend(); ++it) {
            StereoPoseReport& pose = report.poses[pose_of[*it]];
            pose.used = false;
            char reason[160];
            std::snprintf(reason, sizeof reason, "reprojection error too large (first camera %.2f px, second %.2f px)",
                          pose.left_rms_px, pose.right_rms_px);
            pose.reason = reason;
            pairs.erase(pairs.begin() + long(*it));
            pose_of.erase(pose_of.begin() + long(*it));
        }
        require_enough(" after dropping poses with large errors");
    }

    detail::require_pose_spread(left_rotations, options.min_pose_spread_deg);
    advance();

    // Both cameras and their relative pose, refined together.
    {
        std::vector<std::vector<cv::Point3f>> boards;
        std::vector<std::vector<cv::Point2f>> lefts, rights;
        for (const PosePair& pair : pairs) {
            boards.push_back(pair.board);
            lefts.push_back(pair.left);
            rights.push_back(pair.right);
        }
        cv::Mat left_matrix(c.left_matrix), right_matrix(c.right_matrix), R, T, essential, fundamental;
        report.stereo_rms_px = cv::stereoCalibrate(boards, lefts, rights, left_matrix, c.left_distortion, right_matrix,
                                                   c.right_distortion, left_size, R, T, essential, fundamental,
                                                   cv::CALIB_USE_INTRINSIC_GUESS | lens_flags, criteria);
        c.left_matrix = cv::Matx33d(left_matrix);
        c.right_matrix = cv::Matx33d(right_matrix);
        c.R = cv::Matx33d(R);
        c.T = cv::Vec3d(T);
    }

    // Final errors per pose with the joint model: the board pose from the first camera, the
    // second camera's view of it through R, T.
    std::vector<double> all_left, all_right, all_epipolar;
    for (size_t index = 0; index < pairs.size(); ++index) {
        const PosePair& pair = pairs[index];
        cv::Mat rvec, tvec;
        cv::solvePnP(pair.board, pair.left, cv::Mat(c.left_matrix), c.left_distortion, rvec, tvec);
        cv::solvePnPRefineLM(pair.board, pair.left, cv::Mat(c.left_matrix), c.left_distortion, rvec, tvec);
        cv::Matx33d board_rotation;
        cv::Rodrigues(rvec, board_rotation);
        cv::Mat right_rvec;
        cv::Rodrigues(cv::Mat(c.R * board_rotation), right_rvec);
        const cv::Vec3d right_translation = c.R * cv::Vec3d(tvec) + c.T;
        const auto left_squares = squared_residuals(pair.board, pair.left, rvec, tvec, c.left_matrix, c.left_distortion);
        const auto right_squares =
            squared_residuals(pair.board, pair.right, right_rvec, cv::Mat(right_translation), c.right_matrix, c.right_distortion);
        const auto epipolar_squares = squared_epipolar_errors(c, pair.left, pair.right);
        StereoPoseReport& pose = report.poses[pose_of[index]];
        pose.left_rms_px = rms(left_squares);
        pose.right_rms_px = rms(right_squares);
        pose.epipolar_rms_px = rms(epipolar_squares);
        all_left.insert(all_left.end(), left_squares.begin(), left_squares.end());
        all_right.insert(all_right.end(), right_squares.begin(), right_squares.end());
        all_epipolar.insert(all_epipolar.end(), epipolar_squares.begin(), epipolar_squares.end());
    }
    report.left_rms_px = rms(all_left);
    report.right_rms_px = rms(all_right);
    report.epipolar_rms_px = rms(all_epipolar);
    if (int(pairs.size()) < options.recommended_views)
        report.warnings.push_back("only " + std::to_string(pairs.size()) + " usable poses; " +
                                  std::to_string(options.recommended_views) + " or more give a steadier calibration");
    validate_stereo_calibration(c, "stereo calibration result");
    advance();
    return report;
}

void write_stereo_calibration_report(const StereoCalibrationReport& report, const std::string& path) {
    auto escape = [](const std::string& text) {
        std::string escaped;
        for (char c : text) escaped += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
        return escaped;
    };
    auto number = [](double value, int decimals) {
        char text[64];
        std::snprintf(text, sizeof text, "%.*f", decimals, value);
        return std::string(text);
    };
    const StereoCalibration& c = report.calibration;
    std::ostringstream html;
    html << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>PicoScan stereo calibration report</title>\n"
            "<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}td,th{border:1px solid #ccc;"
            "padding:3px 8px;text-align:right}.bad{color:#b00}</style></head><body>\n<h1>Stereo calibration</h1>\n";
    html << "<p>RMS reprojection error: first camera " << number(report.left_rms_px, 3) << " px, second camera "
         << number(report.right_rms_px, 3) << " px (joint " << number(report.stereo_rms_px, 3)
         << " px); epipolar error (RMS distance of the second camera's corners from their epipolar lines) "
         << number(report.epipolar_rms_px, 3) << " px.</p>\n";
    for (const std::string& warning : report.warnings) html << "<p class=\"bad\">Warning: " << escape(warning) << "</p>\n";
    html << "<h2>Poses</h2>\n<table><tr><th>pose</th><th>corners</th><th>first camera RMS (px)</th>"
            "<th>second camera RMS (px)</th><th>epipolar RMS (px)</th><th>used</th></tr>\n";
    for (const StereoPoseReport& pose : report.poses)
        html << "<tr><td>" << escape(pose.name) << "</td><td>" << pose.corners << "</td><td>" << number(pose.left_rms_px, 3)
             << "</td><td>" << number(pose.right_rms_px, 3) << "</td><td>" << number(pose.epipolar_rms_px, 3) << "</td><td"
             << (pose.used ? ">yes" : " class=\"bad\">no: " + escape(pose.reason)) << "</td></tr>\n";
    const cv::Vec3d right_centre = -(c.R.t() * c.T);
    cv::Vec3d rotation_vector;
    cv::Rodrigues(cv::Mat(c.R), rotation_vector);
    html << "</table>\n<h2>Rig</h2>\n<p>Second camera centre in the first camera's frame: (" << number(right_centre[0], 2)
         << ", " << number(right_centre[1], 2) << ", " << number(right_centre[2], 2) << ") mm; baseline "
         << number(c.baseline_mm(), 3) << " mm; rotation between the cameras " << number(cv::norm(rotation_vector) * 180 / kPi, 3)
         << " deg.</p>\n<table><tr><th></th><th>first camera</th><th>second camera</th></tr>\n";
    html << "<tr><td>image size</td><td>" << size_text(c.left_size) << "</td><td>" << size_text(c.right_size) << "</td></tr>\n";
    html << "<tr><td>fx, fy (px)</td><td>" << number(c.left_matrix(0, 0), 2) << ", " << number(c.left_matrix(1, 1), 2)
         << "</td><td>" << number(c.right_matrix(0, 0), 2) << ", " << number(c.right_matrix(1, 1), 2) << "</td></tr>\n";
    html << "<tr><td>cx, cy (px)</td><td>" << number(c.left_matrix(0, 2), 2) << ", " << number(c.left_matrix(1, 2), 2)
         << "</td><td>" << number(c.right_matrix(0, 2), 2) << ", " << number(c.right_matrix(1, 2), 2) << "</td></tr>\n";
    auto coefficients = [&](const cv::Mat& values) {
        std::string text;
        for (size_t index = 0; index < values.total(); ++index)
            text += (index ? " " : "") + number(values.at<double>(int(index)), 5);
        return text;
    };
    html << "<tr><td>distortion</td><td>" << coefficients(c.left_distortion) << "</td><td>" << coefficients(c.right_distortion)
         << "</td></tr>\n</table>\n</body></html>\n";
    write_file_atomically(path, html.str());
}

}  // namespace picoscan
