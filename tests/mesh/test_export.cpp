// Export and preview of meshes: 3MF read back through lib3mf (triangles, volume, units),
// white-frame colours carried to the mesh's vertices, and the contact sheet's six tiles.
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "picoscan/mesh.h"
#include "picoscan/preview.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"
#include <opencv2/calib3d.hpp>

#include <gtest/gtest.h>

#include <cstdio>
#include <cmath>
#include <limits>
#include <random>
#include <filesystem>
#include <fstream>

using namespace picoscan;

namespace {

std::string command_output(const std::string& command) {
    std::string out;
    FILE* pipe = popen(command.c_str(), "r");
    if (!pipe) return out;
    char buffer[4096];
    while (size_t n = fread(buffer, 1, sizeof buffer, pipe)) out.append(buffer, n);
    pclose(pipe);
    return out;
}

// Signed volume of the triangles (divergence theorem), whether or not the mesh is closed.
double signed_volume_mm3(const Mesh& mesh) {
    double volume = 0;
    for (const cv::Vec3i& f : mesh.faces) {
        const cv::Vec3d a(mesh.vertices[f[0]]), b(mesh.vertices[f[1]]), c(mesh.vertices[f[2]]);
        volume += a.dot(b.cross(c)) / 6.0;
    }
    return volume;
}

}  // namespace

TEST(Export, ThreeMfRoundTripKeepsTrianglesVolumeAndMillimetres) {
    const Mesh part = mechanical_part();
    const std::string folder = test_support::make_temp_dir("export-3mf");
    const std::string path = folder + "/part.3mf";
    write_3mf(part, path);
    const Mesh back = read_3mf(path);
    const double written = signed_volume_mm3(part), read = signed_volume_mm3(back);
    std::printf("3MF: %zu -> %zu triangles, volume %.3f -> %.3f mm^3\n", part.faces.size(), back.faces.size(), written, read);
    EXPECT_EQ(back.faces.size(), part.faces.size());
    EXPECT_EQ(back.vertices.size(), part.vertices.size());
    EXPECT_GT(written, 40000);
    EXPECT_NEAR(read, written, 1e-6 * written);
    EXPECT_EQ(read_mesh(path).faces.size(), part.faces.size());
    // The unit in the model part of the package (a zip): millimetres.
    const std::string model = command_output("unzip -p '" + path + "' 3D/3dmodel.model");
    EXPECT_NE(model.find("unit=\"millimeter\""), std::string::npos) << model.substr(0, 400);
    // Not a 3MF: refused with the file's name.
    std::ofstream(folder + "/bad.3mf") << "not a zip";
    try {
        read_3mf(folder + "/bad.3mf");
        FAIL() << "read a broken 3MF";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("bad.3mf"), std::string::npos) << e.what();
    }
}

// A ball whose upper half was seen red and lower half blue in the white frame.
TEST(Export, MeshVerticesTakeTheWhiteFrameColours) {
    PointCloud ball;
    for (int y = 0; y < 150; ++y)
        for (int x = 0; x < 300; ++x) {
            const double theta = CV_PI * (y + 0.5) / 150, phi = 2 * CV_PI * x / 300;
            const cv::Vec3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
            ball.points.emplace_back(cv::Vec3f(d * 20.0));
            ball.normals.emplace_back(cv::Vec3f(d));
            ball.colours.push_back(d[2] > 0 ? cv::Vec3b(220, 30, 30) : cv::Vec3b(30, 30, 220));
        }
    MeshOptions options;
    options.sample_spacing_mm = 0.8;
    const Mesh mesh = mesh_cloud(ball, options);
    ASSERT_EQ(mesh.colours.size(), mesh.vertices.size());
    size_t right = 0, judged = 0;
    for (size_t v = 0; v < mesh.vertices.size(); ++v) {
        if (std::abs(mesh.vertices[v][2]) < 2) continue;  // near the border between the colours
        ++judged;
        const bool red = mesh.colours[v][0] > 150 && mesh.colours[v][2] < 80;
        const bool blue = mesh.colours[v][2] > 150 && mesh.colours[v][0] < 80;
        right += (mesh.vertices[v][2] > 0 ? red : blue) ? 1 : 0;
    }
    std::printf("%zu of %zu vertices took the colour of their side\n", right, judged);
    EXPECT_EQ(right, judged);
    // PLY keeps the colours.
    const std::string path = test_support::make_temp_dir("export-colours") + "/ball.ply";
    write_ply(mesh, path);
    const Mesh back = read_ply(path);
    ASSERT_EQ(back.colours.size(), mesh.colours.size());
    EXPECT_EQ(back.colours[0], mesh.colours[0]);
}

// Each vertex takes the colour of the one input point nearest to it (looked up from the
// vertices' side, without a copy of the cloud): every point a colour of its own, so a vertex
// that took a point merely near it, not the nearest, shows. Checked against a search of all points.
TEST(Export, EachVertexTakesTheColourOfItsNearestPoint) {
    PointCloud ball;
    std::mt19937 random(7);
    std::normal_distribution<double> gauss(0, 1);
    std::uniform_int_distribution<int> level(0, 255);
    for (int i = 0; i < 6000; ++i) {
        cv::Vec3d d(gauss(random), gauss(random), gauss(random));
        d = cv::normalize(d);
        ball.points.emplace_back(cv::Vec3f(d * 15.0));
        ball.normals.emplace_back(cv::Vec3f(d));
        ball.colours.emplace_back(uchar(level(random)), uchar(level(random)), uchar(level(random)));
    }
    ball.points[10] = cv::Vec3f(std::nanf(""), 0, 0);  // unmeasured points take part in nothing
    MeshOptions options;
    options.sample_spacing_mm = 0;
    options.fill = MeshFill::Open;
    const Mesh mesh = mesh_cloud(ball, options);
    ASSERT_EQ(mesh.colours.size(), mesh.vertices.size());
    ASSERT_GT(mesh.vertices.size(), 1000u);
    size_t same = 0;
    for (size_t v = 0; v < mesh.vertices.size(); ++v) {
        double best = std::numeric_limits<double>::max();
        size_t nearest = 0;
        for (size_t i = 0; i < ball.points.size(); ++i) {
            if (!is_finite_point(ball.points[i])) continue;
            const cv::Vec3d d = cv::Vec3d(ball.points[i]) - cv::Vec3d(mesh.vertices[v]);
            if (d.dot(d) < best) best = d.dot(d), nearest = i;
        }
        same += mesh.colours[v] == ball.colours[nearest] ? 1 : 0;
    }
    std::printf("%zu of %zu vertices took the colour of their nearest point\n", same, mesh.vertices.size());
    EXPECT_EQ(same, mesh.vertices.size());
}

// Six labelled tiles; the filled-in bottom shows orange in the bottom tile and not from the top.
TEST(Export, ContactSheetShowsSixSidesAndTheFilledBottom) {
    Mesh part = mechanical_part();
    part.measured.assign(part.vertices.size(), 1);
    for (size_t v = 0; v < part.vertices.size(); ++v)
        if (part.vertices[v][2] < 0.5f) part.measured[v] = 0;  // the face it stands on: "filled in"
    const int tile = 200;
    // The part's up is +z.
    const cv::Mat sheet = render_contact_sheet(part, cv::Vec3d(0, 0, 1), tile);
    ASSERT_EQ(sheet.cols, 3 * tile);
    ASSERT_GT(sheet.rows, 2 * tile);
    const int label = (sheet.rows - 2 * tile) / 2;
    auto orange_share = [&](int index) {
        const cv::Rect area((index % 3) * tile, (index / 3) * (tile + label) + label, tile, tile);
        int orange = 0, part_pixels = 0;
        for (int y = area.y; y < area.y + area.height; ++y)
            for (int x = area.x; x < area.x + area.width; ++x) {
                const cv::Vec3b p = sheet.at<cv::Vec3b>(y, x);
                if (p == cv::Vec3b(250, 250, 250)) continue;  // background
                ++part_pixels;
                orange += p[2] > p[0] + 60 ? 1 : 0;
            }
        return std::make_pair(part_pixels, part_pixels ? double(orange) / part_pixels : 0.0);
    };
    for (int k = 0; k < 6; ++k) {
        const auto [pixels, orange] = orange_share(k);
        std::printf("tile %d: %d part pixels, %.1f %% orange\n", k, pixels, 100 * orange);
        EXPECT_GT(pixels, tile * tile / 10) << k;
    }
    EXPECT_LT(orange_share(0).second, 0.01);  // top
    EXPECT_GT(orange_share(1).second, 0.6);   // bottom (the hole shows measured walls)
    // The sides: only a strip near the bottom (this part's walls have vertices only at their
    // top and bottom edges, so the strip is as wide as the colour lookup's reach).
    for (int k = 2; k < 6; ++k) EXPECT_LT(orange_share(k).second, 0.35) << k;
    const std::string path = test_support::make_temp_dir("export-sheet") + "/sheet.png";
    write_contact_sheet_png(part, path, cv::Vec3d(0, 0, 1));
    EXPECT_TRUE(std::filesystem::is_regular_file(path));
}

// A machined part is shown square to its faces, not along its mass's axes (which the hole, the boss
// and the chamfer tilt by 10-20 degrees): whichever way it is turned, the contact sheet looks down
// its block's top and square onto its sides (the hint leans 17 degrees off its up).
TEST(Export, ContactSheetLooksSquareOnTheFaces) {
    const Mesh upright = mechanical_part();
    for (const cv::Vec3d& rotation : {cv::Vec3d(0, 0, 0), cv::Vec3d(0.3, -0.5, 0.2), cv::Vec3d(1.2, 0.4, -0.9)}) {
        SCOPED_TRACE("rotation " + std::to_string(rotation[0]) + " " + std::to_string(rotation[1]) + " " + std::to_string(rotation[2]));
        cv::Matx33d turn;
        cv::Rodrigues(rotation, turn);
        Mesh part = upright;
        for (cv::Vec3f& v : part.vertices) v = cv::Vec3f(turn * cv::Vec3d(v));
        const ContactSheetAxes axes = contact_sheet_axes(part, turn * cv::Vec3d(0, 0.3, 1));
        const double degrees = 180 / CV_PI;
        const double up_error = std::acos(std::min(1.0, axes.up.dot(turn * cv::Vec3d(0, 0, 1)))) * degrees;
        const cv::Vec3d front = turn.t() * axes.front;  // back in the part's frame
        const double front_error = std::min(std::acos(std::min(1.0, std::abs(front[0]))), std::acos(std::min(1.0, std::abs(front[1])))) * degrees;
        std::printf("up %.4f deg, front %.4f deg off the part's faces\n", up_error, front_error);
        EXPECT_LT(up_error, 0.01);
        EXPECT_LT(front_error, 0.01);
        EXPECT_NEAR(cv::norm(axes.up), 1, 1e-9);
        EXPECT_NEAR(axes.up.dot(axes.front), 0, 1e-9);
    }
}
