// Meshing time of one full-resolution view: the built-in demo scene simulated on the seed rig
// (1600x1200 camera, about 1.9 million points), meshed with fill open (the band surface) with
// the default budget, by Poisson closed and then cut to the measured faces (what fill open did
// before the band surface), and by the pixel grid for comparison. The view is simulated once,
// outside the timing.
//
//   build/benchmarks/bench_mesh
#include "picoscan/error.h"
#include "picoscan/mesh.h"
#include "picoscan/pipeline.h"
#include "picoscan/simulate.h"

#include <benchmark/benchmark.h>

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

}  // namespace

BENCHMARK_CAPTURE(mesh_full_view, open_band_spacing_1mm, MeshMethod::Poisson, MeshFill::Open, 1.0)
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(mesh_full_view, open_band_spacing_0_4mm, MeshMethod::Poisson, MeshFill::Open, 0.4)
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(mesh_full_view, poisson_cut_to_measured_spacing_1mm, MeshMethod::Poisson, MeshFill::Poisson, 1.0)
    ->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(mesh_full_view, grid, MeshMethod::Grid, MeshFill::Open, 0.4)->Unit(benchmark::kSecond)->Iterations(1);

BENCHMARK_MAIN();
