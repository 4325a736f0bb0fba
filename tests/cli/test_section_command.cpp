// picoscan section, run as a user would: a mesh of the demo part cut across its block must give
// the outline's 5 lines and the hole's circle in the DXF (read back here) and the SVG; inputs
// built to fool it (a plane that misses the part, a sphere whose Band trends) and bad input.
#include "picoscan/io.h"
#include "picoscan/section_fit.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <tuple>

namespace fs = std::filesystem;
using namespace picoscan;
using test_support::make_temp_dir;
using test_support::read_file_bytes;
using test_support::run_picoscan;
using Result = test_support::CliResult;

namespace {

constexpr double kPi = 3.14159265358979323846;

// One DXF entity: its type and its group values by code.
struct DxfEntity {
    std::string type;
    std::map<int, double> values;
};

// The entities of an ASCII DXF's ENTITIES section (group code line, value line).
std::vector<DxfEntity> read_dxf_entities(const std::string& path) {
    std::ifstream in(path);
    std::vector<DxfEntity> entities;
    std::string code, value;
    bool in_entities = false;
    while (std::getline(in, code) && std::getline(in, value)) {
        const int group = std::stoi(code);
        if (group == 2 && value == "ENTITIES") in_entities = true;
        if (!in_entities) continue;
        if (group == 0) {
            if (value == "ENDSEC") break;
            entities.push_back({value, {}});
        } else if (!entities.empty() && group != 8) {
            entities.back().values[group] = std::stod(value);
        }
    }
    return entities;
}

size_t count_of(const std::string& text, const std::string& part) {
    size_t count = 0;
    for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++count;
    return count;
}

// The demo part's mesh with `sigma` mm of noise on its vertices (one move per position: the
// surface stays closed), as an STL.
std::string noisy_demo_part(const fs::path& dir, double sigma) {
    Mesh part = mechanical_part();
    std::mt19937 random(3);
    std::normal_distribution<float> unit_noise;  // scaled: its deviation must be positive, and sigma may be 0
    const auto noise = [&](auto& engine) { return float(sigma) * unit_noise(engine); };
    std::map<std::tuple<float, float, float>, cv::Vec3f> moved;
    for (cv::Vec3f& v : part.vertices) {
        const auto key = std::make_tuple(v[0], v[1], v[2]);
        if (!moved.count(key)) moved[key] = v + cv::Vec3f(noise(random), noise(random), noise(random));
        v = moved[key];
    }
    const std::string path = (dir / "part.stl").string();
    write_stl(part, path);
    return path;
}

// An open band of a sphere's wall (radius 10 mm, z from -3.5 to 4.5 mm, rings 0.1 mm apart),
// 10 um of radial noise (as the FreeCAD test of the Band on a sphere).
std::string sphere_wall(const fs::path& dir) {
    Mesh mesh;
    std::mt19937 random(4);
    std::normal_distribution<double> noise(0.0, 0.01);
    const int rows = 81, columns = 360;
    for (int row = 0; row < rows; ++row) {
        const double z = -3.5 + 0.1 * row, ring = std::sqrt(100 - z * z);
        for (int c = 0; c < columns; ++c) {
            const double angle = 2 * kPi * c / columns, r = ring + noise(random);
            mesh.vertices.emplace_back(float(r * std::cos(angle)), float(r * std::sin(angle)), float(z));
        }
    }
    for (int row = 0; row + 1 < rows; ++row)
        for (int c = 0; c < columns; ++c) {
            const int a = row * columns + c, b = row * columns + (c + 1) % columns;
            mesh.faces.emplace_back(a, b, b + columns);
            mesh.faces.emplace_back(a, b + columns, a + columns);
        }
    const std::string path = (dir / "sphere.ply").string();
    write_ply(mesh, path);
    return path;
}

}  // namespace

TEST(SectionCli, DemoPartOutlineIsFiveLinesAndTheHoleInTheDxfAndSvg) {
    const fs::path dir = make_temp_dir("section_cli");
    const std::string part = noisy_demo_part(dir, 0.01);
    const std::string svg = (dir / "outline.svg").string(), dxf = (dir / "outline.dxf").string();
    const Result result = run_picoscan("section " + part + " --axis z --at 12 --svg " + svg + " --dxf " + dxf);
    ASSERT_EQ(result.exit_code, 0) << result.output;
    std::printf("%s", result.output.c_str());
    EXPECT_NE(result.output.find("band +- 3.000 mm"), std::string::npos) << result.output;

    const std::vector<DxfEntity> entities = read_dxf_entities(dxf);
    const std::vector<cv::Vec2d> corners = {{-25, -18}, {25, -18}, {25, 10}, {17, 18}, {-25, 18}};
    int lines = 0, circles = 0, arcs = 0;
    for (const DxfEntity& e : entities) {
        if (e.type == "LINE") {
            ++lines;
            const double angle = std::atan2(e.values.at(21) - e.values.at(20), e.values.at(11) - e.values.at(10)) * 180 / kPi;
            double best = 180;
            for (size_t k = 0; k < corners.size(); ++k) {
                const cv::Vec2d side = corners[(k + 1) % corners.size()] - corners[k];
                const double d = std::fmod(std::abs(angle - std::atan2(side[1], side[0]) * 180 / kPi), 180.0);
                best = std::min(best, std::min(d, 180 - d));
            }
            std::printf("DXF line at %.4f deg: %.4f deg off its side\n", angle, best);
            EXPECT_LT(best, 0.05);
        } else if (e.type == "CIRCLE") {
            ++circles;
            std::printf("DXF circle: radius %.4f mm (%+.1f um), centre (%.4f, %.4f)\n", e.values.at(40),
                        1000 * (e.values.at(40) - 5), e.values.at(10), e.values.at(20));
            EXPECT_NEAR(e.values.at(40), 5.0, 0.02);
            EXPECT_NEAR(e.values.at(10), -11.0, 0.02);
            EXPECT_NEAR(e.values.at(20), 0.0, 0.02);
        } else if (e.type == "ARC") {
            ++arcs;
        }
    }
    EXPECT_EQ(lines, 5);
    EXPECT_EQ(circles, 1);
    EXPECT_EQ(arcs, 0);

    // The drawing is the core's fit of the same cut, number for number.
    const MeshSection section = cut_mesh_section(read_mesh(part), {0, 0, 12}, {1, 0, 0}, {0, 1, 0});
    const SectionFits fits = fit_section_polylines(section.polylines, section.parallel_cuts);
    size_t k = 0;
    for (const SectionFit& fit : fits.fits)
        for (const SectionElement& e : fit.elements) {
            ASSERT_LT(k, entities.size());
            const DxfEntity& d = entities[k++];
            if (e.kind == SectionElementKind::Line) {
                EXPECT_EQ(d.type, "LINE");
                EXPECT_NEAR(d.values.at(10), e.start[0], 1e-6);
                EXPECT_NEAR(d.values.at(20), e.start[1], 1e-6);
                EXPECT_NEAR(d.values.at(11), e.end[0], 1e-6);
                EXPECT_NEAR(d.values.at(21), e.end[1], 1e-6);
                EXPECT_NE(result.output.find(std::to_string(e.band_cuts) + " band cuts"), std::string::npos);
            } else {
                EXPECT_NEAR(d.values.at(40), e.radius_mm, 1e-6);
                EXPECT_NEAR(d.values.at(10), e.centre[0], 1e-6);
            }
        }
    EXPECT_EQ(k, entities.size());

    // The SVG: one path per line, a circle for the hole, in millimetres, y negated.
    const std::string drawing = read_file_bytes(svg);
    EXPECT_EQ(count_of(drawing, "<path class=\"line\""), 5u);
    EXPECT_EQ(count_of(drawing, "<circle "), 1u);
    EXPECT_EQ(count_of(drawing, "<path class=\"arc\""), 0u);
    // 50 x 36 mm and a margin of 2 mm around it.
    const size_t width_at = drawing.find("width=\""), height_at = drawing.find("height=\"");
    ASSERT_NE(width_at, std::string::npos);
    ASSERT_NE(height_at, std::string::npos);
    EXPECT_NEAR(std::stod(drawing.substr(width_at + 7)), 54.0, 0.05);
    EXPECT_NEAR(std::stod(drawing.substr(height_at + 8)), 40.0, 0.05);
    EXPECT_NE(drawing.find("mm\" viewBox="), std::string::npos);
    EXPECT_NE(drawing.find("cx=\"-11.0"), std::string::npos);
}

TEST(SectionCli, APlaneThatMissesThePartOrBadInputIsOneLineAndNothingIsWritten) {
    const fs::path dir = make_temp_dir("section_cli_bad");
    const std::string part = noisy_demo_part(dir, 0.0);
    const std::string svg = (dir / "outline.svg").string(), dxf = (dir / "outline.dxf").string();
    std::ofstream(svg) << "an older drawing";
    const auto refused = [&](const std::string& arguments, const std::string& message) {
        const Result result = run_picoscan("section " + arguments);
        EXPECT_EQ(result.exit_code, 1) << arguments;
        EXPECT_NE(result.output.find(message), std::string::npos) << arguments << "\n" << result.output;
        EXPECT_EQ(count_of(result.output, "\n"), 1u) << result.output;
    };
    // Built to fool it: the block is 32 mm high with its boss, so the plane at 40 mm cuts nothing.
    refused(part + " --axis z --at 40 --svg " + svg + " --dxf " + dxf,
            "--at: the plane through (0.0000, 0.0000, 40.0000) with normal (0.0000, 0.0000, 1.0000) does not cut the mesh: "
            "the mesh lies from -40.00 mm to -8.00 mm from it along its normal");
    refused(part + " --normal 0,0,1 --point 0,0,-3 --dxf " + dxf, "--point: the plane through");
    refused((dir / "nothing.stl").string() + " --axis z --at 12", "nothing.stl: no such file");
    refused(part + " --axis z --at 12 --tolerance 0", "--tolerance: must be a positive distance");
    refused(part + " --axis z --at 12 --band -1", "--band: must be 0 (one cut) or a positive distance");
    refused(part + " --axis w --at 12", "--axis: must be x, y or z");
    refused(part + " --axis z --tolerence 0.1", "--tolerence");  // a typo, refused before the mesh is read
    refused(part, "--axis: give the plane");
    refused(part + " --axis z --svg " + (dir / "outline.txt").string(), "outline.txt");
    PointCloud cloud;
    cloud.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    write_ply(cloud, (dir / "cloud.ply").string());
    refused((dir / "cloud.ply").string() + " --axis z", "holds no triangles");
    EXPECT_EQ(read_file_bytes(svg), "an older drawing");
    EXPECT_FALSE(fs::exists(dxf));
    for (const fs::directory_entry& entry : fs::directory_iterator(dir))  // no temporary file left behind
        EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();

    const Result help = run_picoscan("section --help");
    EXPECT_EQ(help.exit_code, 0);
    EXPECT_NE(help.output.find("picoscan section demo/part.stl --axis z --at 12"), std::string::npos);
}

// A plane across a sphere: one circle of the radius at that height. 0.5 mm above the equator
// the Band's cuts below it nearly match it, but they trend with their height (the sphere
// narrows), so the circle keeps to its own cut and says why; at 2 mm no cut follows it.
// A flattened mesh (here the exact part: its cut has no noise) takes its default tolerance from
// the scan it was made from (--scan: points over the part's surface, 20 um of noise), not from its
// cut; bad --scan input is one line naming it.
TEST(SectionCli, TheScanBehindAFlattenedMeshSetsTheTolerance) {
    const fs::path dir = make_temp_dir("section_cli_scan");
    const std::string part = noisy_demo_part(dir, 0.0);
    const Mesh mesh = read_mesh(part);
    PointCloud scan;  // about 10 points per mm2, 20 um of noise
    scan.points = test_support::noisy_surface_points(mesh.vertices, mesh.faces, 10, 0.02, 5);
    const std::string cloud = (dir / "scan.ply").string();
    write_ply(scan, cloud);

    const Result cut_only = run_picoscan("section " + part + " --axis z --at 12");
    ASSERT_EQ(cut_only.exit_code, 0) << cut_only.output;
    EXPECT_NE(cut_only.output.find("tolerance 0.0050 mm: from the cut of the mesh"), std::string::npos) << cut_only.output;
    const Result with_scan = run_picoscan("section " + part + " --axis z --at 12 --scan " + cloud);
    ASSERT_EQ(with_scan.exit_code, 0) << with_scan.output;
    const std::string from_scan = "mm: 5 x the noise of the scan the mesh was made from, ";
    const size_t at = with_scan.output.find(from_scan);
    ASSERT_NE(at, std::string::npos) << with_scan.output;
    const double scan_noise = std::stod(with_scan.output.substr(at + from_scan.size()));
    const size_t tolerance_at = with_scan.output.rfind("tolerance ", at);
    const double tolerance = std::stod(with_scan.output.substr(tolerance_at + std::string("tolerance ").size()));
    std::printf("scan noise %.4f mm (20 um put in), tolerance %.4f mm\n", scan_noise, tolerance);
    EXPECT_NEAR(scan_noise, 0.02, 0.004);
    EXPECT_NEAR(tolerance, 5 * scan_noise, 0.0002);

    const auto refused = [&](const std::string& arguments, const std::string& message) {
        const Result result = run_picoscan("section " + part + " --axis z --at 12 " + arguments);
        EXPECT_EQ(result.exit_code, 1) << arguments;
        EXPECT_NE(result.output.find(message), std::string::npos) << arguments << "\n" << result.output;
        EXPECT_EQ(count_of(result.output, "\n"), 1u) << result.output;
    };
    refused("--scan " + cloud + " --tolerance 0.1", "--scan: sets the default tolerance: give either --scan or --tolerance");
    refused("--scan " + (dir / "scan.txt").string(), "scan.txt: scan must end in .ply");
    PointCloud few;
    few.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    write_ply(few, (dir / "few.ply").string());
    refused("--scan " + (dir / "few.ply").string(), (dir / "few.ply").string() + ": ");
    // The same scan 10 mm off (another frame, or another part's scan): its noise says nothing of this mesh.
    PointCloud shifted = scan;
    for (cv::Vec3f& p : shifted.points) p[0] += 10;
    write_ply(shifted, (dir / "shifted.ply").string());
    refused("--scan " + (dir / "shifted.ply").string(),
            (dir / "shifted.ply").string() + ": is not the scan this mesh was made from: ");
}

TEST(SectionCli, APlaneThroughASphereGivesItsCircleAtThatHeight) {
    const fs::path dir = make_temp_dir("section_cli_sphere");
    const std::string sphere = sphere_wall(dir);
    const std::string dxf = (dir / "circle.dxf").string();
    for (const double z : {0.5, 2.0}) {
        const Result result = run_picoscan("section " + sphere + " --axis z --at " + std::to_string(z) + " --dxf " + dxf);
        ASSERT_EQ(result.exit_code, 0) << result.output;
        std::printf("%s", result.output.c_str());
        const std::vector<DxfEntity> entities = read_dxf_entities(dxf);
        ASSERT_EQ(entities.size(), 1u);
        EXPECT_EQ(entities[0].type, "CIRCLE");
        const double truth = std::sqrt(100.0 - z * z);
        std::printf("sphere cut at z = %.1f mm: radius %.4f mm (%+.1f um)\n", z, entities[0].values.at(40),
                    1000 * (entities[0].values.at(40) - truth));
        EXPECT_NEAR(entities[0].values.at(40), truth, 0.02);
        EXPECT_NEAR(entities[0].values.at(10), 0.0, 0.02);
        EXPECT_NEAR(entities[0].values.at(20), 0.0, 0.02);
        EXPECT_NE(result.output.find(z < 1 ? "not prismatic" : "one cut"), std::string::npos) << result.output;
    }
}
