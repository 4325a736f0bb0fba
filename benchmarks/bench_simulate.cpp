// Simulator speed: ray-casting a 1600x1200 camera view of a triangle-mesh scene, and
// rendering one frame of a pattern from it.
//
//   build/benchmarks/bench_simulate
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"

#include <benchmark/benchmark.h>

#include <cmath>

using namespace picoscan;

namespace {

// A UV sphere of about `triangles` triangles, radius 40 mm at 400 mm, in front of a plane.
Scene mesh_scene(int triangles) {
    const int rings = int(std::sqrt(triangles / 4.0)), segments = 2 * rings;
    TriangleMesh sphere;
    const double radius = 40, pi = 3.14159265358979323846;
    for (int ring = 0; ring <= rings; ++ring)
        for (int segment = 0; segment < segments; ++segment) {
            const double polar = pi * ring / rings, azimuth = 2 * pi * segment / segments;
            sphere.mesh.vertices.emplace_back(float(radius * std::sin(polar) * std::cos(azimuth)),
                                              float(radius * std::cos(polar)),
                                              float(400 + radius * std::sin(polar) * std::sin(azimuth)));
        }
    for (int ring = 0; ring < rings; ++ring)
        for (int segment = 0; segment < segments; ++segment) {
            const int a = ring * segments + segment, b = ring * segments + (segment + 1) % segments;
            const int c = a + segments, d = b + segments;
            sphere.mesh.faces.emplace_back(a, c, b);
            sphere.mesh.faces.emplace_back(b, c, d);
        }
    Scene scene;
    scene.meshes.push_back(sphere);
    scene.planes.push_back({cv::Vec3d(0, 0, 460), cv::Vec3d(0, 0, -1), 0.5});
    return scene;
}

void BM_Simulator_RayCastMeshScene(benchmark::State& state) {
    const Calibration calibration = seed_rig_calibration();
    const Scene scene = mesh_scene(int(state.range(0)));
    for (auto _ : state) {
        Simulator simulator(calibration, scene);
        benchmark::DoNotOptimize(&simulator.geometry());
    }
    state.counters["triangles"] = double(scene.meshes.front().mesh.faces.size());
}

void BM_Simulator_RenderOneFrame(benchmark::State& state) {
    const Calibration calibration = seed_rig_calibration();
    const Simulator simulator(calibration, mesh_scene(100000));
    PatternOptions options;
    options.projector_size = calibration.projector_size;
    const PatternSequence sequence = make_pattern_sequence(options);
    const cv::Mat pattern = render_pattern(sequence, sequence.frames.back());
    int frame = 0;
    for (auto _ : state) benchmark::DoNotOptimize(simulator.render(pattern, frame++).data);
}

}  // namespace

BENCHMARK(BM_Simulator_RayCastMeshScene)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Simulator_RenderOneFrame)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
