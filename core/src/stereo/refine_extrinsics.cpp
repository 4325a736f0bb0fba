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

// Per projector code cell (rounded u, v) of one camera, a least-squares linear model of the
// pixel position as a function of the code, fitted on the cell's pixels: where in this camera
// any code inside the cell falls, to a fraction of a pixel (the cell's centroid for binary
// codes, which are whole projector pixels).
class CodeToPixel {
public:
    explicit CodeToPixel(const CorrespondenceMap& map) {
        for (int y = 0; y < map.projector_u.rows; ++y) {
            const float* u = map.projector_u.ptr<float>(y);
            const float* v = map.projector_v.ptr<float>(y);
            for (int x = 0; x < map.projector_u.cols; ++x) {
                if (!std::isfinite(u[x]) || !std::isfinite(v[x])) continue;
                Sums& sums = cells_[key(u[x], v[x])];
                const double du = u[x] - std::round(u[x]), dv = v[x] - std::round(v[x]);
                const cv::Vec3d basis(1, du, dv);
                sums.normal += basis * basis.t();
                sums.x += x * basis;
                sums.y += y * basis;
            }
        }
    }
    // Pixel where the code (u, v) falls; false when its cell has too few pixels to fit.
    bool locate(double u, double v, cv::Point2d& pixel) const {
        const auto found = cells_.find(key(u, v));
        if (found == cells_.end() || found->second.normal(0, 0) < 3) return false;
        const Sums& sums = found->second;
        if (std::abs(cv::determinant(sums.normal)) < 1e-9) {
            // Whole-pixel (binary) codes, or codes along a line: the cell's centroid.
            pixel = {sums.x[0] / sums.normal(0, 0), sums.y[0] / sums.normal(0, 0)};
            return true;
        }
        const cv::Vec3d fit_x = sums.normal.solve(sums.x, cv::DECOMP_CHOLESKY);
        const cv::Vec3d fit_y = sums.normal.solve(sums.y, cv::DECOMP_CHOLESKY);
        const cv::Vec3d basis(1, u - std::round(u), v - std::round(v));
        pixel = {fit_x.dot(basis), fit_y.dot(basis)};
        return true;
    }

private:
    struct Sums {
        cv::Matx33d normal = cv::Matx33d::zeros();
        cv::Vec3d x{0, 0, 0}, y{0, 0, 0};
    };
    static long long key(double u, double v) { return std::llround(v) * 100000LL + std::llround(u); }
    std::map<long long, Sums> cells_;
};

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
    // Every few first-camera pixels' codes, located in both cameras the same way (exact for
    // phase codes, the code cells' centroids for binary ones).
    const CodeToPixel left_pixels(left), right_pixels(right);
    const detail::LensDistortion left_lens(calibration.left_distortion), right_lens(calibration.right_distortion);
    std::vector<cv::Point2d> first, second;
    constexpr int kStep = 3;
    for (int y = 0; y < left.projector_u.rows; y += kStep)
        for (int x = 0; x < left.projector_u.cols; x += kStep) {
            const float u = left.projector_u.at<float>(y, x), v = left.projector_v.at<float>(y, x);
            cv::Point2d in_left, in_right;
            if (!std::isfinite(u) || !std::isfinite(v) || !left_pixels.locate(u, v, in_left) ||
                !right_pixels.locate(u, v, in_right))
                continue;
            const cv::Vec2d a = left_lens.undistort(detail::pixel_to_normalised(calibration.left_matrix, {in_left.x, in_left.y}));
            const cv::Vec2d b = right_lens.undistort(detail::pixel_to_normalised(calibration.right_matrix, {in_right.x, in_right.y}));
            first.emplace_back(a[0], a[1]);
            second.emplace_back(b[0], b[1]);
        }
    ExtrinsicsRefinement result;
    result.pairs = int(first.size());
    if (first.size() < 100)
        throw Error("stereo", "only " + std::to_string(first.size()) + " pixels whose projector code both cameras decoded (100 needed)");
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
