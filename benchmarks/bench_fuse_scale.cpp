// Fusing many full-resolution views: the mechanical part standing on a turntable disc,
// simulated on the seed rig (1600x1200 camera) in N views 360/N degrees apart, merged with
// their true poses and meshed by Poisson (fill poisson, the default budget), then checked and
// written. Prints each stage as it starts (the progress a host shows) and reports the
// seconds of each stage and the peak resident memory of the process as counters.
// The views are simulated once and cached as view PLYs (PICOSCAN_BENCH_CACHE, default
// /tmp/picoscan-bench-fuse-scale), outside the timing.
//
//   build/benchmarks/bench_fuse_scale                       (16 views)
//   build/benchmarks/bench_fuse_scale --benchmark_filter=32
#include "picoscan/io.h"
#include "picoscan/mesh.h"
#include "picoscan/pipeline.h"
#include "picoscan/simulate.h"

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

using namespace picoscan;

namespace {

double peak_resident_mb() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return double(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

std::filesystem::path cache_dir(int view_count) {
    const char* chosen = std::getenv("PICOSCAN_BENCH_CACHE");
    const std::filesystem::path root = chosen ? chosen : "/tmp/picoscan-bench-fuse-scale";
    return root / ("v1-" + std::to_string(view_count) + "-views");
}

// The part on a 140 mm disc 5 mm thick that turns with it, each view with its own noise.
std::vector<ScanView> turntable_views(int view_count) {
    TurntablePlan plan;
    plan.turntable_views = view_count;
    plan.top_view = false;
    const std::vector<cv::Matx44d> poses = turntable_part_poses(plan);
    const TurntableScanOptions recipe;
    Scene part_frame;
    part_frame.meshes.push_back({mechanical_part(), recipe.part_albedo});
    part_frame.cylinders.push_back({cv::Vec3d(0, 0, -5), cv::Vec3d(0, 0, 1), 70, 5, 0.6});
    const Calibration rig = seed_rig_calibration();
    const std::filesystem::path cache = cache_dir(view_count);
    std::filesystem::create_directories(cache);
    std::vector<ScanView> views;
    for (int i = 0; i < view_count; ++i) {
        const std::filesystem::path path = cache / ("view_" + std::to_string(i) + ".ply");
        if (!std::filesystem::exists(path)) {
            std::fprintf(stderr, "simulating view %d of %d (cached in %s)\n", i + 1, view_count, cache.c_str());
            SimulateOptions simulate;
            simulate.patterns = recipe.patterns;
            simulate.camera = recipe.camera;
            simulate.camera.seed = uint64_t(i + 1);
            ReconstructOptions reconstruct;
            reconstruct.decode = recipe.decode;
            reconstruct.clean = true;
            const ScanView view =
                reconstruct_view(simulate_captures(transformed(part_frame, poses[size_t(i)]), rig, simulate), rig,
                                 "seed rig", reconstruct)
                    .view;
            write_view_ply(view, path.string());
        }
        ScanView view = read_view_ply(path.string());
        view.pose = poses[0] * poses[size_t(i)].inv();  // into view 0's frame
        views.push_back(std::move(view));
    }
    return views;
}

using Clock = std::chrono::steady_clock;

void fuse_views_at_scale(benchmark::State& state) {
    const int view_count = static_cast<int>(state.range(0));
    const std::vector<ScanView> views = turntable_views(view_count);
    size_t points = 0;
    for (const ScanView& view : views) points += size_t(view.valid_count());
    std::map<std::string, double> seconds;  // stage -> seconds
    size_t faces = 0;
    for (auto _ : state) {
        std::string stage = "merging the views";
        Clock::time_point started = Clock::now();
        const Clock::time_point begin = started;
        auto enter = [&](const std::string& next) {
            const Clock::time_point now = Clock::now();
            seconds[stage] += std::chrono::duration<double>(now - started).count();
            std::fprintf(stderr, "  %6.1f s  %s (peak %.0f MB so far)\n", std::chrono::duration<double>(now - begin).count(),
                         next.c_str(), peak_resident_mb());
            stage = next;
            started = now;
        };
        std::fprintf(stderr, "fusing %d views, %zu points\n", view_count, points);
        const FuseResult fused = fuse_views(views, MeshOptions{}, [&](double, const std::string& next) {
            if (next != stage) enter(next);
            return true;
        });
        enter("writing the mesh");
        const std::filesystem::path out = std::filesystem::temp_directory_path() / "picoscan-bench-fuse-scale.ply";
        write_mesh(fused.mesh, out.string());
        std::filesystem::remove(out);
        enter("done");
        faces = fused.mesh.faces.size();
        std::fprintf(stderr, "%s\n", fused.check.summary().c_str());
    }
    state.counters["views"] = view_count;
    state.counters["points"] = double(points);
    state.counters["faces"] = double(faces);
    state.counters["peak_MB"] = peak_resident_mb();
    for (const auto& [stage, time] : seconds) {
        std::string name = stage;  // one word per counter
        for (char& c : name)
            if (c == ' ') c = '_';
        state.counters[name] = time;
    }
}

}  // namespace

BENCHMARK(fuse_views_at_scale)->Arg(16)->Arg(32)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

BENCHMARK_MAIN();
