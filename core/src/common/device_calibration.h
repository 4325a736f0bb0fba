// Calibrating two devices (two cameras, or a camera and a projector) that saw the same board
// poses, each alone first (Zhang): the reprojection residuals and the dropping of poses whose
// error shows a bad detection. Shared by the camera-projector and the stereo calibration.
#pragma once

#include <opencv2/calib3d.hpp>

#include <cmath>
#include <functional>
#include <vector>

namespace picoscan::detail {

// One device's board points and their images, per usable pose (built once, then pruned).
struct DeviceObservations {
    cv::Size image_size;
    int flags = 0;  // cv::calibrateCamera flags (lens model)
    std::vector<std::vector<cv::Point3f>> board;
    std::vector<std::vector<cv::Point2f>> image;

    void erase_pose(size_t index) {
        board.erase(board.begin() + long(index));
        image.erase(image.begin() + long(index));
    }
};

struct DeviceCalibration {
    cv::Matx33d matrix;
    cv::Mat distortion;  // one row
    std::vector<cv::Mat> rotations, translations;  // board pose per pose
    std::vector<double> pose_rms_px;
};

inline const cv::TermCriteria kCalibrationCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12);

// measured - projected, per point.
inline std::vector<cv::Point2f> reprojection_residuals(const std::vector<cv::Point3f>& board,
                                                       const std::vector<cv::Point2f>& measured, const cv::Mat& rvec,
                                                       const cv::Mat& tvec, const cv::Matx33d& matrix,
                                                       const cv::Mat& distortion) {
    std::vector<cv::Point2f> projected;
    cv::projectPoints(board, rvec, tvec, matrix, distortion, projected);
    std::vector<cv::Point2f> residuals(measured.size());
    for (size_t index = 0; index < measured.size(); ++index) residuals[index] = measured[index] - projected[index];
    return residuals;
}

inline double rms(const std::vector<cv::Point2f>& residuals) {
    double sum = 0;
    for (const cv::Point2f& residual : residuals) sum += residual.dot(residual);
    return residuals.empty() ? 0 : std::sqrt(sum / residuals.size());
}

// Zhang's calibration of one device, with the RMS error of each pose.
inline DeviceCalibration calibrate_device(const DeviceObservations& observations) {
    DeviceCalibration result;
    cv::Mat matrix, distortion;
    cv::calibrateCamera(observations.board, observations.image, observations.image_size, matrix, distortion,
                        result.rotations, result.translations, observations.flags, kCalibrationCriteria);
    result.matrix = cv::Matx33d(matrix);
    result.distortion = distortion.reshape(1, 1);
    for (size_t pose = 0; pose < observations.board.size(); ++pose)
        result.pose_rms_px.push_back(rms(reprojection_residuals(observations.board[pose], observations.image[pose],
                                                                result.rotations[pose], result.translations[pose],
                                                                result.matrix, result.distortion)));
    return result;
}

// Calibrates both devices alone. When a pose's RMS in either exceeds `max_pose_rms_px`, the
// poses are erased from both observations and `drop(pose, first_rms, second_rms)` is told of
// each (highest index first, so the caller erases its own lists alike); `after_dropping` then
// runs (to refuse too few poses) and both devices are calibrated once more.
inline std::pair<DeviceCalibration, DeviceCalibration> calibrate_devices_dropping_bad_poses(
    DeviceObservations& first, DeviceObservations& second, double max_pose_rms_px,
    const std::function<void(size_t, double, double)>& drop, const std::function<void()>& after_dropping) {
    std::pair<DeviceCalibration, DeviceCalibration> fits{calibrate_device(first), calibrate_device(second)};
    bool dropped = false;
    for (size_t pose = first.board.size(); pose-- > 0;) {
        const double first_rms = fits.first.pose_rms_px[pose], second_rms = fits.second.pose_rms_px[pose];
        if (first_rms <= max_pose_rms_px && second_rms <= max_pose_rms_px) continue;
        first.erase_pose(pose);
        second.erase_pose(pose);
        drop(pose, first_rms, second_rms);
        dropped = true;
    }
    if (!dropped) return fits;
    after_dropping();
    return {calibrate_device(first), calibrate_device(second)};
}

}  // namespace picoscan::detail
