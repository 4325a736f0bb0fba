// Fusing many full-resolution views: the mechanical part standing on a turntable disc,
// seen by the seed rig's 1600x1200 camera in N views 360/N degrees apart, merged with
// their true poses and meshed by Poisson (fill poisson, the default budget), then checked and
// written. Prints each stage as it starts (the progress a host shows) and reports the
// seconds of each stage and the peak resident memory of the process as counters.
//
// fuse_views_streamed: the views are ray-cast one at a time as fuse_views asks for them (a
// host reading view files one by one), so only one pixel grid is held at a time; the
// ray-casting is timed apart and left out of the merging stage.
// fuse_views_held_whole: every view made first and held whole (52 MB per 1600x1200 view), as
// a host holding all its views in memory does; the making is outside the timing.
// Run one benchmark per process: the peak resident memory is the process's.
//
//   build/benchmarks/bench_fuse_scale --benchmark_filter=streamed/16
//   build/benchmarks/bench_fuse_scale --benchmark_filter=streamed/32
//   build/benchmarks/bench_fuse_scale --benchmark_filter=held_whole/16
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

// The views of the part on its disc in `view_count` turntable steps, each posed into view 0's
// frame, made when asked for.
class TurntableViews {
public:
    explicit TurntableViews(int view_count) : view_count_(view_count), rig_(seed_rig_calibration()) {
        TurntablePlan plan;
        plan.turntable_views = view_count;
        plan.top_view = false;
        poses_ = turntable_part_poses(plan);
        part_frame_.meshes.push_back({mechanical_part(), 0.85});
        part_frame_.cylinders.push_back({cv::Vec3d(0, 0, -5), cv::Vec3d(0, 0, 1), 70, 5, 0.6});
    }
    ScanView view(size_t index) const {
        std::fprintf(stderr, "ray-casting view %zu of %d\n", index + 1, view_count_);
        ScanView view = noisy_view(Simulator(rig_, transformed(part_frame_, poses_[index])), rig_, uint64_t(index + 1));
        view.pose = poses_[0] * poses_[index].inv();  // into view 0's frame
        return view;
    }

private:
    int view_count_;
    Calibration rig_;
    std::vector<cv::Matx44d> poses_;
    Scene part_frame_;
};

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// Fuses the views view_at gives, timing each stage as fuse_views reports it; `input_seconds`
// (the time spent making views inside view_at) is taken out of the merging stage.
void fuse_and_count(benchmark::State& state, int view_count, const ViewSource& view_at, const double& input_seconds) {
    std::map<std::string, double> seconds;  // stage -> seconds
    size_t points = 0, faces = 0;
    for (auto _ : state) {
        std::string stage = "merging the views";
        Clock::time_point started = Clock::now();
        const Clock::time_point begin = started;
        auto enter = [&](const std::string& next) {
            seconds[stage] += seconds_since(started);
            std::fprintf(stderr, "  %6.1f s  %s (peak %.0f MB so far)\n", seconds_since(begin), next.c_str(), peak_resident_mb());
            stage = next;
            started = Clock::now();
        };
        std::fprintf(stderr, "fusing %d views\n", view_count);
        const FuseResult fused = fuse_views(size_t(view_count), view_at, MeshOptions{}, [&](double, const std::string& next) {
            if (next != stage) enter(next);
            return true;
        });
        enter("writing the mesh");
        const std::filesystem::path out = std::filesystem::temp_directory_path() / "picoscan-bench-fuse-scale.ply";
        write_mesh(fused.mesh, out.string());
        std::filesystem::remove(out);
        enter("done");
        points = fused.merged.points.size();
        faces = fused.mesh.faces.size();
        std::fprintf(stderr, "%zu points; %s\n", points, fused.check.summary().c_str());
    }
    if (input_seconds > 0) {
        seconds["merging the views"] -= input_seconds;
        seconds["ray-casting the views (input)"] = input_seconds;
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

void fuse_views_streamed(benchmark::State& state) {
    const int view_count = static_cast<int>(state.range(0));
    const TurntableViews views(view_count);
    double making_seconds = 0;
    fuse_and_count(state, view_count, [&](size_t index) {
        const Clock::time_point start = Clock::now();
        ScanView view = views.view(index);
        making_seconds += seconds_since(start);
        return view;
    }, making_seconds);
}

void fuse_views_held_whole(benchmark::State& state) {
    const int view_count = static_cast<int>(state.range(0));
    const TurntableViews made(view_count);
    std::vector<ScanView> views;
    for (int i = 0; i < view_count; ++i) views.push_back(made.view(size_t(i)));
    fuse_and_count(state, view_count, [&](size_t index) { return views[index]; }, 0.0);
}

}  // namespace

BENCHMARK(fuse_views_streamed)->Arg(16)->Arg(32)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(fuse_views_held_whole)->Arg(16)->Arg(32)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

BENCHMARK_MAIN();
