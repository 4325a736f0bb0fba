// Shared helpers for the test suites.
#pragma once

#include <opencv2/core.hpp>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace picoscan::test_support {

// Folder of the real capture sets (../shared/datasets), or "" when it is absent.
std::string datasets_dir();
// A fresh empty temporary directory, removed at exit of the test process.
std::string make_temp_dir(const std::string& name);
// Runs a shell command, returns its exit code; stdout+stderr go to `output` if given.
int run_command(const std::string& command, std::string* output = nullptr);
// Path of the built `picoscan` CLI.
std::string cli_path();

// `picoscan ARGUMENTS` run through the shell: its exit code and its stdout+stderr.
struct CliResult {
    int exit_code;
    std::string output;
};
CliResult run_picoscan(const std::string& arguments);

// The message of the picoscan::Error that `action` throws, or "" when it throws none.
std::string error_of(const std::function<void()>& action);

// The whole content of a file, byte for byte ("" when it cannot be read).
std::string read_file_bytes(const std::filesystem::path& path);

// Diameter of the least-squares circle through 2D points (algebraic fit, then Gauss-Newton on
// the distances): for judging holes and bosses measured on clouds and meshes.
double circle_diameter(const std::vector<cv::Vec2d>& points);

// The heap left in another state (blocks of many sizes taken, every other one given back), so
// that the same computation run again in this process gets other addresses: a result that
// depends on memory addresses (containers ordered by pointer) then changes. Keep the returned
// blocks until that run is done.
std::vector<std::vector<char>> stir_heap();

// A simulated scan of a mesh's surface: about `per_mm2` points per mm2 spread by area, each moved
// by Gaussian noise of `sigma_mm` along x, y and z (a scan of known noise behind a flattened mesh).
std::vector<cv::Vec3f> noisy_surface_points(const std::vector<cv::Vec3f>& vertices, const std::vector<cv::Vec3i>& faces,
                                            double per_mm2, double sigma_mm, unsigned seed);

}  // namespace picoscan::test_support

// Skips the current test with a clear message when ../shared/datasets is absent.
#define PICOSCAN_REQUIRE_DATASETS()                                                             \
    do {                                                                                       \
        if (::picoscan::test_support::datasets_dir().empty())                                       \
            GTEST_SKIP() << "real datasets not found at " PICOSCAN_DATASETS_DIR                \
                            " (../shared/datasets is absent on this machine); skipping";        \
    } while (0)
