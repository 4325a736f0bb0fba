// PLY reading and writing as 'picoscan stitch A B' does it: two views read (read_view_ply),
// the merged cloud written (write_ply). The view is made here, shaped like the seed rig's:
// a 1600 x 1200 camera grid of which a 300 x 240 patch (72 000 points, as the turntable
// benchmark's views have) is measured, with normals, colours, quality and pixel indices.
// Binary little-endian, the format picoscan writes. Files go to the system's temporary folder.
//
//   build/benchmarks/bench_ply_io --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include "picoscan/io.h"

#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <unistd.h>

using namespace picoscan;
namespace fs = std::filesystem;

namespace {

ScanView made_view() {
    ScanView view;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    view.points = cv::Mat(1200, 1600, CV_32FC3, cv::Scalar::all(nan));
    view.normals = cv::Mat::zeros(1200, 1600, CV_32FC3);
    view.colours = cv::Mat::zeros(1200, 1600, CV_8UC3);
    view.quality = cv::Mat::zeros(1200, 1600, CV_32F);
    view.camera_matrix = cv::Matx33d(2500, 0, 803.2, 0, 2500, 597.6, 0, 0, 1);
    for (int y = 480; y < 720; ++y)
        for (int x = 650; x < 950; ++x) {
            // A bump on a plane 300 mm away: coordinates with every bit of a float in use.
            const float u = (x - 800) * 0.12f, v = (y - 600) * 0.12f;
            const float z = 300 - 8 * std::exp(-(u * u + v * v) / 200);
            view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(u, v, z);
            view.normals.at<cv::Vec3f>(y, x) = cv::normalize(cv::Vec3f(u * 0.01f, v * 0.01f, -1));
            view.colours.at<cv::Vec3b>(y, x) = cv::Vec3b(uchar(x), uchar(y), uchar(x + y));
            view.quality.at<float>(y, x) = 0.5f + 0.001f * static_cast<float>(x % 500);
        }
    return view;
}

struct Files {
    std::string view, cloud;
    PointCloud merged;  // two views' points, as stitch merges them
    Files() {
        const fs::path dir = fs::temp_directory_path() / ("picoscan-bench-ply-" + std::to_string(::getpid()));
        fs::create_directories(dir);
        view = (dir / "view.ply").string();
        cloud = (dir / "merged.ply").string();
        const ScanView made = made_view();
        write_view_ply(made, view);
        merged = to_point_cloud(made);
        const PointCloud second = to_point_cloud(made);
        merged.points.insert(merged.points.end(), second.points.begin(), second.points.end());
        merged.normals.insert(merged.normals.end(), second.normals.begin(), second.normals.end());
        merged.colours.insert(merged.colours.end(), second.colours.begin(), second.colours.end());
        merged.quality.insert(merged.quality.end(), second.quality.begin(), second.quality.end());
    }
    ~Files() {
        std::error_code ignored;
        fs::remove_all(fs::path(view).parent_path(), ignored);
    }
};

const Files& files() {
    static const Files made;
    return made;
}

void BM_ReadViewPly(benchmark::State& state) {
    const std::string& path = files().view;
    for (auto _ : state) {
        ScanView view = read_view_ply(path);
        benchmark::DoNotOptimize(view.points.data);
    }
    state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(fs::file_size(path)));
}
BENCHMARK(BM_ReadViewPly)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();

void BM_ReadPly(benchmark::State& state) {
    const std::string& path = files().view;
    for (auto _ : state) {
        Mesh mesh = read_ply(path);
        benchmark::DoNotOptimize(mesh.vertices.data());
    }
    state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(fs::file_size(path)));
}
BENCHMARK(BM_ReadPly)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();

void BM_WriteMergedCloudPly(benchmark::State& state) {
    const Files& made = files();
    for (auto _ : state) write_ply(made.merged, made.cloud);
    state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(fs::file_size(made.cloud)));
}
BENCHMARK(BM_WriteMergedCloudPly)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
