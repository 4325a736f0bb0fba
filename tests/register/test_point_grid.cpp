// The registration's uniform grids, built to fool a grid that tells cells apart by a hash:
// cells (-1, -1, z) and (1, 1, z) shared the hash (x * 73856093) ^ (y * 19349663) ^ (z * 83492791),
// and they lie on the camera's axis, where the part is.
#include "../../core/src/register/point_grid.h"

#include <gtest/gtest.h>

#include <algorithm>

using namespace picoscan;
using picoscan::detail::NearestGrid;
using picoscan::detail::PointGrid;
using picoscan::detail::SearchMemory;

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
    const detail::SurfaceSamples samples = detail::sample_view(view, detail::measured_bounds(view), 0.7);
    ASSERT_EQ(samples.points.size(), 2u);
    EXPECT_NEAR(samples.points[0][0], -0.35, 1e-6);
    EXPECT_NEAR(samples.points[1][0], 1.05, 1e-6);
}

TEST(NearestGrid, RememberedSearchAgreesWithBruteForceAlongRandomWalks) {
    // Points on two planes meeting at an edge (as ICP's fixed samples lie on a part's faces),
    // plus a sparse scatter, and queries that walk about them as ICP's samples do between
    // iterations: mostly small steps, sometimes none, sometimes a jump, with the reach
    // shrinking and growing. Every answer must be the brute-force nearest within reach.
    cv::RNG rng(12);
    std::vector<cv::Vec3d> points;
    for (int i = 0; i < 1500; ++i) points.push_back({rng.uniform(-15.0, 15.0), rng.uniform(-15.0, 15.0), 400 + rng.gaussian(0.01)});
    for (int i = 0; i < 1500; ++i) points.push_back({rng.uniform(-15.0, 15.0), 15 + rng.gaussian(0.01), 400 + rng.uniform(0.0, 20.0)});
    for (int i = 0; i < 200; ++i) points.push_back({rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0), rng.uniform(390.0, 430.0)});
    auto brute_force = [&](const cv::Vec3d& query, double reach) {
        int best = -1;
        double best_squared = reach * reach;
        for (size_t i = 0; i < points.size(); ++i) {
            const cv::Vec3d d = points[i] - query;
            if (d.dot(d) < best_squared) {
                best_squared = d.dot(d);
                best = static_cast<int>(i);
            }
        }
        return best;
    };
    const double reaches[] = {3.0, 1.5, 0.7, 0.4, 2.2};
    int found = 0, compared = 0;
    for (double cell : {3.0, 1.0}) {
        const NearestGrid grid(points, cell);
        for (int walk = 0; walk < 150; ++walk) {
            SearchMemory memory;
            cv::Vec3d query = points[static_cast<size_t>(rng.uniform(0, static_cast<int>(points.size())))] +
                              cv::Vec3d(rng.gaussian(1.0), rng.gaussian(1.0), rng.gaussian(1.0));
            for (int step = 0; step < 40; ++step) {
                const int kind = rng.uniform(0, 10);
                const double size = kind == 0 ? 0.0 : kind == 1 ? 4.0 : kind < 5 ? 0.3 : 0.02;
                query += cv::Vec3d(rng.gaussian(size), rng.gaussian(size), rng.gaussian(size));
                const double reach = reaches[(walk + step / 8) % 5];
                const int expected = brute_force(query, reach);
                ASSERT_EQ(grid.nearest_remembered(query, reach, memory), expected)
                    << "cell " << cell << " walk " << walk << " step " << step << " query " << query << " reach " << reach;
                ASSERT_EQ(grid.nearest(query, reach), expected) << "without memory, cell " << cell << " walk " << walk << " step " << step;
                found += expected >= 0;
                ++compared;
            }
        }
    }
    EXPECT_EQ(compared, 2 * 150 * 40);
    EXPECT_GT(found, compared / 4);          // the walks stay near the surface often enough
    EXPECT_LT(found, compared - compared / 10);  // and leave it often enough
}
