// Registration of a plain (unpainted) pair of views with no guess: what `picoscan stitch A B`
// does for the views of a turntable scan when nothing says how they lie (ORB on the white
// frames, FPFH shape histograms, RANSAC, ICP of every start, the gates). The views are the
// plain grey mechanical part's 8 turntable views that the registration tests cache (run
// `test_register --gtest_filter='*FeatureMode*'` once to make them); pair k registers view
// k+1 onto view k. Times are the whole process's CPU (the two views are prepared on two
// threads) and wall time; counters say whether the pair was right, wrong or refused, so a
// faster build that changes a result shows it.
//
//   build/benchmarks/bench_register --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include "picoscan/io.h"
#include "picoscan/register.h"
#include "picoscan/simulate.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

using namespace picoscan;

namespace {

constexpr int kViews = 8;

struct PlainScan {
    std::vector<ScanView> views;
    std::vector<cv::Matx44d> part_to_camera;
    std::string problem;  // why the views could not be read
};

const PlainScan& plain_scan() {
    static const PlainScan scan = [] {
        PlainScan s;
        // The tests' plan (tests/support/turntable_scan.cpp): the part's middle at the working point.
        TurntablePlan plan;
        plan.top_view = false;
        double top = 0;
        for (const cv::Vec3f& v : mechanical_part().vertices) top = std::max(top, static_cast<double>(v[2]));
        plan.part_middle_height_mm = top / 2;
        s.part_to_camera = turntable_part_poses(plan);
        const std::filesystem::path cache = std::filesystem::path(PICOSCAN_TEST_CACHE_DIR) / "plain-v2-grey-mechanical";
        for (int k = 0; k < kViews; ++k) {
            const std::filesystem::path path = cache / ("view_" + std::to_string(k) + ".ply");
            if (!std::filesystem::exists(path)) {
                s.problem = path.string() + " is missing: run test_register once to cache the views";
                break;
            }
            s.views.push_back(read_view_ply(path.string()));
        }
        return s;
    }();
    return scan;
}

cv::Vec3d centroid(const ScanView& view) {
    const std::vector<cv::Vec3f> points = to_point_cloud(view).points;
    cv::Vec3d sum(0, 0, 0);
    for (const cv::Vec3f& p : points) sum += cv::Vec3d(p);
    return points.empty() ? sum : sum * (1.0 / static_cast<double>(points.size()));
}

void plain_global_pair(benchmark::State& state) {
    const PlainScan& scan = plain_scan();
    if (!scan.problem.empty()) {
        state.SkipWithError(scan.problem.c_str());
        return;
    }
    const size_t fixed = static_cast<size_t>(state.range(0)), moving = (fixed + 1) % kViews;
    PairRegistration pair;
    for (auto _ : state) {
        pair = register_pair(scan.views[fixed], scan.views[moving]);
        benchmark::DoNotOptimize(pair.transform);
    }
    const cv::Matx44d truth = scan.part_to_camera[fixed] * scan.part_to_camera[moving].inv();
    const PoseDifference error = pose_difference(truth, pair.transform, centroid(scan.views[moving]));
    const bool refused = !pair.problem.empty(), right = !refused && error.rotation_deg < 1 && error.translation_mm < 1;
    state.counters["right"] = right;
    state.counters["wrong"] = !refused && !right;
    state.counters["refused"] = refused;
    state.counters["error_deg"] = refused ? 0 : error.rotation_deg;
    state.counters["error_mm"] = refused ? 0 : error.translation_mm;
}

}  // namespace

BENCHMARK(plain_global_pair)->DenseRange(0, kViews - 1)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK_MAIN();
