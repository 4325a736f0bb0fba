// Camera + projector calibration from board poses (Zhang's method for both devices, the
// projector's board points found through local homographies, Moreno & Taubin 2012).
#include "picoscan/board.h"
#include "picoscan/calibrate.h"
#include "picoscan/calibration.h"
#include "common/pose_spread.h"
#include "picoscan/error.h"

#include "common/board_image.h"
#include "common/device_calibration.h"
#include "common/progress_reporter.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <sstream>

namespace picoscan {

namespace {

std::string size_text(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

// Projector point of a camera corner: a homography fitted on the decoded pixels around it.
bool projector_point(const CorrespondenceMap& map, const cv::Point2f& corner, const CalibrateOptions& options,
                     cv::Point2f& projected) {
    const int half = options.homography_half_window_px;
    const int x0 = std::max(0, int(std::lround(corner.x)) - half), x1 = std::min(map.projector_u.cols - 1, int(std::lround(corner.x)) + half);
    const int y0 = std::max(0, int(std::lround(corner.y)) - half), y1 = std::min(map.projector_u.rows - 1, int(std::lround(corner.y)) + half);
    std::vector<cv::Point2f> camera, projector;
    for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
            const float u = map.projector_u.at<float>(y, x), v = map.projector_v.at<float>(y, x);
            if (std::isfinite(u) && std::isfinite(v)) {
                camera.emplace_back(float(x), float(y));
                projector.emplace_back(u, v);
            }
        }
    if (int(camera.size()) < options.min_homography_pixels) return false;
    // RANSAC drops stray codes at square edges; the inliers are then refined by least squares.
    const cv::Mat homography = cv::findHomography(camera, projector, cv::RANSAC, 1.0);
    if (homography.empty()) return false;
    std::vector<cv::Point2f> mapped;
    cv::perspectiveTransform(std::vector<cv::Point2f>{corner}, mapped, homography);
    projected = mapped.front();
    return std::isfinite(projected.x) && std::isfinite(projected.y);
}

}  // namespace

PoseObservation observe_pose(const CaptureSet& pose, const BoardSpec& board, const CalibrateOptions& options) {
    PoseObservation observation;
    observation.name = pose.directory;
    observation.camera_size = pose.images.front().size();
    observation.projector_size = pose.sequence.projector_size;
    if (!pose.sequence.columns.used() || !pose.sequence.rows.used())
        throw Error(pose.directory, "projector calibration needs the columns and the rows encoded (patterns --rows)");
    BoardDetection detection;
    const cv::Mat image = detail::board_image(pose);
    if (image.empty() || !detect_board(image, board, detection)) {
        observation.problem = "board not found in the white frame";
        return observation;
    }
    const std::vector<cv::Point3f> model = board_points(board);
    const CorrespondenceMap map = decode(pose, options.decode);
    for (size_t index = 0; index < detection.image_points.size(); ++index) {
        observation.board_points.push_back(model[size_t(detection.point_ids[index])]);
        observation.camera_points.push_back(detection.image_points[index]);
        cv::Point2f projected;
        if (projector_point(map, detection.image_points[index], options, projected)) {
            observation.projector_corner.push_back(int(index));
            observation.projector_points.push_back(projected);
        }
    }
    const size_t found = observation.camera_points.size(), mapped = observation.projector_points.size();
    if (mapped < options.min_corner_fraction * found || mapped < 6)
        observation.problem = "projector codes cover only " + std::to_string(mapped) + " of " + std::to_string(found) +
                              " corners";
    return observation;
}

CalibrationReport calibrate_rig(const std::vector<PoseObservation>& poses, const CalibrateOptions& options,
                                const ProgressCallback& progress) {
    if (poses.empty()) throw Error("--captures", "no board poses given");
    const cv::Size camera_size = poses.front().camera_size;
    const cv::Size projector_size = poses.front().projector_size;
    for (const PoseObservation& pose : poses) {
        if (pose.camera_size != camera_size)
            throw Error(pose.name, "images are " + size_text(pose.camera_size) + " but " + poses.front().name + " has " +
                                       size_text(camera_size));
        if (pose.projector_size != projector_size)
            throw Error(pose.name, "projector size " + size_text(pose.projector_size) + " differs from " +
                                       poses.front().name + "'s " + size_text(projector_size));
    }

    CalibrationReport report;
    Calibration& calibration = report.calibration;
    calibration.camera_size = camera_size;
    calibration.projector_size = projector_size;
    const int lens_flags = options.radial_k1_only ? cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 : 0;
    const int camera_flags = lens_flags | (options.camera_principal_point_at_centre ? cv::CALIB_FIX_PRINCIPAL_POINT : 0);
    // The corners of each usable pose, split into the sets each device is calibrated with (the
    // projector's: the corners with a projector point, with their camera points for the joint
    // refinement). Built once, pruned when poses are dropped.
    detail::DeviceObservations camera_views{camera_size, camera_flags, {}, {}}, projector_views{projector_size, lens_flags, {}, {}};
    std::vector<std::vector<cv::Point2f>> camera_with_projector;
    std::vector<size_t> pose_of;  // report index of each usable pose
    detail::ProgressReporter reporter(progress, "calibrate", 3);
    for (const PoseObservation& pose : poses) {
        CalibrationPoseReport pose_report;
        pose_report.name = pose.name;
        pose_report.corners = int(pose.camera_points.size());
        pose_report.projector_corners = int(pose.projector_points.size());
        pose_report.reason = pose.problem;
        pose_report.used = pose.problem.empty();
        if (pose_report.used) {
            camera_views.board.push_back(pose.board_points);
            camera_views.image.push_back(pose.camera_points);
            std::vector<cv::Point3f> board_with_projector;
            std::vector<cv::Point2f> camera_points;
            for (int corner : pose.projector_corner) {
                board_with_projector.push_back(pose.board_points[size_t(corner)]);
                camera_points.push_back(pose.camera_points[size_t(corner)]);
            }
            projector_views.board.push_back(board_with_projector);
            projector_views.image.push_back(pose.projector_points);
            camera_with_projector.push_back(camera_points);
            pose_of.push_back(report.poses.size());
        }
        report.poses.push_back(pose_report);
    }

    auto require_enough = [&](const std::string& stage) {
        if (int(pose_of.size()) >= options.min_views) return;
        std::string problems;
        for (const auto& pose : report.poses)
            if (!pose.used) problems += "; " + pose.name + ": " + pose.reason;
        throw Error("--captures", "only " + std::to_string(pose_of.size()) + " usable board poses" + stage +
                                      " (at least " + std::to_string(options.min_views) + " needed)" + problems);
    };
    require_enough("");

    // Each device alone first (Zhang: homographies give the initial guess), dropping poses
    // whose reprojection error shows a bad detection, then both together.
    const auto [camera_fit, projector_fit] = detail::calibrate_devices_dropping_bad_poses(
        camera_views, projector_views, options.max_view_rms_px,
        [&](size_t index, double camera_rms, double projector_rms) {
            CalibrationPoseReport& pose_report = report.poses[pose_of[index]];
            pose_report.used = false;
            pose_report.camera_rms_px = camera_rms;
            pose_report.projector_rms_px = projector_rms;
            char reason[160];
            std::snprintf(reason, sizeof reason, "reprojection error too large (camera %.2f px, projector %.2f px)",
                          camera_rms, projector_rms);
            pose_report.reason = reason;
            camera_with_projector.erase(camera_with_projector.begin() + long(index));
            pose_of.erase(pose_of.begin() + long(index));
        },
        [&] { require_enough(" after dropping poses with large errors"); });
    reporter.advance();

    detail::require_pose_spread(camera_fit.rotations, options.min_pose_spread_deg);

    // Both devices and their relative pose, refined together.
    {
        cv::Mat camera_matrix(camera_fit.matrix), projector_matrix(projector_fit.matrix);
        calibration.camera_distortion = camera_fit.distortion;
        calibration.projector_distortion = projector_fit.distortion;
        cv::Mat R, T, essential, fundamental;
        report.stereo_rms_px = cv::stereoCalibrate(projector_views.board, camera_with_projector, projector_views.image,
                                                   camera_matrix, calibration.camera_distortion, projector_matrix,
                                                   calibration.projector_distortion, camera_size, R, T, essential,
                                                   fundamental, cv::CALIB_USE_INTRINSIC_GUESS | camera_flags,
                                                   detail::kCalibrationCriteria);
        calibration.camera_matrix = cv::Matx33d(camera_matrix);
        calibration.projector_matrix = cv::Matx33d(projector_matrix);
        calibration.R = cv::Matx33d(R);
        calibration.T = cv::Vec3d(T);
    }
    reporter.advance();

    // Final residuals per pose with the joint model: the board pose from the camera, the
    // projector's view of it through R, T.
    std::vector<cv::Point2f> all_camera, all_projector;
    for (size_t index = 0; index < pose_of.size(); ++index) {
        const std::vector<cv::Point3f>& board = camera_views.board[index];
        const std::vector<cv::Point2f>& camera = camera_views.image[index];
        cv::Mat rvec, tvec;
        cv::solvePnP(board, camera, cv::Mat(calibration.camera_matrix), calibration.camera_distortion, rvec, tvec);
        cv::solvePnPRefineLM(board, camera, cv::Mat(calibration.camera_matrix), calibration.camera_distortion, rvec, tvec);
        cv::Matx33d board_rotation;
        cv::Rodrigues(rvec, board_rotation);
        const cv::Matx33d projector_rotation = calibration.R * board_rotation;
        const cv::Vec3d projector_translation = calibration.R * cv::Vec3d(tvec) + calibration.T;
        cv::Mat projector_rvec;
        cv::Rodrigues(cv::Mat(projector_rotation), projector_rvec);
        const auto camera_residual =
            detail::reprojection_residuals(board, camera, rvec, tvec, calibration.camera_matrix, calibration.camera_distortion);
        const auto projector_residual = detail::reprojection_residuals(
            projector_views.board[index], projector_views.image[index], projector_rvec, cv::Mat(projector_translation),
            calibration.projector_matrix, calibration.projector_distortion);
        CalibrationPoseReport& pose_report = report.poses[pose_of[index]];
        pose_report.camera_rms_px = detail::rms(camera_residual);
        pose_report.projector_rms_px = detail::rms(projector_residual);
        all_camera.insert(all_camera.end(), camera_residual.begin(), camera_residual.end());
        all_projector.insert(all_projector.end(), projector_residual.begin(), projector_residual.end());
        report.camera_corners.insert(report.camera_corners.end(), camera.begin(), camera.end());
        cv::Matx44d board_to_camera = cv::Matx44d::eye();
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) board_to_camera(r, c) = board_rotation(r, c);
            board_to_camera(r, 3) = tvec.at<double>(r);
        }
        report.board_poses.push_back(board_to_camera);
    }
    report.camera_residuals = all_camera;
    report.projector_residuals = all_projector;
    report.camera_rms_px = detail::rms(all_camera);
    report.projector_rms_px = detail::rms(all_projector);

    // Advice: too few poses, or corners seen in too little of the image.
    if (int(pose_of.size()) < options.recommended_views)
        report.warnings.push_back("only " + std::to_string(pose_of.size()) + " usable poses; " +
                                  std::to_string(options.recommended_views) + " or more give a steadier calibration");
    constexpr int kCells = 4;
    std::vector<bool> covered(kCells * kCells, false);
    for (const cv::Point2f& point : report.camera_corners) {
        const int cx = std::clamp(int(point.x * kCells / camera_size.width), 0, kCells - 1);
        const int cy = std::clamp(int(point.y * kCells / camera_size.height), 0, kCells - 1);
        covered[size_t(cy * kCells + cx)] = true;
    }
    const int covered_cells = int(std::count(covered.begin(), covered.end(), true));
    if (covered_cells < kCells * kCells * 3 / 4)
        report.warnings.push_back("board corners were seen in only " + std::to_string(covered_cells) + " of " +
                                  std::to_string(kCells * kCells) +
                                  " image cells; add poses with the board near the edges and corners of the view");
    validate_calibration(calibration, "calibration result");
    reporter.advance();
    return report;
}

namespace detail {

cv::Mat board_image(const CaptureSet& captures) {
    const auto& frames = captures.sequence.frames;
    for (size_t index = 0; index < frames.size(); ++index)
        if (frames[index].kind == FrameKind::White) return captures.images[index];
    cv::Mat sum;
    int count = 0;
    for (size_t index = 0; index < frames.size(); ++index) {
        if (frames[index].kind != FrameKind::Phase) continue;
        cv::Mat frame;
        captures.images[index].convertTo(frame, CV_32F);
        sum = sum.empty() ? frame : sum + frame;
        ++count;
    }
    if (count == 0) return cv::Mat();
    cv::Mat mean;
    sum.convertTo(mean, captures.images.front().depth(), 1.0 / count);
    return mean;
}

}  // namespace detail

}  // namespace picoscan
