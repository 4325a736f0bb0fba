// Normals of an organised view from its pixel grid.
#include "picoscan/cloud.h"

#include "common/parallel.h"

#include <cmath>
#include <limits>

namespace picoscan {

namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
}  // namespace

void estimate_normals(ScanView& view) {
    const cv::Mat& points = view.points;
    view.normals.create(points.size(), CV_32FC3);
    const int width = points.cols, height = points.rows;
    detail::parallel_rows(height, [&](int begin, int end) {
        for (int y = begin; y < end; ++y) {
            const cv::Vec3f* row = points.ptr<cv::Vec3f>(y);
            const cv::Vec3f* above = points.ptr<cv::Vec3f>(std::max(y - 1, 0));
            const cv::Vec3f* below = points.ptr<cv::Vec3f>(std::min(y + 1, height - 1));
            cv::Vec3f* normal = view.normals.ptr<cv::Vec3f>(y);
            for (int x = 0; x < width; ++x) {
                const cv::Vec3f& centre = row[x];
                normal[x] = cv::Vec3f(kNaN, kNaN, kNaN);
                if (!(centre[2] == centre[2])) continue;  // NaN: no point
                const cv::Vec3f& left = (x > 0 && row[x - 1][2] == row[x - 1][2]) ? row[x - 1] : centre;
                const cv::Vec3f& right = (x + 1 < width && row[x + 1][2] == row[x + 1][2]) ? row[x + 1] : centre;
                const cv::Vec3f& up = above[x][2] == above[x][2] ? above[x] : centre;
                const cv::Vec3f& down = below[x][2] == below[x][2] ? below[x] : centre;
                const float ax = right[0] - left[0], ay = right[1] - left[1], az = right[2] - left[2];
                const float bx = down[0] - up[0], by = down[1] - up[1], bz = down[2] - up[2];
                float nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
                const float length_squared = nx * nx + ny * ny + nz * nz;
                if (!(length_squared > 0)) continue;
                // Unit length, turned towards the camera at the origin.
                const float scale = (nx * centre[0] + ny * centre[1] + nz * centre[2] > 0 ? -1.0f : 1.0f) / std::sqrt(length_squared);
                normal[x] = cv::Vec3f(nx * scale, ny * scale, nz * scale);
            }
        }
    });
}

}  // namespace picoscan
