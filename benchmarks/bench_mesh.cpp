// Meshing time of one full-resolution view: the built-in demo scene simulated on the seed rig
// (1600x1200 camera, about 1.9 million points), meshed with fill open (the band surface) with
// the default budget, by Poisson closed and then cut to the measured faces (what fill open did
// before the band surface), and by the pixel grid for comparison. The view is simulated once,
// outside the timing.
//
// single_view_poisson: one view of a test turntable scan closed by Poisson (fill poisson, the
// default options: what `picoscan mesh VIEW.ply --fill poisson` does), the mechanical part's view 2
// and the plain stepped block's view 0, read from the views the tests cache (run
// `test_fill --gtest_filter=MeshFill.PoissonClosesASingleView` once to make them). The seconds
// of each stage are counters (time_<stage>); so are the faces and whether the mesh is closed.
//
//   build/benchmarks/bench_mesh
//   build/benchmarks/bench_mesh --benchmark_filter=single_view_poisson
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "picoscan/mesh.h"
#include "picoscan/pipeline.h"
#include "picoscan/simulate.h"

#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <string>

using namespace picoscan;

namespace {

const ScanView& full_view() {
    static const ScanView view = [] {
        const Calibration rig = seed_rig_calibration();
        return reconstruct_view(simulate_captures(demo_scene(), rig), rig, "seed rig").view;
    }();
    return view;
}

void mesh_full_view(benchmark::State& state, MeshMethod method, MeshFill fill, double spacing_mm) {
    const ScanView& view = full_view();
    MeshOptions options;
    options.method = method;
    options.fill = fill;
    options.sample_spacing_mm = spacing_mm;
    size_t faces = 0;
    for (auto _ : state) {
        Mesh mesh;
        try {
            mesh = mesh_view(view, options);
        } catch (const Error& e) {
            state.SkipWithError(e.what());  // a refusal is a result too
            break;
        }
        if (fill == MeshFill::Poisson) {
            // Poisson's closure cut away: the faces with fewer than two measured corners go.
            std::vector<cv::Vec3i> measured;
            for (const cv::Vec3i& f : mesh.faces)
                if (mesh.measured[f[0]] + mesh.measured[f[1]] + mesh.measured[f[2]] >= 2) measured.push_back(f);
            mesh.faces.swap(measured);
        }
        faces = mesh.faces.size();
        benchmark::DoNotOptimize(faces);
    }
    state.counters["points"] = view.valid_count();
    state.counters["faces"] = static_cast<double>(faces);
}

// The seconds of each stage, from the progress reports: a stage lasts until the next one starts.
class StageClock {
public:
    ProgressCallback callback() {
        return [this](double, const std::string& stage) {
            switch_to(stage);
            return true;
        };
    }
    void switch_to(const std::string& stage) {
        const auto now = std::chrono::steady_clock::now();
        if (!current_.empty()) seconds_[current_] += std::chrono::duration<double>(now - since_).count();
        current_ = stage;
        since_ = now;
    }
    const std::map<std::string, double>& seconds() {
        switch_to("");
        return seconds_;
    }

private:
    std::string current_;
    std::chrono::steady_clock::time_point since_;
    std::map<std::string, double> seconds_;
};

void single_view_poisson(benchmark::State& state, const std::string& view_file) {
    const std::filesystem::path path = std::filesystem::path(PICOSCAN_TEST_CACHE_DIR) / view_file;
    if (!std::filesystem::exists(path)) {
        state.SkipWithError((path.string() + " is missing: run test_fill --gtest_filter=MeshFill.PoissonClosesASingleView").c_str());
        return;
    }
    const ScanView view = read_view_ply(path.string());
    MeshOptions options;
    options.fill = MeshFill::Poisson;
    MeshCheck check;
    StageClock clock;
    for (auto _ : state) {
        try {
            check = check_mesh(mesh_view(view, options, clock.callback()));
        } catch (const Error& e) {
            state.SkipWithError(e.what());
            return;
        }
    }
    for (const auto& [stage, seconds] : clock.seconds())
        state.counters["time_" + stage] = benchmark::Counter(seconds, benchmark::Counter::kAvgIterations);
    state.counters["faces"] = static_cast<double>(check.faces);
    state.counters["closed"] = check.closed_volume;
    state.counters["volume_mm3"] = check.volume_mm3;
}

}  // namespace

BENCHMARK_CAPTURE(single_view_poisson, mechanical_view_2, "turntable-v3-disturbed/view_2.ply")
    ->Unit(benchmark::kSecond)->MeasureProcessCPUTime()->Iterations(1);
BENCHMARK_CAPTURE(single_view_poisson, stepped_block_view_0, "plain-v2-stepped-block/view_0.ply")
    ->Unit(benchmark::kSecond)->MeasureProcessCPUTime()->Iterations(1);
BENCHMARK_CAPTURE(mesh_full_view, open_band_spacing_1mm, MeshMethod::Poisson, MeshFill::Open, 1.0)
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(mesh_full_view, open_band_spacing_0_4mm, MeshMethod::Poisson, MeshFill::Open, 0.4)
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(mesh_full_view, poisson_cut_to_measured_spacing_1mm, MeshMethod::Poisson, MeshFill::Poisson, 1.0)
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(mesh_full_view, grid, MeshMethod::Grid, MeshFill::Open, 0.4)->Unit(benchmark::kSecond)->Iterations(1);

BENCHMARK_MAIN();
