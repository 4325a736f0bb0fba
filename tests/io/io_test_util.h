// Small helpers for the io tests: raw files, sample meshes, tolerant comparisons.
#pragma once

#include "picoscan/cloud.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

namespace picoscan::iotest {

inline void write_bytes(const std::string& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    ASSERT_TRUE(out.good()) << path;
}

inline std::string read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A unit cube: 8 shared vertices, 12 outward counter-clockwise triangles, with normals
// and colours per vertex.
inline Mesh cube_mesh() {
    Mesh mesh;
    for (int i = 0; i < 8; ++i) {
        const float x = (i & 1) ? 1.5f : -0.25f, y = (i & 2) ? 2.125f : 0.1f, z = (i & 4) ? 3.3f : -1e-3f;
        mesh.vertices.emplace_back(x, y, z);
        const cv::Vec3f n = cv::normalize(cv::Vec3f(x - 0.625f, y - 1.1125f, z - 1.6485f));
        mesh.normals.push_back(n);
        mesh.colours.emplace_back(static_cast<uchar>(i * 30), static_cast<uchar>(255 - i * 7), static_cast<uchar>(i));
    }
    // Faces (outward CCW): -z, +z, -y, +y, -x, +x.
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
        mesh.faces.emplace_back(q[0], q[1], q[2]);
        mesh.faces.emplace_back(q[0], q[2], q[3]);
    }
    return mesh;
}

inline void expect_close(const cv::Vec3f& expected, const cv::Vec3f& actual, double relative) {
    for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(expected[k], actual[k], relative * std::max(1.0, std::abs(double(expected[k]))))
            << "component " << k;
}

inline void expect_exact(const cv::Vec3f& expected, const cv::Vec3f& actual) {
    for (int k = 0; k < 3; ++k) EXPECT_EQ(expected[k], actual[k]) << "component " << k;
}

}  // namespace picoscan::iotest
