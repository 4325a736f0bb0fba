// Decode + triangulate speed of one 1600x1200 scan, side by side with OpenCV contrib's own
// structured-light path on the same frames and with a floor that only reads every frame once.
//
//   build/benchmarks/bench_decode --benchmark_counters_tabular=true
//
// Frames: the seed-like rig's simulated scan of the built-in part, 10-bit column Gray code
// with inverses + 9-bit rows + 24 phase shifts per axis (88 frames). The "columns" cases use
// the 46 column frames only.
#include "picoscan/decode.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "picoscan/triangulate.h"

#include "common/parallel.h"

#include <benchmark/benchmark.h>
#include <opencv2/structured_light.hpp>

#include <numeric>

using namespace picoscan;

namespace {

struct Scan {
    Calibration calibration;
    CaptureSet all_frames;      // columns and rows
    CaptureSet column_frames;   // the column half only
    std::unique_ptr<Triangulator> triangulator;
};

CaptureSet columns_only(const CaptureSet& full) {
    CaptureSet captures;
    captures.sequence = full.sequence;
    captures.sequence.rows = AxisCode{};
    captures.sequence.frames.clear();
    for (size_t index = 0; index < full.sequence.frames.size(); ++index) {
        const Frame& frame = full.sequence.frames[index];
        const bool is_row = frame.axis == Axis::Rows && (frame.kind == FrameKind::Gray ||
                                                         frame.kind == FrameKind::GrayInverse || frame.kind == FrameKind::Phase);
        if (is_row) continue;
        captures.sequence.frames.push_back(frame);
        captures.images.push_back(full.images[index]);
    }
    captures.white_colour = full.white_colour;
    return captures;
}

const Scan& scan() {
    static const Scan instance = [] {
        Scan scan;
        scan.calibration = seed_rig_calibration();
        PatternOptions options;
        options.projector_size = scan.calibration.projector_size;
        SimulationOptions simulation;
        simulation.blur_sigma_px = 0.7;
        scan.all_frames = simulate_capture(make_pattern_sequence(options), scan.calibration, demo_scene(), simulation);
        scan.column_frames = columns_only(scan.all_frames);
        scan.triangulator = std::make_unique<Triangulator>(scan.calibration);
        return scan;
    }();
    return instance;
}

void set_counters(benchmark::State& state, const CaptureSet& captures) {
    const double bytes = double(captures.images.size()) * captures.images.front().total();
    state.counters["frames"] = double(captures.images.size());
    state.counters["MB_read"] = bytes / 1e6;
    state.SetBytesProcessed(int64_t(state.iterations() * bytes));
}

// The floor: every input frame read once, in parallel, doing nothing but summing.
void read_every_frame(benchmark::State& state, const CaptureSet& captures) {
    const int rows = captures.images.front().rows, width = captures.images.front().cols;
    for (auto _ : state) {
        std::vector<uint64_t> sums(rows, 0);
        detail::parallel_rows(rows, [&](int begin, int end) {
            for (int y = begin; y < end; ++y) {
                uint32_t sum = 0;
                for (const cv::Mat& image : captures.images) {
                    const uint8_t* row = image.ptr<uint8_t>(y);
                    for (int x = 0; x < width; ++x) sum += row[x];
                }
                sums[y] = sum;
            }
        });
        benchmark::DoNotOptimize(sums.data());
    }
    set_counters(state, captures);
}

// Fresh outputs each time (what a one-off reconstruction pays, page faults included).
void picoscan_decode_triangulate(benchmark::State& state, const CaptureSet& captures) {
    size_t points = 0;
    for (auto _ : state) {
        const CorrespondenceMap map = decode(captures);
        const ScanView view = scan().triangulator->triangulate(map, captures.white_colour);
        points = size_t(view.valid_count());
        benchmark::DoNotOptimize(view.points.data);
    }
    state.counters["points"] = double(points);
    set_counters(state, captures);
}

// Outputs reused from scan to scan (a scanner in a loop).
void picoscan_decode_triangulate_reusing(benchmark::State& state, const CaptureSet& captures) {
    CorrespondenceMap map;
    ScanView view;
    for (auto _ : state) {
        decode_into(captures, {}, map);
        scan().triangulator->triangulate_into(map, captures.white_colour, view);
        benchmark::DoNotOptimize(view.points.data);
    }
    state.counters["points"] = double(view.valid_count());
    set_counters(state, captures);
}

void BM_Floor_ReadEveryFrame_Columns(benchmark::State& state) { read_every_frame(state, scan().column_frames); }
void BM_PicoScan_DecodeTriangulate_Columns(benchmark::State& state) { picoscan_decode_triangulate(state, scan().column_frames); }
void BM_PicoScan_DecodeTriangulateReusing_Columns(benchmark::State& state) {
    picoscan_decode_triangulate_reusing(state, scan().column_frames);
}
void BM_PicoScan_DecodeTriangulateReusing_ColumnsRows(benchmark::State& state) {
    picoscan_decode_triangulate_reusing(state, scan().all_frames);
}
void BM_Floor_ReadEveryFrame_ColumnsRows(benchmark::State& state) { read_every_frame(state, scan().all_frames); }
void BM_PicoScan_DecodeTriangulate_ColumnsRows(benchmark::State& state) { picoscan_decode_triangulate(state, scan().all_frames); }

void BM_PicoScan_DecodeOnly_Columns(benchmark::State& state) {
    CorrespondenceMap map;
    for (auto _ : state) decode_into(scan().column_frames, {}, map);
    set_counters(state, scan().column_frames);
}

// The Gray code alone (columns and rows), the same work as OpenCV's getProjPixel below.
void BM_PicoScan_GrayCodeOnly_ColumnsRows(benchmark::State& state) {
    CorrespondenceMap map;
    DecodeOptions options;
    options.binary_only = true;
    for (auto _ : state) decode_into(scan().all_frames, options, map);
    state.counters["frames"] = 2 + 2.0 * (scan().all_frames.sequence.columns.gray_bits + scan().all_frames.sequence.rows.gray_bits);
    state.counters["points"] = double(cv::countNonZero(map.mask));
}

// OpenCV contrib: GrayCodePattern::getProjPixel for every camera pixel (its decode loop),
// on the Gray frames (columns and rows with inverses; it needs both).
void BM_OpenCV_GrayCode_GetProjPixel(benchmark::State& state) {
    const CaptureSet& captures = scan().all_frames;
    std::vector<cv::Mat> gray_frames;
    for (size_t index = 0; index < captures.sequence.frames.size(); ++index) {
        const FrameKind kind = captures.sequence.frames[index].kind;
        if (kind == FrameKind::Gray || kind == FrameKind::GrayInverse) gray_frames.push_back(captures.images[index]);
    }
    auto graycode = cv::structured_light::GrayCodePattern::create(captures.sequence.projector_size.width,
                                                                  captures.sequence.projector_size.height);
    const cv::Size size = captures.images.front().size();
    long decoded = 0;
    for (auto _ : state) {
        decoded = 0;
        cv::Point projector_pixel;
        for (int y = 0; y < size.height; ++y)
            for (int x = 0; x < size.width; ++x) decoded += !graycode->getProjPixel(gray_frames, x, y, projector_pixel);
        benchmark::DoNotOptimize(decoded);
    }
    state.counters["frames"] = double(gray_frames.size());
    state.counters["points"] = double(decoded);
}

// OpenCV contrib: SinusoidalPattern PSP (three-step) phase map + its phase unwrapping, on
// shifts 0, 8 and 16 of 24 (exactly 0, 2pi/3, 4pi/3) of the columns.
void BM_OpenCV_Sinusoidal_PSP_3Step(benchmark::State& state) {
    const CaptureSet& captures = scan().all_frames;
    std::vector<cv::Mat> three;
    for (size_t index = 0; index < captures.sequence.frames.size(); ++index) {
        const Frame& frame = captures.sequence.frames[index];
        if (frame.kind == FrameKind::Phase && frame.axis == Axis::Columns && frame.shift % 8 == 0)
            three.push_back(captures.images[index]);
    }
    auto parameters = cv::makePtr<cv::structured_light::SinusoidalPattern::Params>();
    parameters->width = captures.sequence.projector_size.width;
    parameters->height = captures.sequence.projector_size.height;
    parameters->nbrOfPeriods = int(captures.sequence.projector_size.width / captures.sequence.columns.period_px);
    parameters->methodId = cv::structured_light::PSP;
    auto sinusoidal = cv::structured_light::SinusoidalPattern::create(parameters);
    cv::Mat wrapped, unwrapped, shadow_mask;
    for (auto _ : state) {
        sinusoidal->computePhaseMap(three, wrapped, shadow_mask);
        sinusoidal->unwrapPhaseMap(wrapped, unwrapped, captures.images.front().size(), shadow_mask);
        benchmark::DoNotOptimize(unwrapped.data);
    }
    state.counters["frames"] = 3;
}

}  // namespace

BENCHMARK(BM_Floor_ReadEveryFrame_Columns)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PicoScan_DecodeTriangulate_Columns)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PicoScan_DecodeTriangulateReusing_Columns)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PicoScan_DecodeOnly_Columns)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Floor_ReadEveryFrame_ColumnsRows)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PicoScan_DecodeTriangulate_ColumnsRows)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PicoScan_DecodeTriangulateReusing_ColumnsRows)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PicoScan_GrayCodeOnly_ColumnsRows)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_OpenCV_GrayCode_GetProjPixel)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_OpenCV_Sinusoidal_PSP_3Step)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
