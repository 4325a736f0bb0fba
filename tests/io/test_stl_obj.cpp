// STL round trips and encoding detection, OBJ output.
#include "io_test_util.h"
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <sstream>

namespace picoscan {
namespace {

using iotest::read_bytes;
using iotest::write_bytes;

// Faces of a read mesh compared by position, since STL reading renumbers vertices.
void expect_same_geometry(const Mesh& expected, const Mesh& actual, double tolerance) {
    ASSERT_EQ(expected.faces.size(), actual.faces.size());
    for (size_t f = 0; f < expected.faces.size(); ++f)
        for (int k = 0; k < 3; ++k) {
            const cv::Vec3f e = expected.vertices[expected.faces[f][k]];
            const cv::Vec3f a = actual.vertices[actual.faces[f][k]];
            if (tolerance == 0) iotest::expect_exact(e, a);
            else iotest::expect_close(e, a, tolerance);
        }
}

TEST(Stl, BinaryRoundTripMergesVertices) {
    const std::string dir = test_support::make_temp_dir("stl");
    const Mesh cube = iotest::cube_mesh();
    write_stl(cube, dir + "/cube.stl", Encoding::Binary);
    const std::string bytes = read_bytes(dir + "/cube.stl");
    ASSERT_EQ(bytes.size(), 84u + 50u * 12u);
    EXPECT_NE(bytes.compare(0, 5, "solid"), 0);  // so naive readers do not take it for ASCII

    // The stored facet normal is the winding normal of the triangle.
    float stored[3];
    std::memcpy(stored, bytes.data() + 84, 12);
    const cv::Vec3f a = cube.vertices[cube.faces[0][0]], b = cube.vertices[cube.faces[0][1]],
                    c = cube.vertices[cube.faces[0][2]];
    const cv::Vec3f expected = cv::normalize((b - a).cross(c - a));
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(stored[k], expected[k], 1e-6);
    EXPECT_NEAR(stored[2], -1.0f, 1e-6);  // the first face is the -z side

    const Mesh mesh = read_stl(dir + "/cube.stl");
    EXPECT_EQ(mesh.vertices.size(), 8u);
    EXPECT_TRUE(mesh.normals.empty());
    EXPECT_TRUE(mesh.colours.empty());
    expect_same_geometry(cube, mesh, 0);
}

TEST(Stl, AsciiRoundTrip) {
    const std::string dir = test_support::make_temp_dir("stl");
    const Mesh cube = iotest::cube_mesh();
    write_stl(cube, dir + "/cube_ascii.stl", Encoding::Ascii);
    const std::string text = read_bytes(dir + "/cube_ascii.stl");
    EXPECT_EQ(text.compare(0, 5, "solid"), 0);
    EXPECT_NE(text.find("facet normal 0 0 -1"), std::string::npos);
    const Mesh mesh = read_stl(dir + "/cube_ascii.stl");
    EXPECT_EQ(mesh.vertices.size(), 8u);
    expect_same_geometry(cube, mesh, 1e-5);
}

std::string binary_stl(const std::string& header80, const std::vector<std::array<float, 9>>& triangles) {
    std::string bytes = header80;
    bytes.resize(80, '\0');
    const uint32_t count = static_cast<uint32_t>(triangles.size());
    bytes.append(reinterpret_cast<const char*>(&count), 4);
    for (const auto& t : triangles) {
        const float normal[3] = {0, 0, 0};
        bytes.append(reinterpret_cast<const char*>(normal), 12);
        bytes.append(reinterpret_cast<const char*>(t.data()), 36);
        bytes.append(2, '\0');
    }
    return bytes;
}

TEST(Stl, BinaryStartingWithSolidIsDetectedBySize) {
    const std::string dir = test_support::make_temp_dir("stl");
    // Many exporters write "solid" into the binary header.
    const std::string bytes = binary_stl("solid exported by some CAD tool",
                                         {{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}});
    write_bytes(dir + "/solid_binary.stl", bytes);
    const Mesh mesh = read_stl(dir + "/solid_binary.stl");
    EXPECT_EQ(mesh.faces.size(), 2u);
    EXPECT_EQ(mesh.vertices.size(), 4u);
    EXPECT_EQ(mesh.faces[1], cv::Vec3i(1, 3, 2));
}

TEST(Stl, NegativeZeroMergesWithZero) {
    const std::string dir = test_support::make_temp_dir("stl");
    write_bytes(dir + "/zeros.stl", binary_stl("zeros", {{0, 0, 0, 1, 0, 0, 0, 1, 0}, {-0.0f, -0.0f, 0, 0, 1, 0, 1, 0, 0}}));
    const Mesh mesh = read_stl(dir + "/zeros.stl");
    EXPECT_EQ(mesh.vertices.size(), 3u);
}

TEST(Stl, BinaryWithTrailingPaddingStillReads) {
    const std::string dir = test_support::make_temp_dir("stl");
    write_bytes(dir + "/padded.stl", binary_stl("padded", {{0, 0, 0, 1, 0, 0, 0, 1, 0}}) + std::string(7, '\0'));
    EXPECT_EQ(read_stl(dir + "/padded.stl").faces.size(), 1u);
}

TEST(Stl, AsciiVariantsRead) {
    const std::string dir = test_support::make_temp_dir("stl");
    const std::string text =
        "  SOLID part one\r\n"
        "FACET NORMAL 0 0 1\r\n OUTER LOOP\r\n VERTEX 0 0 0\r\n VERTEX 1 0 0\r\n VERTEX 0 1 0\r\n ENDLOOP\r\nENDFACET\r\n"
        "ENDSOLID part one\r\n"
        "solid two\n"
        "facet normal 0 0 0\nouter loop\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nvertex 0.5 2 0\nendloop\nendfacet\n"
        "endsolid\n";
    write_bytes(dir + "/variants.stl", text);
    const Mesh mesh = read_stl(dir + "/variants.stl");
    EXPECT_EQ(mesh.faces.size(), 3u);  // the quad-like facet becomes a fan of two
    EXPECT_EQ(mesh.vertices.size(), 5u);
}

TEST(Stl, EmptyMeshRoundTrips) {
    const std::string dir = test_support::make_temp_dir("stl");
    for (Encoding encoding : {Encoding::Binary, Encoding::Ascii}) {
        write_stl(Mesh{}, dir + "/empty.stl", encoding);
        const Mesh mesh = read_stl(dir + "/empty.stl");
        EXPECT_TRUE(mesh.faces.empty());
        EXPECT_TRUE(mesh.vertices.empty());
    }
}

TEST(Obj, WritesVerticesColoursNormalsAndOneBasedFaces) {
    const std::string dir = test_support::make_temp_dir("obj");
    const Mesh cube = iotest::cube_mesh();
    write_obj(cube, dir + "/cube.obj");
    std::istringstream lines(read_bytes(dir + "/cube.obj"));
    std::string line;
    std::vector<cv::Vec3f> positions, colours, normals;
    std::vector<cv::Vec3i> faces;
    while (std::getline(lines, line)) {
        std::istringstream words(line);
        std::string tag;
        words >> tag;
        if (tag == "v") {
            cv::Vec3f p, c;
            words >> p[0] >> p[1] >> p[2] >> c[0] >> c[1] >> c[2];
            ASSERT_FALSE(words.fail()) << line;
            positions.push_back(p);
            colours.push_back(c);
        } else if (tag == "vn") {
            cv::Vec3f n;
            words >> n[0] >> n[1] >> n[2];
            normals.push_back(n);
        } else if (tag == "f") {
            cv::Vec3i face;
            for (int k = 0; k < 3; ++k) {
                std::string corner;
                words >> corner;
                const size_t slash = corner.find("//");
                ASSERT_NE(slash, std::string::npos) << line;
                EXPECT_EQ(corner.substr(0, slash), corner.substr(slash + 2));
                face[k] = std::stoi(corner.substr(0, slash));
            }
            faces.push_back(face);
        }
    }
    ASSERT_EQ(positions.size(), cube.vertices.size());
    ASSERT_EQ(normals.size(), cube.normals.size());
    ASSERT_EQ(faces.size(), cube.faces.size());
    for (size_t i = 0; i < positions.size(); ++i) {
        iotest::expect_close(cube.vertices[i], positions[i], 1e-5);
        iotest::expect_close(cube.normals[i], normals[i], 1e-5);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(colours[i][k], cube.colours[i][k] / 255.0f, 1e-6);
    }
    for (size_t f = 0; f < faces.size(); ++f) EXPECT_EQ(faces[f], cube.faces[f] + cv::Vec3i(1, 1, 1));
}

TEST(Obj, PlainMeshHasNoColoursOrNormals) {
    const std::string dir = test_support::make_temp_dir("obj");
    Mesh mesh;
    mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    mesh.faces.push_back(cv::Vec3i(0, 1, 2));
    write_obj(mesh, dir + "/tri.obj");
    const std::string text = read_bytes(dir + "/tri.obj");
    EXPECT_NE(text.find("\nv 1 0 0\n"), std::string::npos) << text;
    EXPECT_EQ(text.find("vn"), std::string::npos);
    EXPECT_NE(text.find("\nf 1 2 3\n"), std::string::npos) << text;
}

// A side x side grid of squares, two triangles each: enough records for several progress reports.
Mesh grid_mesh(int side) {
    Mesh mesh;
    for (int y = 0; y <= side; ++y)
        for (int x = 0; x <= side; ++x) mesh.vertices.emplace_back(0.5f * x, 0.5f * y, 0.01f * ((x * y) % 7));
    const int row = side + 1;
    for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x) {
            const int a = y * row + x;
            mesh.faces.emplace_back(a, a + 1, a + row + 1);
            mesh.faces.emplace_back(a, a + row + 1, a + row);
        }
    return mesh;
}

// The readers report every 65 536 records (PLY: vertices and faces; STL: triangles) and at the
// last, and stop at the first report answered false: a caller's Cancel is heard within 65 536 records.
TEST(MeshReading, ReportsProgressAndStopsWhenCancelled) {
    const std::string dir = test_support::make_temp_dir("read_progress");
    const Mesh grid = grid_mesh(200);  // 40 401 vertices, 80 000 triangles
    for (const std::string name : {"grid.stl", "grid.ply", "grid_ascii.stl"}) {
        SCOPED_TRACE(name);
        write_mesh(grid, dir + "/" + name, name == "grid_ascii.stl" ? Encoding::Ascii : Encoding::Binary);
        std::vector<double> fractions;
        std::vector<std::string> stages;
        const Mesh mesh = read_mesh(dir + "/" + name, [&](double fraction, const std::string& stage) {
            fractions.push_back(fraction);
            stages.push_back(stage);
            return true;
        });
        EXPECT_EQ(mesh.faces.size(), 80000u);
        EXPECT_EQ(mesh.vertices.size(), 40401u);
        if (name == "grid_ascii.stl") {  // the share is estimated from the text's length
            ASSERT_GE(fractions.size(), 1u);
            EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
            EXPECT_LE(fractions.back(), 1.0);
        } else {  // binary STL: 80 000 triangles; PLY: 40 401 vertices, then 80 000 faces
            const double records = name == "grid.stl" ? 80000.0 : 120401.0;
            EXPECT_EQ(fractions, (std::vector<double>{65536.0 / records, 1.0}));
        }
        EXPECT_EQ(stages, std::vector<std::string>(fractions.size(), "reading the mesh"));

        int reports = 0;
        try {
            // Cancel at the first report.
            read_mesh(dir + "/" + name, [&](double, const std::string&) { return ++reports > 1; });
            FAIL() << "cancelling did not stop the reading";
        } catch (const Error& error) {
            EXPECT_EQ(error.subject(), "cancelled") << error.what();
            EXPECT_NE(std::string(error.what()).find(name), std::string::npos) << error.what();
        }
        EXPECT_EQ(reports, 1);
    }
}

}  // namespace
}  // namespace picoscan
