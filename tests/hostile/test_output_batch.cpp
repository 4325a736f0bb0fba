// OutputBatch: a set of outputs replaced together. A commit that fails part-way (the last
// target is a directory, so its rename fails after the others succeeded) leaves the old set
// whole, byte for byte, and no temporary or backup file behind.
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace picoscan;

namespace {

std::vector<std::string> leftovers(const fs::path& folder) {
    std::vector<std::string> found;
    for (const auto& entry : fs::recursive_directory_iterator(folder))
        if (entry.path().filename().string().find(".tmp-") != std::string::npos) found.push_back(entry.path().string());
    return found;
}

TEST(OutputBatch, FailedCommitLeavesTheOldSetWhole) {
    const fs::path folder = test_support::make_temp_dir("output-batch");
    const std::string old_cloud(100000, 'c'), old_mesh = "old mesh";
    std::ofstream(folder / "cloud.ply", std::ios::binary) << old_cloud;
    std::ofstream(folder / "mesh.stl", std::ios::binary) << old_mesh;
    fs::create_directories(folder / "preview.png");  // in the way of the last rename
    try {
        OutputBatch batch;
        write_file_atomically((folder / "cloud.ply").string(), "new cloud");
        write_file_atomically((folder / "mesh.stl").string(), "new mesh");
        write_file_atomically((folder / "new.txt").string(), "a file that did not exist");
        write_file_atomically((folder / "preview.png").string(), "new preview");
        EXPECT_EQ(test_support::read_file_bytes(folder / "cloud.ply"), old_cloud) << "replaced before the commit";
        batch.commit();
        FAIL() << "the commit over a directory succeeded";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("preview.png"), std::string::npos) << error.what();
    }
    EXPECT_EQ(test_support::read_file_bytes(folder / "cloud.ply"), old_cloud);
    EXPECT_EQ(test_support::read_file_bytes(folder / "mesh.stl"), old_mesh);
    EXPECT_FALSE(fs::exists(folder / "new.txt")) << "a new output of the failed set was left";
    EXPECT_TRUE(fs::is_directory(folder / "preview.png"));
    EXPECT_EQ(leftovers(folder), std::vector<std::string>{});
}

TEST(OutputBatch, CommitReplacesEveryOutput) {
    const fs::path folder = test_support::make_temp_dir("output-batch-ok");
    std::ofstream(folder / "cloud.ply", std::ios::binary) << "old cloud";
    {
        OutputBatch batch;
        write_file_atomically((folder / "cloud.ply").string(), "new cloud");
        write_file_atomically((folder / "mesh.stl").string(), "new mesh");
        batch.commit();
    }
    EXPECT_EQ(test_support::read_file_bytes(folder / "cloud.ply"), "new cloud");
    EXPECT_EQ(test_support::read_file_bytes(folder / "mesh.stl"), "new mesh");
    EXPECT_EQ(leftovers(folder), std::vector<std::string>{});
}

TEST(OutputBatch, AbandonedBatchWritesNothing) {
    const fs::path folder = test_support::make_temp_dir("output-batch-abandoned");
    std::ofstream(folder / "cloud.ply", std::ios::binary) << "old cloud";
    {
        OutputBatch batch;
        write_file_atomically((folder / "cloud.ply").string(), "new cloud");
    }
    EXPECT_EQ(test_support::read_file_bytes(folder / "cloud.ply"), "old cloud");
    EXPECT_EQ(leftovers(folder), std::vector<std::string>{});
}

}  // namespace
