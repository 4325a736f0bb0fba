// Deviation map speed: signed distances of 1 M scan points to a reference of about 100 k
// triangles (the demo part, remeshed to that size), AABB tree build included.
//
//   build/benchmarks/bench_deviation
#include "picoscan/deviation.h"
#include "picoscan/simulate.h"

#include <benchmark/benchmark.h>

#include <random>

using namespace picoscan;

namespace {

// The demo part with its triangles split until it has at least `triangles` of them.
Mesh reference_of_size(size_t triangles) {
    Mesh mesh = mechanical_part();
    while (mesh.faces.size() < triangles) {
        Mesh finer;
        finer.vertices = mesh.vertices;
        for (const cv::Vec3i& f : mesh.faces) {
            const int centre = int(finer.vertices.size());
            finer.vertices.push_back((mesh.vertices[f[0]] + mesh.vertices[f[1]] + mesh.vertices[f[2]]) / 3);
            finer.faces.emplace_back(f[0], f[1], centre);
            finer.faces.emplace_back(f[1], f[2], centre);
            finer.faces.emplace_back(f[2], f[0], centre);
        }
        mesh = finer;
    }
    return mesh;
}

// Points on the reference's triangles with 20 um of noise along z.
std::vector<cv::Vec3f> scan_points(const Mesh& mesh, size_t count) {
    std::mt19937 random(1);
    std::uniform_int_distribution<size_t> face(0, mesh.faces.size() - 1);
    std::uniform_real_distribution<float> unit(0, 1);
    std::normal_distribution<float> noise(0, 0.02f);
    std::vector<cv::Vec3f> points(count);
    for (auto& p : points) {
        const cv::Vec3i f = mesh.faces[face(random)];
        float u = unit(random), v = unit(random);
        if (u + v > 1) u = 1 - u, v = 1 - v;
        p = mesh.vertices[f[0]] + u * (mesh.vertices[f[1]] - mesh.vertices[f[0]]) + v * (mesh.vertices[f[2]] - mesh.vertices[f[0]]);
        p[2] += noise(random);
    }
    return points;
}

void BM_Deviation_MeasureAgainstMesh(benchmark::State& state) {
    const Mesh reference = reference_of_size(size_t(state.range(1)));
    const std::vector<cv::Vec3f> points = scan_points(reference, size_t(state.range(0)));
    for (auto _ : state) {
        const DeviationMap map = measure_deviation(points, reference);
        benchmark::DoNotOptimize(map.statistics.mean_mm);
    }
    state.counters["points"] = double(points.size());
    state.counters["triangles"] = double(reference.faces.size());
}

}  // namespace

// {1, ...}: the reference alone (welding, pseudo-normals, AABB tree); {1000000, ...}: the target case.
BENCHMARK(BM_Deviation_MeasureAgainstMesh)->Args({1, 100000})->Args({1000000, 100000})->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
