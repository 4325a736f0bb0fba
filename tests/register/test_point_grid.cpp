// The registration's uniform grids, built to fool a grid that tells cells apart by a hash:
// cells (-1, -1, z) and (1, 1, z) shared the hash (x * 73856093) ^ (y * 19349663) ^ (z * 83492791),
// and they lie on the camera's axis, where the part is.
#include "../../core/src/register/point_grid.h"

#include <gtest/gtest.h>

#include <algorithm>

using namespace picoscan;
using picoscan::detail::PointGrid;

namespace {

// The points of the two colliding cells (-1, -1, 100) and (1, 1, 100) of a grid of 1 mm,
// and one more in the cell between them.
const std::vector<cv::Vec3d> kColliding = {{-0.5, -0.5, 100.5}, {1.5, 1.5, 100.5}, {0.5, 0.5, 100.5}};

}  // namespace

TEST(PointGrid, WithinFindsEachPointOnceWhenCellHashesCollide) {
    const PointGrid grid(kColliding, 1.0);
    std::vector<int> found;
    grid.within({0.5, 0.5, 100.5}, 1.5, found);  // reaches all three (the corners lie 1.41 mm away)
    std::sort(found.begin(), found.end());
    EXPECT_EQ(found, (std::vector<int>{0, 1, 2}));
    // From a corner cell: the other corner, 2.83 mm away, is out of reach.
    grid.within({-0.5, -0.5, 100.5}, 1.5, found);
    std::sort(found.begin(), found.end());
    EXPECT_EQ(found, (std::vector<int>{0, 2}));
    EXPECT_EQ(grid.nearest({1.4, 1.4, 100.5}, 1.0), 1);
    EXPECT_EQ(grid.nearest({-0.4, -0.4, 100.5}, 0.2), 0);
}

TEST(PointGrid, WithinAgreesWithBruteForceAroundTheAxis) {
    // A lattice over the cells around the camera axis, where the old hash collided, queried
    // from points between the lattice's.
    std::vector<cv::Vec3d> points;
    for (int x = -6; x <= 6; ++x)
        for (int y = -6; y <= 6; ++y)
            for (int z = 0; z < 4; ++z) points.push_back({0.73 * x + 0.1, 0.73 * y - 0.2, 400 + 0.73 * z});
    const double cell = 0.7, radius = 1.4;
    const PointGrid grid(points, cell);
    std::vector<int> found;
    int compared = 0;
    for (int x = -8; x <= 8; ++x)
        for (int y = -8; y <= 8; ++y) {
            const cv::Vec3d query(0.37 * x, 0.37 * y, 401.1);
            grid.within(query, radius, found);
            std::sort(found.begin(), found.end());
            std::vector<int> expected;
            for (size_t i = 0; i < points.size(); ++i)
                if (cv::norm(points[i] - query) <= radius) expected.push_back(static_cast<int>(i));
            ASSERT_EQ(found, expected) << "query " << query;
            ++compared;
        }
    EXPECT_EQ(compared, 17 * 17);
}

TEST(PointGrid, ThinningKeepsOnePointInEveryCellEvenWhenHashesCollide) {
    // A view of two pixels in the colliding cells (-1, -1, 100) and (1, 1, 100) of 0.7 mm
    // cells, and a third in the first one's cell: two samples, one per cell.
    ScanView view;
    view.points = cv::Mat(1, 3, CV_32FC3);
    view.points.at<cv::Vec3f>(0, 0) = {-0.35f, -0.35f, 70.35f};
    view.points.at<cv::Vec3f>(0, 1) = {1.05f, 1.05f, 70.35f};
    view.points.at<cv::Vec3f>(0, 2) = {-0.30f, -0.30f, 70.30f};
    const detail::SurfaceSamples samples = detail::sample_view(view, 0.7);
    ASSERT_EQ(samples.points.size(), 2u);
    EXPECT_NEAR(samples.points[0][0], -0.35, 1e-6);
    EXPECT_NEAR(samples.points[1][0], 1.05, 1e-6);
}
