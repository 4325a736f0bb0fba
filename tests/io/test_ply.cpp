// PLY round trips (binary and ASCII), foreign layouts (big-endian, odd types and
// orders, polygons) and what the writer puts in the header.
#include "io_test_util.h"
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <cstring>
#include <limits>
#include <sstream>

namespace picoscan {
namespace {

using iotest::expect_close;
using iotest::expect_exact;
using iotest::read_bytes;
using iotest::write_bytes;

PointCloud sample_cloud() {
    PointCloud cloud;
    for (int i = 0; i < 50; ++i) {
        const float t = static_cast<float>(i);
        cloud.points.emplace_back(t * 0.37f - 3.1f, 1e-4f * t * t, 400.0f + std::sin(t) * 12.345678f);
        cloud.normals.push_back(cv::normalize(cv::Vec3f(std::cos(t), std::sin(t), -1.0f)));
        cloud.colours.emplace_back(static_cast<uchar>(i * 5), static_cast<uchar>(255 - i), static_cast<uchar>(i * 3 % 256));
        cloud.quality.push_back(t * 1.5f + 0.125f);
    }
    return cloud;
}

std::string header_of(const std::string& bytes) {
    const size_t end = bytes.find("end_header\n");
    return end == std::string::npos ? "" : bytes.substr(0, end + 11);
}

TEST(Ply, CloudBinaryRoundTripIsExact) {
    const std::string dir = test_support::make_temp_dir("ply");
    const PointCloud cloud = sample_cloud();
    const std::string path = dir + "/cloud.ply";
    write_ply(cloud, path, Encoding::Binary);

    const std::string bytes = read_bytes(path);
    const std::string header = header_of(bytes);
    EXPECT_NE(header.find("format binary_little_endian 1.0"), std::string::npos);
    EXPECT_NE(header.find("element vertex 50"), std::string::npos);
    EXPECT_NE(header.find("property float nx"), std::string::npos);
    EXPECT_NE(header.find("property uchar red"), std::string::npos);
    EXPECT_NE(header.find("property float quality"), std::string::npos);
    EXPECT_EQ(header.find("element face"), std::string::npos);
    EXPECT_EQ(bytes.size(), header.size() + 50 * (12 + 12 + 3 + 4));

    // Quality of the last vertex sits in the last four bytes.
    float last_quality = 0;
    std::memcpy(&last_quality, bytes.data() + bytes.size() - 4, 4);
    EXPECT_EQ(last_quality, cloud.quality.back());

    const Mesh mesh = read_ply(path);
    ASSERT_EQ(mesh.vertices.size(), cloud.points.size());
    ASSERT_EQ(mesh.normals.size(), cloud.points.size());
    ASSERT_EQ(mesh.colours.size(), cloud.points.size());
    EXPECT_TRUE(mesh.faces.empty());
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        expect_exact(cloud.points[i], mesh.vertices[i]);
        expect_exact(cloud.normals[i], mesh.normals[i]);
        EXPECT_EQ(cloud.colours[i], mesh.colours[i]);
    }
}

TEST(Ply, CloudAsciiRoundTripIsClose) {
    const std::string dir = test_support::make_temp_dir("ply");
    const PointCloud cloud = sample_cloud();
    const std::string path = dir + "/cloud_ascii.ply";
    write_ply(cloud, path, Encoding::Ascii);

    const std::string bytes = read_bytes(path);
    EXPECT_NE(bytes.find("format ascii 1.0"), std::string::npos);
    const Mesh mesh = read_ply(path);
    ASSERT_EQ(mesh.vertices.size(), cloud.points.size());
    ASSERT_EQ(mesh.normals.size(), cloud.points.size());
    ASSERT_EQ(mesh.colours.size(), cloud.points.size());
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        expect_close(cloud.points[i], mesh.vertices[i], 1e-5);
        expect_close(cloud.normals[i], mesh.normals[i], 1e-5);
        EXPECT_EQ(cloud.colours[i], mesh.colours[i]);
    }
    // Quality is the last value of each vertex line.
    std::istringstream lines(bytes.substr(header_of(bytes).size()));
    std::string line;
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        ASSERT_TRUE(std::getline(lines, line));
        const float quality = std::stof(line.substr(line.rfind(' ') + 1));
        EXPECT_NEAR(quality, cloud.quality[i], 1e-5 * std::abs(cloud.quality[i]));
    }
}

TEST(Ply, CloudWithoutOptionalLayers) {
    const std::string dir = test_support::make_temp_dir("ply");
    PointCloud cloud;
    cloud.points = {{1, 2, 3}, {4, 5, 6}};
    for (Encoding encoding : {Encoding::Binary, Encoding::Ascii}) {
        const std::string path = dir + "/plain.ply";
        write_ply(cloud, path, encoding);
        const std::string header = header_of(read_bytes(path));
        EXPECT_EQ(header.find("nx"), std::string::npos);
        EXPECT_EQ(header.find("red"), std::string::npos);
        EXPECT_EQ(header.find("quality"), std::string::npos);
        const Mesh mesh = read_ply(path);
        ASSERT_EQ(mesh.vertices.size(), 2u);
        EXPECT_TRUE(mesh.normals.empty());
        EXPECT_TRUE(mesh.colours.empty());
        expect_exact(cloud.points[1], mesh.vertices[1]);
    }
}

TEST(Ply, EmptyCloudRoundTrip) {
    const std::string dir = test_support::make_temp_dir("ply");
    for (Encoding encoding : {Encoding::Binary, Encoding::Ascii}) {
        write_ply(PointCloud{}, dir + "/empty.ply", encoding);
        const Mesh mesh = read_ply(dir + "/empty.ply");
        EXPECT_TRUE(mesh.vertices.empty());
        EXPECT_TRUE(mesh.faces.empty());
    }
}

TEST(Ply, MeshRoundTripBothEncodings) {
    const std::string dir = test_support::make_temp_dir("ply");
    const Mesh cube = iotest::cube_mesh();
    for (Encoding encoding : {Encoding::Binary, Encoding::Ascii}) {
        SCOPED_TRACE(encoding == Encoding::Binary ? "binary" : "ascii");
        const std::string path = dir + "/cube.ply";
        write_ply(cube, path, encoding);
        const std::string header = header_of(read_bytes(path));
        EXPECT_NE(header.find("element face 12\nproperty list uchar int vertex_indices\n"), std::string::npos);
        const Mesh mesh = read_ply(path);
        ASSERT_EQ(mesh.vertices.size(), cube.vertices.size());
        ASSERT_EQ(mesh.normals.size(), cube.normals.size());
        ASSERT_EQ(mesh.colours.size(), cube.colours.size());
        EXPECT_EQ(mesh.faces, cube.faces);
        for (size_t i = 0; i < cube.vertices.size(); ++i) {
            if (encoding == Encoding::Binary) {
                expect_exact(cube.vertices[i], mesh.vertices[i]);
                expect_exact(cube.normals[i], mesh.normals[i]);
            } else {
                expect_close(cube.vertices[i], mesh.vertices[i], 1e-5);
                expect_close(cube.normals[i], mesh.normals[i], 1e-5);
            }
            EXPECT_EQ(cube.colours[i], mesh.colours[i]);
        }
    }
}

TEST(Ply, NonFiniteValuesSurviveBothEncodings) {
    const std::string dir = test_support::make_temp_dir("ply");
    PointCloud cloud;
    const float inf = std::numeric_limits<float>::infinity();
    cloud.points = {{std::numeric_limits<float>::quiet_NaN(), inf, -inf}, {-0.0f, 1e-38f, 3.4e38f}};
    for (Encoding encoding : {Encoding::Binary, Encoding::Ascii}) {
        write_ply(cloud, dir + "/odd.ply", encoding);
        const Mesh mesh = read_ply(dir + "/odd.ply");
        ASSERT_EQ(mesh.vertices.size(), 2u);
        EXPECT_TRUE(std::isnan(mesh.vertices[0][0]));
        EXPECT_EQ(mesh.vertices[0][1], inf);
        EXPECT_EQ(mesh.vertices[0][2], -inf);
        EXPECT_EQ(mesh.vertices[1], cloud.points[1]);
    }
}

TEST(Ply, WriterRefusesInconsistentData) {
    const std::string dir = test_support::make_temp_dir("ply");
    PointCloud cloud;
    cloud.points = {{0, 0, 0}, {1, 1, 1}};
    cloud.normals = {{0, 0, 1}};
    EXPECT_THROW(write_ply(cloud, dir + "/bad.ply"), Error);
    Mesh mesh;
    mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    mesh.faces.push_back(cv::Vec3i(0, 1, 3));
    try {
        write_ply(mesh, dir + "/bad_mesh.ply");
        FAIL() << "no error for a bad face index";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("bad_mesh.ply"), std::string::npos) << error.what();
    }
    EXPECT_FALSE(std::filesystem::exists(dir + "/bad.ply"));
    EXPECT_FALSE(std::filesystem::exists(dir + "/bad_mesh.ply"));
}

// Big-endian helpers for hand-made files.
template <class T>
void append_be(std::string& out, T value) {
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    for (size_t i = 0; i < sizeof(T); ++i) out.push_back(static_cast<char>(bytes[sizeof(T) - 1 - i]));
}

TEST(Ply, ReadsBigEndianWithMixedTypesAndUnknownData) {
    const std::string dir = test_support::make_temp_dir("ply");
    std::string bytes =
        "ply\r\n"
        "format binary_big_endian 1.0\r\n"
        "comment made by hand\r\n"
        "obj_info nothing\r\n"
        "element material 2\r\n"
        "property float shininess\r\n"
        "property list uchar uint8 name\r\n"
        "element vertex 4\r\n"
        "property int16 id\r\n"
        "property float64 z\r\n"
        "property uint8 blue\r\n"
        "property float x\r\n"
        "property list ushort int tags\r\n"
        "property uchar green\r\n"
        "property int y\r\n"
        "property uchar red\r\n"
        "element face 1\r\n"
        "property uchar flags\r\n"
        "property list uint ushort vertex_indices\r\n"
        "end_header\r\n";
    // material: two records, the second with a list of three bytes.
    append_be<float>(bytes, 0.5f);
    bytes.push_back(0);
    append_be<float>(bytes, 0.75f);
    bytes.push_back(3);
    bytes += "abc";
    const double zs[4] = {400.25, -1.5, 1e-9, 12345.5};
    const float xs[4] = {1.25f, -2.5f, 0.0f, 3.0e10f};
    const int ys[4] = {-7, 0, 2147483647, -2147483647 - 1};
    for (int i = 0; i < 4; ++i) {
        append_be<int16_t>(bytes, static_cast<int16_t>(-i));
        append_be<double>(bytes, zs[i]);
        bytes.push_back(static_cast<char>(10 + i));  // blue
        append_be<float>(bytes, xs[i]);
        append_be<uint16_t>(bytes, static_cast<uint16_t>(i));  // tags list of i ints
        for (int t = 0; t < i; ++t) append_be<int32_t>(bytes, 1000 + t);
        bytes.push_back(static_cast<char>(200 + i));  // green
        append_be<int32_t>(bytes, ys[i]);
        bytes.push_back(static_cast<char>(100 + i));  // red
    }
    bytes.push_back(7);  // flags
    append_be<uint32_t>(bytes, 4);
    for (uint16_t index : {3, 2, 1, 0}) append_be<uint16_t>(bytes, index);
    write_bytes(dir + "/big.ply", bytes);

    const Mesh mesh = read_ply(dir + "/big.ply");
    ASSERT_EQ(mesh.vertices.size(), 4u);
    ASSERT_EQ(mesh.colours.size(), 4u);
    EXPECT_TRUE(mesh.normals.empty());
    for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(mesh.vertices[i][0], xs[i]);
        EXPECT_EQ(mesh.vertices[i][1], static_cast<float>(ys[i]));
        EXPECT_EQ(mesh.vertices[i][2], static_cast<float>(zs[i]));
        EXPECT_EQ(mesh.colours[i], cv::Vec3b(100 + i, 200 + i, 10 + i));
    }
    ASSERT_EQ(mesh.faces.size(), 2u);  // the quad as a fan
    EXPECT_EQ(mesh.faces[0], cv::Vec3i(3, 2, 1));
    EXPECT_EQ(mesh.faces[1], cv::Vec3i(3, 1, 0));
}

TEST(Ply, ReadsAsciiPolygonFanAndShortColourNames) {
    const std::string dir = test_support::make_temp_dir("ply");
    const std::string text =
        "ply\n"
        "format ascii 1.0\n"
        "element vertex 5\n"
        "property uchar r\n"
        "property uchar g\n"
        "property uchar b\n"
        "property double nz\n"
        "property double nx\n"
        "property double ny\n"
        "property float z\n"
        "property float y\n"
        "property float x\n"
        "element edge 2\n"
        "property int vertex1\n"
        "property int vertex2\n"
        "element face 2\n"
        "property list int int vertex_index\n"
        "end_header\n"
        "1 2 3 1 0 0 +0.5 1 0\n"
        "4 5 6 1 0 0 0.5 1 1\n"
        "7 8 9\n 1 0 0 0.5 2 1\n"  // records may span lines
        "10 11 12 1 0 0 0.5 2 0\n"
        "13 14 15 1 0 0 1.5e0 1.5 -1e-1\n"
        "0 1\n1 2\n"
        "5 0 1 2 3 4\n"
        "2 0 1\n";  // a two-vertex face makes no triangle
    write_bytes(dir + "/fan.ply", text);
    const Mesh mesh = read_ply(dir + "/fan.ply");
    ASSERT_EQ(mesh.vertices.size(), 5u);
    EXPECT_EQ(mesh.vertices[0], cv::Vec3f(0, 1, 0.5f));
    EXPECT_EQ(mesh.vertices[4], cv::Vec3f(-0.1f, 1.5f, 1.5f));
    ASSERT_EQ(mesh.normals.size(), 5u);
    EXPECT_EQ(mesh.normals[2], cv::Vec3f(0, 0, 1));
    ASSERT_EQ(mesh.colours.size(), 5u);
    EXPECT_EQ(mesh.colours[4], cv::Vec3b(13, 14, 15));
    ASSERT_EQ(mesh.faces.size(), 3u);
    EXPECT_EQ(mesh.faces[0], cv::Vec3i(0, 1, 2));
    EXPECT_EQ(mesh.faces[1], cv::Vec3i(0, 2, 3));
    EXPECT_EQ(mesh.faces[2], cv::Vec3i(0, 3, 4));
}

TEST(Ply, FloatColoursAreTakenAsUnitRange) {
    const std::string dir = test_support::make_temp_dir("ply");
    write_bytes(dir + "/fc.ply",
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                "property float z\nproperty float red\nproperty float green\nproperty float blue\n"
                "end_header\n0 0 0 1 0.5 7\n");
    const Mesh mesh = read_ply(dir + "/fc.ply");
    ASSERT_EQ(mesh.colours.size(), 1u);
    EXPECT_EQ(mesh.colours[0], cv::Vec3b(255, 128, 255));
}

TEST(Ply, HeaderMayEndWithoutNewlineWhenThereIsNoBody) {
    const std::string dir = test_support::make_temp_dir("ply");
    write_bytes(dir + "/bare.ply",
                "ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                "property float z\nend_header");
    EXPECT_TRUE(read_ply(dir + "/bare.ply").vertices.empty());
}

TEST(Ply, ReadMeshDispatchesOnExtension) {
    const std::string dir = test_support::make_temp_dir("ply");
    const Mesh cube = iotest::cube_mesh();
    write_ply(cube, dir + "/UPPER.PLY");
    write_stl(cube, dir + "/Upper.Stl");
    write_obj(cube, dir + "/cube.obj");
    EXPECT_EQ(read_mesh(dir + "/UPPER.PLY").faces.size(), 12u);
    EXPECT_EQ(read_mesh(dir + "/Upper.Stl").faces.size(), 12u);
    EXPECT_THROW(read_mesh(dir + "/cube.obj"), Error);
    EXPECT_THROW(read_mesh(dir + "/noextension"), Error);
}

}  // namespace
}  // namespace picoscan

namespace picoscan {
namespace {

// A camera-sized grid (1600x1200) with a few measured pixels: read back, every pixel is what
// was written, NaN points and zero layers where nothing was measured (the reader leaves such
// grids as fresh zero pages and writes only where points are).
TEST(Ply, ViewOnACameraSizedGridRoundTripsEveryPixel) {
    const std::string dir = test_support::make_temp_dir("ply-view");
    const int width = 1600, height = 1200;
    ScanView view;
    view.points = cv::Mat(height, width, CV_32FC3, cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
    view.normals = cv::Mat::zeros(height, width, CV_32FC3);
    view.colours = cv::Mat::zeros(height, width, CV_8UC3);
    view.quality = cv::Mat::zeros(height, width, CV_32F);
    view.camera_matrix = cv::Matx33d(2500, 0, 800, 0, 2500, 600, 0, 0, 1);
    cv::RNG rng(7);
    for (int k = 0; k < 5000; ++k) {
        const int x = rng.uniform(0, width), y = rng.uniform(0, height);
        view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(rng.uniform(-50.f, 50.f), rng.uniform(-50.f, 50.f), rng.uniform(200.f, 400.f));
        view.normals.at<cv::Vec3f>(y, x) = cv::normalize(cv::Vec3f(rng.uniform(-1.f, 1.f), rng.uniform(-1.f, 1.f), -1.f));
        view.colours.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uchar>(k), static_cast<uchar>(k / 7), 200);
        view.quality.at<float>(y, x) = rng.uniform(0.1f, 1.f);
    }
    const std::string path = dir + "/view.ply";
    write_view_ply(view, path);
    ScanView back = read_view_ply(path);
    ASSERT_EQ(back.points.size(), view.points.size());
    EXPECT_EQ(back.valid_count(), view.valid_count());
    auto same_bits = [](const cv::Mat& a, const cv::Mat& b) {
        return a.type() == b.type() && a.size() == b.size() && a.isContinuous() && b.isContinuous() &&
               std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
    };
    EXPECT_TRUE(same_bits(back.points, view.points));  // the same NaN bits where unmeasured
    EXPECT_TRUE(same_bits(back.normals, view.normals));
    EXPECT_TRUE(same_bits(back.colours, view.colours));
    EXPECT_TRUE(same_bits(back.quality, view.quality));
    // The grids behave as any other: copied, changed, released.
    cv::Mat copy = back.normals.clone();
    back.normals.setTo(cv::Scalar::all(1));
    EXPECT_TRUE(same_bits(copy, view.normals));
    back = ScanView();
    EXPECT_TRUE(same_bits(copy, view.normals));
}

}  // namespace
}  // namespace picoscan
