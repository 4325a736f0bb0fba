// write_file_atomically: the target is either the old file or the complete new one.
#include "io_test_util.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <filesystem>

namespace fs = std::filesystem;

namespace picoscan {
namespace {

using iotest::read_bytes;

// Files in `dir` whose name marks them as a leftover temporary.
std::vector<std::string> temp_leftovers(const std::string& dir) {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        if (name.find(".tmp-") != std::string::npos) names.push_back(name);
    }
    return names;
}

TEST(AtomicWrite, WritesAndReplaces) {
    const std::string dir = test_support::make_temp_dir("atomic");
    const std::string path = dir + "/out.bin";
    const std::string first("first\0bytes", 11);
    write_file_atomically(path, first);
    EXPECT_EQ(read_bytes(path), first);
    write_file_atomically(path, "second");
    EXPECT_EQ(read_bytes(path), "second");
    write_file_atomically(path, "");
    EXPECT_TRUE(fs::exists(path));
    EXPECT_EQ(fs::file_size(path), 0u);
    EXPECT_TRUE(temp_leftovers(dir).empty());
}

TEST(AtomicWrite, MissingDirectoryThrowsAndCreatesNothing) {
    const std::string dir = test_support::make_temp_dir("atomic");
    const std::string path = dir + "/no/such/dir/out.ply";
    try {
        write_file_atomically(path, "data");
        FAIL() << "no error";
    } catch (const Error& error) {
        EXPECT_EQ(error.subject(), path);
        EXPECT_NE(std::string(error.what()).find(path), std::string::npos);
    }
    EXPECT_FALSE(fs::exists(dir + "/no"));
    EXPECT_TRUE(fs::is_empty(dir));
    EXPECT_THROW(write_ply(iotest::cube_mesh(), path), Error);
    EXPECT_THROW(write_stl(iotest::cube_mesh(), path), Error);
    EXPECT_THROW(write_obj(iotest::cube_mesh(), path), Error);
    EXPECT_TRUE(fs::is_empty(dir));
}

TEST(AtomicWrite, FailedRenameRemovesTheTemporaryAndKeepsTheTarget) {
    const std::string dir = test_support::make_temp_dir("atomic");
    // A non-empty directory cannot be replaced by a file: the rename fails after the
    // temporary has been fully written.
    const std::string target = dir + "/scan.ply";
    fs::create_directory(target);
    iotest::write_bytes(target + "/keep.txt", "old content");
    try {
        write_ply(iotest::cube_mesh(), target);
        FAIL() << "no error";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find(target), std::string::npos) << error.what();
        EXPECT_NE(std::string(error.what()).find("rename"), std::string::npos) << error.what();
    }
    EXPECT_TRUE(fs::is_directory(target));
    EXPECT_EQ(read_bytes(target + "/keep.txt"), "old content");
    EXPECT_TRUE(temp_leftovers(dir).empty());
}

TEST(AtomicWrite, RefusedDataLeavesTheOldFileIntact) {
    const std::string dir = test_support::make_temp_dir("atomic");
    const std::string path = dir + "/mesh.ply";
    write_ply(iotest::cube_mesh(), path);
    const std::string before = read_bytes(path);
    Mesh broken = iotest::cube_mesh();
    broken.faces.back()[2] = 99;
    EXPECT_THROW(write_ply(broken, path), Error);
    EXPECT_THROW(write_stl(broken, path), Error);
    EXPECT_THROW(write_obj(broken, path), Error);
    EXPECT_EQ(read_bytes(path), before);
    EXPECT_TRUE(temp_leftovers(dir).empty());
}

TEST(AtomicWrite, EmptyPathThrows) { EXPECT_THROW(write_file_atomically("", "x"), Error); }

}  // namespace
}  // namespace picoscan
