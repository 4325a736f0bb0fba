// Readers against broken and hostile files: every problem is an Error naming the file,
// never a crash, a hang or a huge allocation.
#include "io_test_util.h"
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <random>

namespace picoscan {
namespace {

using iotest::read_bytes;
using iotest::write_bytes;

// read_ply, read_stl or read_mesh (called without progress).
using MeshReader = Mesh (*)(const std::string&, const ProgressCallback&);

// Expects `read` to throw picoscan::Error whose message names the file and contains `words`.
void expect_error(MeshReader read, const std::string& path,
                  const std::string& words = "") {
    try {
        read(path, {});
        ADD_FAILURE() << "no error for " << path;
    } catch (const Error& error) {
        const std::string what = error.what();
        EXPECT_NE(what.find(path), std::string::npos) << what;
        EXPECT_EQ(error.subject(), path);
        EXPECT_NE(what.find(words), std::string::npos) << "expected '" << words << "' in: " << what;
        EXPECT_EQ(what.find('\n'), std::string::npos) << "message should be one line: " << what;
    }
}

const std::string kAsciiHeader = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                                 "property float y\nproperty float z\n";

struct Case {
    const char* name;
    std::string bytes;
    const char* words;
};

TEST(HostilePly, BrokenFilesThrowErrorNamingTheFile) {
    const std::string dir = test_support::make_temp_dir("hostile");
    std::string binary_header =
        "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    std::string two_vertices(24, '\0');
    auto face = [](uint8_t count, std::vector<int32_t> indices) {
        std::string bytes(1, static_cast<char>(count));
        for (int32_t i : indices) bytes.append(reinterpret_cast<const char*>(&i), 4);
        return bytes;
    };
    const std::vector<Case> cases = {
        {"empty.ply", "", "not a PLY file"},
        {"garbage.ply", std::string("\x00\xff\x13garbage\n\n", 12), "not a PLY file"},
        {"no_end.ply", "ply\nformat ascii 1.0\nelement vertex 1\n", "end_header missing"},
        {"no_format.ply", "ply\nelement vertex 0\nend_header\n", "format line missing"},
        {"bad_format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown format"},
        {"no_count.ply", "ply\nformat ascii 1.0\nelement vertex\nend_header\n", "element vertex count missing"},
        {"bad_count.ply", "ply\nformat ascii 1.0\nelement vertex -5\nend_header\n", "bad count"},
        {"overflow_count.ply", "ply\nformat ascii 1.0\nelement vertex 99999999999999999999999\nend_header\n", "bad count"},
        {"bad_type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n", "unknown property type"},
        {"float_count.ply", "ply\nformat ascii 1.0\nelement face 1\nproperty list float int v\nend_header\n", "list count type"},
        {"orphan_property.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n", "property before any element"},
        {"no_vertex.ply", "ply\nformat ascii 1.0\nend_header\n", "element vertex missing"},
        {"no_xyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n", "lacks x, y or z"},
        {"ascii_short.ply", kAsciiHeader + "end_header\n1 2 3\n4 5 6\n7 8\n", "file ends early"},
        {"ascii_word.ply", kAsciiHeader + "end_header\n1 2 3\n4 five 6\n7 8 9\n", "bad number 'five'"},
        {"huge_count.ply",
         "ply\nformat binary_little_endian 1.0\nelement vertex 100000000\nproperty float x\n"
         "property float y\nproperty float z\nend_header\n" + two_vertices, "file is too short"},
        {"too_many_vertices.ply",
         "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty uchar x\n"
         "property uchar y\nproperty uchar z\nend_header\n", "too many vertices"},
        {"truncated.ply", binary_header + two_vertices.substr(0, 20), "too short"},
        {"truncated_face.ply", binary_header + two_vertices + face(3, {0, 1}), "list count beyond the end"},
        {"index_out_of_range.ply", binary_header + two_vertices + face(3, {0, 1, 2}), "vertex index 2"},
        {"negative_index.ply", binary_header + two_vertices + face(3, {0, -1, 1}), "vertex index -1"},
        {"lying_list.ply",
         "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
         "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n\xff\xff\xff\x7f",
         "list count beyond the end"},
        {"fractional_index.ply",
         kAsciiHeader + "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 1 1\n2 2 2\n3 0 1.5 2\n",
         "vertex index 1.5"},
        {"negative_count.ply",
         kAsciiHeader + "element face 1\nproperty list char int vertex_indices\nend_header\n0 0 0\n1 1 1\n2 2 2\n-3 0 1 2\n",
         "bad list count"},
        {"unknown_keyword.ply", "ply\nformat ascii 1.0\nbanana 3\nend_header\n", "unexpected line"},
        {"duplicate_element.ply",
         "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nelement vertex 0\nend_header\n", "declared twice"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        const std::string path = dir + "/" + c.name;
        write_bytes(path, c.bytes);
        expect_error(read_ply, path, c.words);
    }
}

TEST(HostilePly, ZeroSizedElementWithHugeCountIsSkippedQuickly) {
    const std::string dir = test_support::make_temp_dir("hostile");
    // An element without properties takes no bytes: its count must not drive a loop.
    write_bytes(dir + "/ghost.ply",
                "ply\nformat binary_little_endian 1.0\nelement ghost 18446744073709551615\n"
                "element vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n");
    EXPECT_TRUE(read_ply(dir + "/ghost.ply").vertices.empty());
}

// A view's point 1e15 mm away overflowed the registration's integer cell keys (UBSan, stitch):
// the reader refuses points beyond 1 km and keeps those within.
TEST(HostilePly, ViewPointsBeyondAKilometreAreRefused) {
    const std::string dir = test_support::make_temp_dir("hostile");
    auto view_file = [&](const std::string& name, const std::string& second_point) {
        const std::string path = dir + "/" + name;
        write_bytes(path, "ply\nformat ascii 1.0\ncomment picoscan_grid 2 1\nelement vertex 2\nproperty float x\n"
                          "property float y\nproperty float z\nproperty int pixel\nend_header\n0 0 400 0\n" +
                              second_point + " 1\n");
        return path;
    };
    auto read_view = [](const std::string& path, const ProgressCallback&) {
        read_view_ply(path);
        return Mesh();
    };
    expect_error(read_view, view_file("far.ply", "1e15 0 400"), "vertex 1 lies beyond 1 km");
    expect_error(read_view, view_file("below.ply", "0 -2000000 400"), "vertex 1 lies beyond 1 km");
    expect_error(read_view, view_file("infinite.ply", "0 0 inf"), "vertex 1 lies beyond 1 km");
    const ScanView near = read_view_ply(view_file("near.ply", "0 -999999 400"));
    EXPECT_EQ(near.valid_count(), 2);
}

TEST(HostileStl, BrokenFilesThrowErrorNamingTheFile) {
    const std::string dir = test_support::make_temp_dir("hostile");
    std::string lying(84, '\0');
    lying[80] = '\x10';  // 16 triangles declared, none present
    lying += std::string(50, '\0');
    const std::string facet = "facet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 0 0 vertex 0 1 0 endloop endfacet\n";
    const std::vector<Case> cases = {
        {"empty.stl", "", "not an STL file"},
        {"short.stl", "abc", "not an STL file"},
        {"lying.stl", lying, "declares 16 triangles"},
        {"huge_count.stl", std::string(80, 'x') + std::string("\xff\xff\xff\xff", 4), "declares 4294967295"},
        {"bad_number.stl", "solid x\nfacet normal 0 0 1 outer loop vertex 0 zero 0", "bad number 'zero'"},
        {"truncated_ascii.stl", "solid x\n" + facet + "facet normal 0 0 1 outer loop vertex 0 0 0", "file ends early"},
        {"two_vertices.stl", "solid x\nfacet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 0 0 endloop endfacet\nendsolid\n",
         "fewer than three"},
        {"junk_keyword.stl", "solid x\n" + facet + "teapot\nendsolid x\n", "unexpected 'teapot'"},
        {"nested.stl", "solid x\nsolid y\nendsolid\n", "'solid' inside a solid"},
        {"stray_facet.stl", "solid x\nendsolid x\n" + facet, "outside a solid"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.name);
        const std::string path = dir + "/" + c.name;
        write_bytes(path, c.bytes);
        expect_error(read_stl, path, c.words);
    }
}

TEST(HostileIo, MissingFileAndDirectory) {
    const std::string dir = test_support::make_temp_dir("hostile");
    expect_error(read_ply, dir + "/missing.ply", "cannot open");
    expect_error(read_stl, dir + "/missing.stl", "cannot open");
    std::filesystem::create_directory(dir + "/folder.ply");
    expect_error(read_ply, dir + "/folder.ply", "not a regular file");
    expect_error(read_mesh, dir + "/mesh.obj", "unsupported mesh format");
}

// Random byte damage to valid files: the readers may succeed or throw Error, nothing else.
void mutate_and_read(const std::string& valid, const std::string& path,
                     MeshReader read, int rounds) {
    std::mt19937 random(1234);
    int errors = 0;
    for (int round = 0; round < rounds; ++round) {
        std::string bytes = valid;
        const int edits = 1 + static_cast<int>(random() % 6);
        for (int e = 0; e < edits && !bytes.empty(); ++e) {
            const size_t at = random() % bytes.size();
            switch (random() % 4) {
                case 0: bytes[at] = static_cast<char>(random()); break;
                case 1: bytes.erase(at, 1 + random() % 8); break;
                case 2: bytes.insert(at, 1, static_cast<char>("0123456789 \n-.e"[random() % 15])); break;
                default: bytes.resize(at); break;
            }
        }
        write_bytes(path, bytes);
        try {
            const Mesh mesh = read(path, {});
            for (const cv::Vec3i& face : mesh.faces)
                for (int k = 0; k < 3; ++k) {
                    ASSERT_GE(face[k], 0);
                    ASSERT_LT(face[k], static_cast<int>(mesh.vertices.size()));
                }
            if (!mesh.normals.empty()) {
                ASSERT_EQ(mesh.normals.size(), mesh.vertices.size());
            }
            if (!mesh.colours.empty()) {
                ASSERT_EQ(mesh.colours.size(), mesh.vertices.size());
            }
        } catch (const Error&) {
            ++errors;
        }
    }
    EXPECT_GT(errors, 0);
}

TEST(HostileIo, RandomDamageNeverEscapesAsAnythingButError) {
    const std::string dir = test_support::make_temp_dir("hostile");
    const Mesh cube = iotest::cube_mesh();
    for (Encoding encoding : {Encoding::Binary, Encoding::Ascii}) {
        write_ply(cube, dir + "/cube.ply", encoding);
        mutate_and_read(read_bytes(dir + "/cube.ply"), dir + "/damaged.ply", read_ply, 1500);
        write_stl(cube, dir + "/cube.stl", encoding);
        mutate_and_read(read_bytes(dir + "/cube.stl"), dir + "/damaged.stl", read_stl, 1500);
    }
}

}  // namespace
}  // namespace picoscan
