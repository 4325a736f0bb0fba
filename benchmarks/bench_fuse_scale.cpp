// Fusing many full-resolution views: the mechanical part standing on a turntable disc,
// seen by the seed rig's 1600x1200 camera in N views 360/N degrees apart, merged with
// their true poses and meshed by Poisson (fill poisson, the default budget), then checked and
// written. Prints each stage as it starts (the progress a host shows) and reports the
// seconds of each stage and the peak resident memory of the process as counters.
// The views are made once, outside the timing.
//
//   build/benchmarks/bench_fuse_scale --benchmark_filter=/16
//   build/benchmarks/bench_fuse_scale --benchmark_filter=/32
#include "picoscan/io.h"
#include "picoscan/mesh.h"
#include "picoscan/pipeline.h"
#include "picoscan/simulate.h"

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cmath>
#include <limits>
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

// The part on a 140 mm disc 5 mm thick that turns with it. Each view is the ray-cast truth
// of every lit camera pixel (Simulator::geometry) with 20 um of independent noise along the
// camera ray: rendering and decoding the patterns of 16-32 full views would take longer than
// the fusion measured here, and would not change how many points it gets.
ScanView noisy_view(const Simulator& simulator, const Calibration& rig, uint64_t seed) {
    const SimulatedGeometry& truth = simulator.geometry();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    ScanView view;
    view.points = cv::Mat(truth.points.size(), CV_32FC3, cv::Scalar::all(nan));
    view.normals = cv::Mat(truth.points.size(), CV_32FC3, cv::Scalar::all(nan));
    view.colours = cv::Mat(truth.points.size(), CV_8UC3, cv::Scalar::all(0));
    view.camera_matrix = rig.camera_matrix;
    view.camera_distortion = rig.camera_distortion.clone();
    cv::RNG random(seed);
    for (int y = 0; y < truth.points.rows; ++y)
        for (int x = 0; x < truth.points.cols; ++x) {
            const cv::Vec3f p = truth.points.at<cv::Vec3f>(y, x);
            if (!truth.lit.at<uint8_t>(y, x) || !std::isfinite(p[0])) continue;
            const cv::Vec3d ray = cv::normalize(cv::Vec3d(p));
            cv::Vec3d n = cv::Vec3d(truth.normals.at<cv::Vec3f>(y, x));
            if (n.dot(ray) > 0) n = -n;  // towards the camera
            view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(cv::Vec3d(p) + ray * random.gaussian(0.02));
            view.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(n);
            const uint8_t grey = cv::saturate_cast<uint8_t>(255 * truth.shading.at<float>(y, x));
            view.colours.at<cv::Vec3b>(y, x) = cv::Vec3b(grey, grey, grey);
        }
    return view;
}

std::vector<ScanView> turntable_views(int view_count) {
    TurntablePlan plan;
    plan.turntable_views = view_count;
    plan.top_view = false;
    const std::vector<cv::Matx44d> poses = turntable_part_poses(plan);
    Scene part_frame;
    part_frame.meshes.push_back({mechanical_part(), 0.85});
    part_frame.cylinders.push_back({cv::Vec3d(0, 0, -5), cv::Vec3d(0, 0, 1), 70, 5, 0.6});
    const Calibration rig = seed_rig_calibration();
    std::vector<ScanView> views;
    for (int i = 0; i < view_count; ++i) {
        std::fprintf(stderr, "ray-casting view %d of %d\n", i + 1, view_count);
        ScanView view = noisy_view(Simulator(rig, transformed(part_frame, poses[size_t(i)])), rig, uint64_t(i + 1));
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
