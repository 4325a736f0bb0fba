#include "support/test_support.h"

#include "picoscan/error.h"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <fstream>
#include <random>
#include <vector>

namespace fs = std::filesystem;

namespace picoscan::test_support {

namespace {
struct TempDirs {
    std::vector<fs::path> paths;
    ~TempDirs() {
        std::error_code ignored;
        for (const auto& path : paths) fs::remove_all(path, ignored);
    }
};
TempDirs& temp_dirs() {
    static TempDirs dirs;
    return dirs;
}
}  // namespace

std::string datasets_dir() {
    const char* override_dir = std::getenv("PICOSCAN_DATASETS");
    fs::path dir = override_dir ? fs::path(override_dir) : fs::path(PICOSCAN_DATASETS_DIR);
    std::error_code error;
    if (!fs::is_directory(dir, error)) return "";
    return fs::canonical(dir).string();
}

std::string make_temp_dir(const std::string& name) {
    fs::path base = fs::temp_directory_path();
    for (int attempt = 0;; ++attempt) {
        fs::path dir = base / ("picoscan-test-" + name + "-" + std::to_string(::getpid()) + "-" +
                               std::to_string(attempt));
        if (fs::create_directories(dir)) {
            temp_dirs().paths.push_back(dir);
            return dir.string();
        }
    }
}

int run_command(const std::string& command, std::string* output) {
    std::string full = command + " 2>&1";
    FILE* pipe = popen(full.c_str(), "r");
    if (!pipe) return -1;
    std::array<char, 4096> buffer{};
    std::string text;
    while (fgets(buffer.data(), buffer.size(), pipe)) text += buffer.data();
    int status = pclose(pipe);
    if (output) *output = text;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string cli_path() { return PICOSCAN_CLI; }

std::string error_of(const std::function<void()>& action) {
    try {
        action();
    } catch (const Error& error) {
        return error.what();
    }
    return "";
}

CliResult run_picoscan(const std::string& arguments) {
    CliResult result;
    result.exit_code = run_command(cli_path() + " " + arguments, &result.output);
    return result;
}

double circle_diameter(const std::vector<cv::Vec2d>& points) {
    cv::Mat a(static_cast<int>(points.size()), 3, CV_64F), b(static_cast<int>(points.size()), 1, CV_64F);
    for (int i = 0; i < a.rows; ++i) {
        const cv::Vec2d& p = points[static_cast<size_t>(i)];
        a.at<double>(i, 0) = p[0];
        a.at<double>(i, 1) = p[1];
        a.at<double>(i, 2) = 1;
        b.at<double>(i) = p.dot(p);
    }
    cv::Mat x;
    cv::solve(a, b, x, cv::DECOMP_SVD);
    cv::Vec2d centre(x.at<double>(0) / 2, x.at<double>(1) / 2);
    double radius = std::sqrt(x.at<double>(2) + centre.dot(centre));
    for (int iteration = 0; iteration < 20; ++iteration) {
        cv::Mat j(a.rows, 3, CV_64F), r(a.rows, 1, CV_64F);
        for (int i = 0; i < a.rows; ++i) {
            const cv::Vec2d d = points[static_cast<size_t>(i)] - centre;
            const double length = cv::norm(d);
            j.at<double>(i, 0) = -d[0] / length;
            j.at<double>(i, 1) = -d[1] / length;
            j.at<double>(i, 2) = -1;
            r.at<double>(i) = length - radius;
        }
        cv::Mat step;
        cv::solve(j, -r, step, cv::DECOMP_SVD);
        centre += cv::Vec2d(step.at<double>(0), step.at<double>(1));
        radius += step.at<double>(2);
    }
    return 2 * radius;
}

std::string read_file_bytes(const std::filesystem::path& path) {
    std::ifstream file(path, std::ios::binary);
    std::stringstream text;
    text << file.rdbuf();
    return text.str();
}

std::vector<std::vector<char>> stir_heap() {
    std::vector<std::vector<char>> blocks;
    for (int i = 0; i < 2000; ++i) blocks.emplace_back(size_t(64 + (i * 7919) % 4096));
    for (size_t i = 0; i < blocks.size(); i += 2) blocks[i].clear(), blocks[i].shrink_to_fit();
    return blocks;
}

std::vector<cv::Vec3f> noisy_surface_points(const std::vector<cv::Vec3f>& vertices, const std::vector<cv::Vec3i>& faces,
                                            double per_mm2, double sigma_mm, unsigned seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<float> unit(0, 1);
    std::normal_distribution<float> noise(0, float(sigma_mm));
    std::vector<cv::Vec3f> points;
    for (const cv::Vec3i& f : faces) {
        const cv::Vec3f a = vertices[size_t(f[0])], b = vertices[size_t(f[1])], c = vertices[size_t(f[2])];
        const double expected = 0.5 * cv::norm((b - a).cross(c - a)) * per_mm2;
        for (int k = 0; k < int(expected + unit(random)); ++k) {
            float u = unit(random), v = unit(random);
            if (u + v > 1) u = 1 - u, v = 1 - v;
            points.push_back(a + u * (b - a) + v * (c - a) + cv::Vec3f(noise(random), noise(random), noise(random)));
        }
    }
    return points;
}

}  // namespace picoscan::test_support
