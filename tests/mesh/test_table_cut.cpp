// The table cut (detail::clip_at_plane, what --fill table runs after Poisson): closed pieces
// the cut leaves smaller than smallest_piece_mm2 are dropped, larger ones kept.
#include "../../core/src/mesh/cgal_types.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <vector>

using namespace picoscan;

namespace {

// Adds the closed box [lo, hi] to `mesh`, its faces counter-clockwise seen from outside.
void add_box(Mesh& mesh, const cv::Vec3f& lo, const cv::Vec3f& hi) {
    const int first = static_cast<int>(mesh.vertices.size());
    for (int corner = 0; corner < 8; ++corner) {
        // 0..3 the bottom (z = lo) anticlockwise from lo seen from above, 4..7 the top above them.
        const bool x_hi = corner % 4 == 1 || corner % 4 == 2, y_hi = corner % 4 >= 2, z_hi = corner >= 4;
        mesh.vertices.emplace_back(x_hi ? hi[0] : lo[0], y_hi ? hi[1] : lo[1], z_hi ? hi[2] : lo[2]);
    }
    const int faces[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                              {3, 7, 6}, {3, 6, 2}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
    for (const auto& face : faces) mesh.faces.emplace_back(first + face[0], first + face[1], first + face[2]);
}

double triangle_area(const Mesh& mesh, const cv::Vec3i& face) {
    const cv::Vec3d a(mesh.vertices[face[0]]), b(mesh.vertices[face[1]]), c(mesh.vertices[face[2]]);
    return 0.5 * cv::norm((b - a).cross(c - a));
}

// The area of each piece of faces joined by shared vertices, smallest first.
std::vector<double> piece_areas(const Mesh& mesh) {
    std::vector<int> parent(mesh.vertices.size());
    std::iota(parent.begin(), parent.end(), 0);
    auto root = [&](int v) {
        while (parent[v] != v) v = parent[v] = parent[parent[v]];
        return v;
    };
    for (const cv::Vec3i& face : mesh.faces) {
        parent[root(face[1])] = root(face[0]);
        parent[root(face[2])] = root(face[0]);
    }
    std::vector<double> area_of_root(mesh.vertices.size(), 0.0);
    for (const cv::Vec3i& face : mesh.faces) area_of_root[root(face[0])] += triangle_area(mesh, face);
    std::vector<double> areas;
    for (size_t v = 0; v < parent.size(); ++v)
        if (root(static_cast<int>(v)) == static_cast<int>(v) && area_of_root[v] > 0) areas.push_back(area_of_root[v]);
    std::sort(areas.begin(), areas.end());
    return areas;
}

// The part: a 20 x 20 mm block standing 1 mm into the table (z = 0); after the cut, 20 x 20 x 10 mm.
Mesh part_through_the_table() {
    Mesh mesh;
    add_box(mesh, {0, 0, -1}, {20, 20, 10});
    return mesh;
}

const cv::Vec3d kUp(0, 0, 1);
constexpr double kSpacing = 1.0;  // as mesh_cloud.cpp calls it: caps at 3 spacings, crumbs below spacing^2
constexpr double kPartArea = 2 * 20 * 20 + 4 * 20 * 10;

}  // namespace

TEST(MeshTableCut, CrumbTheCutLeavesIsDroppedAndASmallPartAboveTheThresholdIsKept) {
    // A crumb: 0.2 x 0.2 mm, 0.1 mm each side of the table. Cut and capped it is a closed
    // 0.2 x 0.2 x 0.1 mm box of 0.16 mm^2, under spacing^2 = 1 mm^2.
    Mesh with_crumb = part_through_the_table();
    add_box(with_crumb, {30, 0, -0.1f}, {30.2f, 0.2f, 0.1f});
    const Mesh cut = detail::clip_at_plane(with_crumb, kUp, 0, 3 * kSpacing, kSpacing * kSpacing);
    const std::vector<double> areas = piece_areas(cut);
    ASSERT_EQ(areas.size(), 1u);
    EXPECT_NEAR(areas[0], kPartArea, 1e-3 * kPartArea);
    for (const cv::Vec3f& v : cut.vertices) {
        EXPECT_LE(v[0], 20.001f);  // nothing of the crumb at x = 30
        EXPECT_GE(v[2], -1e-4f);   // nothing below the table
    }

    // A small real piece: 0.6 x 0.6 mm, from 0.1 mm below the table to 0.5 mm above. Cut and
    // capped, 0.6 x 0.6 x 0.5 mm: 0.72 + 1.2 = 1.92 mm^2, over the threshold: kept beside the part.
    Mesh with_small_part = with_crumb;
    add_box(with_small_part, {40, 0, -0.1f}, {40.6f, 0.6f, 0.5f});
    const std::vector<double> both = piece_areas(detail::clip_at_plane(with_small_part, kUp, 0, 3 * kSpacing, kSpacing * kSpacing));
    ASSERT_EQ(both.size(), 2u);
    EXPECT_NEAR(both[0], 1.92, 0.01);
    EXPECT_NEAR(both[1], kPartArea, 1e-3 * kPartArea);
}
