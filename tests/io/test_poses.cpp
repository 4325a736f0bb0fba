// Poses files with placements: a '# placement N' line before each placement's views, read
// back into ViewPose::placement; older files (no such line) are all placement 0.
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <fstream>

using namespace picoscan;

TEST(PosesFile, PlacementsAreWrittenAndReadBack) {
    const std::string path = test_support::make_temp_dir("poses_placements") + "/poses.txt";
    cv::Matx44d shifted = cv::Matx44d::eye();
    shifted(0, 3) = 12.5;
    write_poses({{"a.ply", cv::Matx44d::eye(), true, 0}, {"b.ply", shifted, true, 0}, {"c.ply", shifted, false, 1}}, path);
    const std::vector<ViewPose> poses = read_poses(path);
    ASSERT_EQ(poses.size(), 3u);
    EXPECT_EQ(poses[0].placement, 0);
    EXPECT_EQ(poses[1].placement, 0);
    EXPECT_EQ(poses[2].placement, 1);
    EXPECT_FALSE(poses[2].aligned);
    EXPECT_EQ(poses[2].pose(0, 3), 12.5);

    // One placement: no placement lines, as before.
    write_poses({{"a.ply", cv::Matx44d::eye(), true, 0}}, path);
    std::ifstream in(path);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text.find("# placement"), std::string::npos) << text;

    std::ofstream(path) << "# placement two\na.ply\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
    try {
        read_poses(path);
        FAIL() << "a malformed placement line was accepted";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find(":1"), std::string::npos) << error.what();
    }
}
