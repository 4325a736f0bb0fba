// Prepares the fuzzers' working corpora: copies the committed seeds (so the fuzzers never
// modify them) and adds seeds written by PicoScan's own writers, which keeps the binary
// seeds in step with the formats.
//   fuzz_seed_corpus <committed corpus dir> <working corpus dir>
#include "picoscan/calibration.h"
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "picoscan/patterns.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using namespace picoscan;

namespace {

Mesh tetrahedron() {
    Mesh mesh;
    mesh.vertices = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0, 10}};
    mesh.faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    mesh.normals = {{-0.577f, -0.577f, -0.577f}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    mesh.colours = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {128, 128, 128}};
    return mesh;
}

template <class T>
void append_be(std::string& out, T value) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    for (size_t i = 0; i < sizeof(T); ++i) out.push_back(static_cast<char>(bytes[sizeof(T) - 1 - i]));
}

// Big-endian PLY with double coordinates, a quad face and an unknown element.
std::string big_endian_ply() {
    std::string bytes =
        "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
        "property double z\nproperty ushort red\nproperty ushort green\nproperty ushort blue\n"
        "element face 1\nproperty list uint int vertex_indices\nelement extra 1\nproperty short s\nend_header\n";
    const double corners[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (const auto& c : corners) {
        append_be<double>(bytes, c[0]);
        append_be<double>(bytes, c[1]);
        append_be<double>(bytes, 5.0);
        for (int k = 0; k < 3; ++k) append_be<uint16_t>(bytes, 200);
    }
    append_be<uint32_t>(bytes, 4);
    for (int32_t i : {0, 1, 2, 3}) append_be<int32_t>(bytes, i);
    append_be<int16_t>(bytes, -3);
    return bytes;
}

void write_raw(const fs::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) throw Error(path.string(), "cannot write seed");
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s <committed corpus dir> <working corpus dir>\n", argv[0]);
        return 2;
    }
    try {
        const fs::path committed = argv[1], work = argv[2];
        fs::remove_all(work);
        fs::create_directories(work);
        fs::copy(committed, work, fs::copy_options::recursive);
        for (const char* target : {"ply", "stl", "manifest", "calibration", "scene", "poses"}) fs::create_directories(work / target);

        const Mesh mesh = tetrahedron();
        PointCloud cloud;
        cloud.points = mesh.vertices;
        cloud.normals = mesh.normals;
        cloud.colours = mesh.colours;
        cloud.quality = {1, 2, 3, 4};
        write_ply(mesh, (work / "ply" / "gen_mesh_binary.ply").string(), Encoding::Binary);
        write_ply(mesh, (work / "ply" / "gen_mesh_ascii.ply").string(), Encoding::Ascii);
        write_ply(cloud, (work / "ply" / "gen_cloud_binary.ply").string(), Encoding::Binary);
        write_ply(cloud, (work / "ply" / "gen_cloud_ascii.ply").string(), Encoding::Ascii);
        write_raw(work / "ply" / "gen_big_endian.ply", big_endian_ply());
        write_stl(mesh, (work / "stl" / "gen_binary.stl").string(), Encoding::Binary);
        write_stl(mesh, (work / "stl" / "gen_ascii.stl").string(), Encoding::Ascii);

        PatternOptions options;
        options.projector_size = {64, 32};
        options.shifts = 3;
        options.period_bits = 3;
        write_manifest(make_pattern_sequence(options), (work / "manifest" / "gen_picoscan.json").string());
        options.rows = false;
        write_manifest(make_pattern_sequence(options), (work / "manifest" / "gen_columns_only.json").string());
        write_manifest(make_slstudio_gray_sequence({64, 32}, 6), (work / "manifest" / "gen_slstudio.json").string());

        Calibration calibration;
        calibration.camera_size = {64, 48};
        calibration.camera_matrix = {80, 0, 31.5, 0, 80, 23.5, 0, 0, 1};
        calibration.projector_size = {32, 16};
        calibration.projector_matrix = {40, 0, 15.5, 0, 40, 7.5, 0, 0, 1};
        calibration.T = {-150, 0, 10};
        write_calibration(calibration, (work / "calibration" / "gen_picoscan.yml").string());

        std::vector<ViewPose> views(3);
        for (size_t i = 0; i < views.size(); ++i) {
            views[i].name = "view" + std::to_string(i) + ".ply";
            views[i].aligned = i != 2;
            const double angle = 0.7 * double(i);
            views[i].pose = {std::cos(angle), 0, std::sin(angle), 10.0 * i, 0, 1, 0, 0,
                             -std::sin(angle), 0, std::cos(angle), 400, 0, 0, 0, 1};
        }
        write_poses(views, (work / "poses" / "gen_turntable.txt").string());
    } catch (const std::exception& error) {
        std::fprintf(stderr, "fuzz_seed_corpus: %s\n", error.what());
        return 1;
    }
    return 0;
}
