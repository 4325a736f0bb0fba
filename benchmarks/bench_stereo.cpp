// Binocular reconstruction speed, side by side with the single-camera path on the same frames.
//
//   build/benchmarks/bench_stereo --benchmark_counters_tabular=true
//
// Frames: the two-camera rig (seed_stereo_rig, cameras cut to 1280x1024 with the same lens)
// scanning the built-in demo part with a 19-frame columns-only sequence: white, black, 6 Gray
// bits without inverses (16 px stripes) and 11 phase shifts of a 32 px period.
// Stereo: decode both cameras + match + triangulate. Single camera: decode the first camera +
// triangulate through its camera-projector calibration. Rectification tables and the
// Triangulator's tables are built once, outside the timed loop. Time is wall-clock; CPU is the
// whole process's (both cores), so CPU / 2 is what an idle 2-core machine could reach at best.
#include "picoscan/decode.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "picoscan/stereo.h"
#include "picoscan/triangulate.h"

#include <benchmark/benchmark.h>

using namespace picoscan;

namespace {

PatternSequence nineteen_frames(cv::Size projector) {
    PatternSequence sequence;
    sequence.projector_size = projector;
    sequence.columns.gray_bits = 6;
    sequence.columns.gray_unit_px = 16;
    sequence.columns.shifts = 11;
    sequence.columns.period_px = 32;
    sequence.columns.shift_sign = -1;
    auto add = [&](FrameKind kind, int bit, int shift) {
        Frame frame;
        frame.file = std::to_string(sequence.frames.size()) + ".png";
        frame.kind = kind;
        frame.bit = bit;
        frame.shift = shift;
        sequence.frames.push_back(frame);
    };
    add(FrameKind::White, 0, 0);
    add(FrameKind::Black, 0, 0);
    for (int bit = 0; bit < 6; ++bit) add(FrameKind::Gray, bit, 0);
    for (int shift = 0; shift < 11; ++shift) add(FrameKind::Phase, 0, shift);
    return sequence;
}

struct Pair {
    SeedStereoRig rig;
    CaptureSet left, right;
    std::unique_ptr<StereoMatcher> matcher;
    std::unique_ptr<Triangulator> triangulator;
};

const Pair& pair() {
    static const Pair instance = [] {
        Pair pair;
        pair.rig = seed_stereo_rig();
        for (Calibration* camera : {&pair.rig.left, &pair.rig.right}) {
            camera->camera_size = cv::Size(1280, 1024);
            camera->camera_matrix = cv::Matx33d(2000, 0, 641.5, 0, 2000, 510.2, 0, 0, 1);
        }
        pair.rig.stereo = stereo_from_projector_calibrations(pair.rig.left, pair.rig.right);
        SimulationOptions options;
        options.blur_sigma_px = 0.7;
        auto captures = simulate_stereo_capture(nineteen_frames(pair.rig.left.projector_size), pair.rig, demo_scene(), options);
        pair.left = std::move(captures.first);
        pair.right = std::move(captures.second);
        pair.matcher = std::make_unique<StereoMatcher>(pair.rig.stereo);
        pair.triangulator = std::make_unique<Triangulator>(pair.rig.left);
        return pair;
    }();
    return instance;
}

void BM_Stereo_DecodeBothMatchTriangulate(benchmark::State& state) {
    const Pair& data = pair();
    StereoStatistics statistics;
    for (auto _ : state) {
        const CorrespondenceMap left = decode(data.left);
        const CorrespondenceMap right = decode(data.right);
        const StereoReconstruction result = data.matcher->reconstruct(left, right, data.left.white_colour);
        statistics = result.statistics;
        benchmark::DoNotOptimize(result.view.points.data);
    }
    state.counters["frames_per_camera"] = double(data.left.images.size());
    state.counters["points"] = statistics.valid;
    state.counters["LR_consistency"] = statistics.left_right_consistency();
}

void BM_Stereo_MatchTriangulateOnly(benchmark::State& state) {
    const Pair& data = pair();
    const CorrespondenceMap left = decode(data.left), right = decode(data.right);
    int points = 0;
    for (auto _ : state) {
        const StereoReconstruction result = data.matcher->reconstruct(left, right, data.left.white_colour);
        points = result.statistics.valid;
        benchmark::DoNotOptimize(result.view.points.data);
    }
    state.counters["points"] = points;
}

void BM_SingleCamera_DecodeTriangulate(benchmark::State& state) {
    const Pair& data = pair();
    int points = 0;
    for (auto _ : state) {
        const CorrespondenceMap map = decode(data.left);
        const ScanView view = data.triangulator->triangulate(map, data.left.white_colour);
        points = view.valid_count();
        benchmark::DoNotOptimize(view.points.data);
    }
    state.counters["frames_per_camera"] = double(data.left.images.size());
    state.counters["points"] = points;
}

void BM_Stereo_RectificationTables(benchmark::State& state) {
    const Pair& data = pair();
    for (auto _ : state) {
        StereoMatcher matcher(data.rig.stereo);
        benchmark::DoNotOptimize(&matcher);
    }
}

}  // namespace

BENCHMARK(BM_Stereo_DecodeBothMatchTriangulate)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK(BM_Stereo_MatchTriangulateOnly)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK(BM_SingleCamera_DecodeTriangulate)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK(BM_Stereo_RectificationTables)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK_MAIN();
