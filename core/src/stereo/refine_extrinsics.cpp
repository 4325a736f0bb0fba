// The stereo rig's rotation and baseline direction from the codes both cameras decoded.
#include "picoscan/stereo.h"

#include "picoscan/error.h"

#include "common/lens.h"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <map>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Centroid of the pixels of each projector code cell (rounded u, v): sub-pixel even where a
// binary code gives whole projector pixels only.
std::map<long long, cv::Vec3d> code_cells(const CorrespondenceMap& map) {
    std::map<long long, cv::Vec3d> cells;  // x sum, y sum, count
    for (int y = 0; y < map.projector_u.rows; ++y) {
        const float* u = map.projector_u.ptr<float>(y);
        const float* v = map.projector_v.ptr<float>(y);
        for (int x = 0; x < map.projector_u.cols; ++x) {
            if (!std::isfinite(u[x]) || !std::isfinite(v[x])) continue;
            const long long key = std::llround(v[x]) * 100000LL + std::llround(u[x]);
            cells[key] += cv::Vec3d(x, y, 1);
        }
    }
    return cells;
}

// Distance (in normalised first-camera units) of each pair from its epipolar line.
std::vector<double> epipolar_distances(const std::vector<cv::Point2d>& first, const std::vector<cv::Point2d>& second,
                                       const cv::Matx33d& R, const cv::Vec3d& T) {
    const cv::Matx33d t_cross(0, -T[2], T[1], T[2], 0, -T[0], -T[1], T[0], 0);
    const cv::Matx33d essential = t_cross * R;
    std::vector<double> distances(first.size());
    for (size_t index = 0; index < first.size(); ++index) {
        // Line in the first image of the second point: E^T x2.
        const cv::Vec3d line = essential.t() * cv::Vec3d(second[index].x, second[index].y, 1);
        distances[index] = std::abs(line[0] * first[index].x + line[1] * first[index].y + line[2]) / std::hypot(line[0], line[1]);
    }
    return distances;
}

double median(std::vector<double> values) {
    if (values.empty()) return 0;
    std::nth_element(values.begin(), values.begin() + long(values.size() / 2), values.end());
    return values[values.size() / 2];
}

}  // namespace

ExtrinsicsRefinement refine_stereo_extrinsics(const CorrespondenceMap& left, const CorrespondenceMap& right,
                                              const StereoCalibration& calibration) {
    validate_stereo_calibration(calibration, "stereo calibration");
    if (left.projector_v.empty() || right.projector_v.empty())
        throw Error("stereo", "refining the cameras' pose needs projector rows decoded in both cameras (patterns --rows)");
    const auto left_cells = code_cells(left), right_cells = code_cells(right);
    const detail::LensDistortion left_lens(calibration.left_distortion), right_lens(calibration.right_distortion);
    std::vector<cv::Point2d> first, second;
    for (const auto& [key, sum] : left_cells) {
        const auto other = right_cells.find(key);
        if (other == right_cells.end()) continue;
        const cv::Vec2d a = left_lens.undistort(detail::pixel_to_normalised(calibration.left_matrix, {sum[0] / sum[2], sum[1] / sum[2]}));
        const cv::Vec3d& b_sum = other->second;
        const cv::Vec2d b =
            right_lens.undistort(detail::pixel_to_normalised(calibration.right_matrix, {b_sum[0] / b_sum[2], b_sum[1] / b_sum[2]}));
        first.emplace_back(a[0], a[1]);
        second.emplace_back(b[0], b[1]);
    }
    ExtrinsicsRefinement result;
    result.pairs = int(first.size());
    if (first.size() < 100)
        throw Error("stereo", "only " + std::to_string(first.size()) + " projector codes seen by both cameras (100 needed)");
    const double focal = calibration.left_matrix(0, 0);
    cv::Mat inlier_mask;
    const cv::Mat essential =
        cv::findEssentialMat(first, second, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.9999, 1.0 / focal, inlier_mask);
    if (essential.rows != 3) throw Error("stereo", "no consistent relative pose of the cameras fits the shared codes");
    cv::Mat rotation, direction;
    result.inliers = cv::recoverPose(essential, first, second, cv::Mat::eye(3, 3, CV_64F), rotation, direction, inlier_mask);
    if (result.inliers < 0.5 * result.pairs)
        throw Error("stereo", "only " + std::to_string(result.inliers) + " of " + std::to_string(result.pairs) +
                                  " shared codes agree with one relative pose of the cameras");
    result.calibration = calibration;
    result.calibration.R = cv::Matx33d(rotation);
    result.calibration.T = cv::normalize(cv::Vec3d(direction)) * cv::norm(calibration.T);
    result.median_epipolar_before_px = focal * median(epipolar_distances(first, second, calibration.R, calibration.T));
    result.median_epipolar_after_px =
        focal * median(epipolar_distances(first, second, result.calibration.R, result.calibration.T));
    cv::Vec3d change;
    cv::Rodrigues(cv::Mat(calibration.R.t() * result.calibration.R), change);
    result.rotation_change_deg = cv::norm(change) * 180 / kPi;
    return result;
}

}  // namespace picoscan
