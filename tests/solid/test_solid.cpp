// Closed meshes -> planar B-rep faces: a noisy box grid-meshed on every side must come out as its
// six faces (each one wire of four straight edges), a curved surface must stay triangles, and
// meshes that bound no solid are refused with the reason. (The BREP is read back by OpenCASCADE
// in the freecad_headless suite.)
#include "picoscan/error.h"
#include "picoscan/solid.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <tuple>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A box of cells x cells y cells z, spacing `step` mm, its surface meshed on the lattice (two
// triangles per cell square, outward), every vertex moved by Gaussian noise.
Mesh grid_box(int nx, int ny, int nz, double step, double sigma, unsigned seed = 3) {
    Mesh mesh;
    std::map<std::tuple<int, int, int>, int> index_of;
    std::mt19937 random(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    auto vertex = [&](int i, int j, int k) {
        const auto key = std::make_tuple(i, j, k);
        const auto found = index_of.find(key);
        if (found != index_of.end()) return found->second;
        mesh.vertices.emplace_back(float(i * step + noise(random)), float(j * step + noise(random)), float(k * step + noise(random)));
        return index_of[key] = int(mesh.vertices.size()) - 1;
    };
    const int size[3] = {nx, ny, nz};
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
            const int u_axis = (axis + 1) % 3, v_axis = (axis + 2) % 3;
            for (int u = 0; u < size[u_axis]; ++u)
                for (int v = 0; v < size[v_axis]; ++v) {
                    int corner[4];
                    const int du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
                    for (int c = 0; c < 4; ++c) {
                        int p[3];
                        p[axis] = side * size[axis];
                        p[u_axis] = u + du[c];
                        p[v_axis] = v + dv[c];
                        corner[c] = vertex(p[0], p[1], p[2]);
                    }
                    // (u, v, axis) is right-handed: counter-clockwise in (u, v) faces +axis.
                    if (side == 1) {
                        mesh.faces.emplace_back(corner[0], corner[1], corner[2]);
                        mesh.faces.emplace_back(corner[0], corner[2], corner[3]);
                    } else {
                        mesh.faces.emplace_back(corner[0], corner[2], corner[1]);
                        mesh.faces.emplace_back(corner[0], corner[3], corner[2]);
                    }
                }
        }
    return mesh;
}

// A closed UV sphere.
Mesh sphere(double radius, int rings, int segments) {
    Mesh mesh;
    mesh.vertices.emplace_back(0.f, 0.f, float(radius));
    for (int r = 1; r < rings; ++r)
        for (int s = 0; s < segments; ++s) {
            const double theta = kPi * r / rings, phi = 2 * kPi * s / segments;
            mesh.vertices.emplace_back(float(radius * std::sin(theta) * std::cos(phi)),
                                       float(radius * std::sin(theta) * std::sin(phi)), float(radius * std::cos(theta)));
        }
    mesh.vertices.emplace_back(0.f, 0.f, float(-radius));
    const int bottom = int(mesh.vertices.size()) - 1;
    auto at = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
    for (int s = 0; s < segments; ++s) mesh.faces.emplace_back(0, at(1, s), at(1, s + 1));
    for (int r = 1; r + 1 < rings; ++r)
        for (int s = 0; s < segments; ++s) {
            mesh.faces.emplace_back(at(r, s), at(r + 1, s), at(r + 1, s + 1));
            mesh.faces.emplace_back(at(r, s), at(r + 1, s + 1), at(r, s + 1));
        }
    for (int s = 0; s < segments; ++s) mesh.faces.emplace_back(bottom, at(rings - 1, s + 1), at(rings - 1, s));
    return mesh;
}

}  // namespace

TEST(PlanarFaces, NoisyBoxBecomesSixFacesOfFourStraightEdges) {
    for (double sigma : {0.0, 0.01, 0.03}) {
        const Mesh box = grid_box(40, 30, 20, 1.0, sigma);
        const PlanarFaceModel model = planar_face_model(box);
        SCOPED_TRACE(model.summary());
        EXPECT_EQ(model.faces.size(), 6u);
        EXPECT_EQ(model.merged_facets, box.faces.size());
        EXPECT_EQ(model.edges.size(), 12u);
        EXPECT_NEAR(model.mesh_volume_mm3, 40 * 30 * 20, 40 * 30 * 20 * 1e-3);
        if (sigma > 0) {
            EXPECT_NEAR(model.noise_mm, sigma, 0.3 * sigma);
        }
        for (const BrepFace& face : model.faces) {
            ASSERT_EQ(face.wires.size(), 1u);
            EXPECT_EQ(face.wires[0].size(), 4u);
            EXPECT_LT(face.rms_mm, 1.5 * sigma + 1e-5);
            // Outward: the normal points away from the box's centre.
            EXPECT_GT((face.origin - cv::Vec3d(20, 15, 10)).dot(face.normal), 0);
        }
        for (double tolerance : model.vertex_tolerance_mm) EXPECT_LT(tolerance, 6 * sigma + 1e-6);
    }
}

TEST(PlanarFaces, CurvedSurfaceStaysTrianglesAndInwardFacetsTurn) {
    // A UV sphere: only the fans at its poles are flat within the (curvature-sized) noise estimate.
    Mesh ball = sphere(10, 60, 120);
    const PlanarFaceModel model = planar_face_model(ball);
    SCOPED_TRACE(model.summary());
    EXPECT_LT(model.merged_facets, ball.faces.size() / 10);
    for (const BrepFace& face : model.faces) {
        if (!face.merged) continue;
        EXPECT_GT(std::abs(face.normal[2]), 0.9);  // near the poles only
    }
    const double volume = model.mesh_volume_mm3;
    for (cv::Vec3i& face : ball.faces) std::swap(face[1], face[2]);
    const PlanarFaceModel inward = planar_face_model(ball);
    EXPECT_DOUBLE_EQ(inward.mesh_volume_mm3, volume);
    EXPECT_EQ(inward.faces.size(), model.faces.size());
    for (const BrepFace& face : inward.faces) EXPECT_GT(face.origin.dot(face.normal), 0);  // still outward
}

TEST(PlanarFaces, OneFacePerFacetWhenNotMerging) {
    const Mesh box = grid_box(6, 5, 4, 1.0, 0.0);
    PlanarFaceOptions options;
    options.merge = false;
    const PlanarFaceModel model = planar_face_model(box, options);
    EXPECT_EQ(model.faces.size(), box.faces.size());
    EXPECT_EQ(model.merged_faces, 0u);
}

TEST(PlanarFaces, WritesABrepSolid) {
    const PlanarFaceModel model = planar_face_model(grid_box(8, 6, 4, 1.0, 0.01));
    const std::string path = test_support::make_temp_dir("planar_faces") + "/box.brep";
    write_brep(model, path);
    std::ifstream stream(path);
    std::string text((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
    EXPECT_EQ(text.rfind("DBRep_DrawableShape\n", 0), 0u);
    EXPECT_NE(text.find("Surfaces 6\n"), std::string::npos);
    EXPECT_NE(text.find("Curves 12\n"), std::string::npos);
    EXPECT_NE(text.find("\nSo\n"), std::string::npos);
}

namespace {

size_t count_of(const std::string& text, const std::string& what) {
    size_t count = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++count;
    return count;
}

std::string brep_text(const PlanarFaceModel& model, const std::string& name) {
    const std::string path = test_support::make_temp_dir("planar_faces") + "/" + name + ".brep";
    write_brep(model, path);
    std::ifstream stream(path);
    return std::string((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
}

}  // namespace

// Each face carries its own facets (so FreeCAD draws them instead of meshing the face again), and
// each edge the mesh vertices along it, on both faces' triangulations.
TEST(PlanarFaces, EachFaceCarriesItsFacetsAsItsTriangulation) {
    const PlanarFaceModel box = planar_face_model(grid_box(8, 6, 4, 1.0, 0.01));
    ASSERT_EQ(box.faces.size(), 6u);
    size_t triangles = 0;
    for (const BrepFace& face : box.faces) {
        triangles += face.triangles.size();
        EXPECT_EQ(int(face.triangles.size()), face.facet_count);
        for (const cv::Vec3i& t : face.triangles) {  // counter-clockwise seen from outside
            const cv::Vec3d n = (box.vertices[t[1]] - box.vertices[t[0]]).cross(box.vertices[t[2]] - box.vertices[t[0]]);
            EXPECT_GT(n.dot(face.normal), 0);
        }
    }
    EXPECT_EQ(triangles, box.facet_count);
    size_t chain_vertices = 0;
    for (const BrepEdge& edge : box.edges) {
        ASSERT_GE(edge.chain.size(), 2u);
        EXPECT_EQ(edge.chain.front(), edge.start);
        EXPECT_EQ(edge.chain.back(), edge.end);
        chain_vertices += edge.chain.size() - 1;
    }
    // The box's 12 edges run along 4 x (8 + 6 + 4) mesh edges.
    EXPECT_EQ(chain_vertices, 4u * (8 + 6 + 4));
    const std::string text = brep_text(box, "box");
    EXPECT_NE(text.find("Triangulations 6\n"), std::string::npos);
    EXPECT_NE(text.find("PolygonOnTriangulations 24\n"), std::string::npos);  // each edge on its two faces
    EXPECT_EQ(count_of(text, "\n6  "), 24u);
    // Each face names its triangulation ("2  t" ending its line), each edge its line on each
    // face's plane ("2  pcurve surface 0 0 length").
    EXPECT_EQ(count_of(text, "\n2  "), 6u + 24u);
    EXPECT_NE(text.find("Curve2ds 24\n"), std::string::npos);

    PlanarFaceOptions unmerged;
    unmerged.merge = false;
    const Mesh ball = sphere(10, 12, 16);
    const PlanarFaceModel triangles_only = planar_face_model(ball, unmerged);
    const std::string ball_text = brep_text(triangles_only, "sphere");
    EXPECT_NE(ball_text.find("Triangulations " + std::to_string(ball.faces.size()) + "\n"), std::string::npos);
    EXPECT_NE(ball_text.find("PolygonOnTriangulations " + std::to_string(3 * ball.faces.size()) + "\n"), std::string::npos);
    EXPECT_NE(ball_text.find("Curve2ds " + std::to_string(3 * ball.faces.size()) + "\n"), std::string::npos);

    // A face's plane moved 0.1 mm off its edges (beyond their tolerance): its four edges get no line
    // on it (OpenCASCADE then projects them, as without pcurves), the others keep theirs.
    PlanarFaceModel shifted = box;
    shifted.faces[0].origin += 0.1 * cv::normalize(shifted.faces[0].normal);
    ASSERT_EQ(shifted.faces[0].wires.size(), 1u);
    ASSERT_EQ(shifted.faces[0].wires[0].size(), 4u);
    for (const auto& wire : shifted.faces[0].wires)
        for (int e : wire) ASSERT_LT(shifted.edges[size_t(std::abs(e) - 1)].tolerance_mm, 0.1);
    EXPECT_NE(brep_text(shifted, "shifted").find("Curve2ds 20\n"), std::string::npos);

    // An edge whose chain leaves the face's triangles, or does not run from its start to its end,
    // cannot be written: refused naming the file, nothing written.
    PlanarFaceModel astray = box;
    const int outside = [&] {  // a vertex none of edge 0's faces' triangles uses
        for (int v = 0; v < int(box.vertices.size()); ++v) {
            bool used = false;
            for (const BrepFace& face : box.faces) {
                bool has_edge = false;
                for (const auto& wire : face.wires)
                    for (int e : wire) has_edge = has_edge || std::abs(e) == 1;
                if (!has_edge) continue;
                for (const cv::Vec3i& t : face.triangles) used = used || t[0] == v || t[1] == v || t[2] == v;
            }
            if (!used) return v;
        }
        return -1;
    }();
    ASSERT_GE(outside, 0);
    astray.edges[0].chain = {box.edges[0].start, outside, box.edges[0].end};
    EXPECT_THROW(brep_text(astray, "astray"), Error);
    PlanarFaceModel backwards = box;
    std::reverse(backwards.edges[0].chain.begin(), backwards.edges[0].chain.end());
    EXPECT_THROW(brep_text(backwards, "backwards"), Error);
}

TEST(PlanarFaces, MeshesThatBoundNoSolidAreRefused) {
    Mesh open = grid_box(4, 4, 4, 1.0, 0.0);
    open.faces.pop_back();
    EXPECT_THROW(
        try { planar_face_model(open); } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("not closed"), std::string::npos) << error.what();
            throw;
        },
        Error);
    Mesh flipped = grid_box(4, 4, 4, 1.0, 0.0);
    std::swap(flipped.faces[5][1], flipped.faces[5][2]);
    EXPECT_THROW(
        try { planar_face_model(flipped); } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("not consistently oriented"), std::string::npos) << error.what();
            throw;
        },
        Error);
    // A facet collapsed onto two corners bounds nothing: it is left out.
    Mesh collapsed = grid_box(4, 4, 4, 1.0, 0.0);
    collapsed.faces.emplace_back(0, 0, 1);
    EXPECT_EQ(planar_face_model(collapsed).facet_count, collapsed.faces.size() - 1);
    // Two facets back to back on three points in a line: closed, but of zero area.
    Mesh line;
    line.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
    line.faces = {{0, 1, 2}, {0, 2, 1}};
    EXPECT_THROW(
        try { planar_face_model(line); } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("degenerate"), std::string::npos) << error.what();
            throw;
        },
        Error);
    EXPECT_THROW(planar_face_model(Mesh{}), Error);
    PlanarFaceOptions bad;
    bad.max_normal_deg = 95;
    EXPECT_THROW(planar_face_model(grid_box(2, 2, 2, 1.0, 0.0), bad), Error);
}

namespace {

// A prism along +y (length `length`, `rows` rows of facets) over an outline in (x, z) whose k-th
// side is cut into segments[k] pieces, its two ends closed by fans; every vertex moved by noise.
Mesh prism(const std::vector<cv::Vec2d>& outline, const std::vector<int>& segments, double length, int rows, double sigma,
           unsigned seed) {
    std::vector<cv::Vec2d> ring;
    for (size_t k = 0; k < outline.size(); ++k) {
        const cv::Vec2d a = outline[k], b = outline[(k + 1) % outline.size()];
        for (int s = 0; s < segments[k]; ++s) ring.push_back(a + (b - a) * (double(s) / segments[k]));
    }
    const int n = int(ring.size());
    Mesh mesh;
    std::mt19937 random(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    auto add = [&](double x, double y, double z) {
        mesh.vertices.emplace_back(float(x + noise(random)), float(y + noise(random)), float(z + noise(random)));
    };
    for (int j = 0; j <= rows; ++j)
        for (const cv::Vec2d& p : ring) add(p[0], length * j / rows, p[1]);
    cv::Vec2d centre(0, 0);
    for (const cv::Vec2d& p : ring) centre += p / double(n);
    const int front = int(mesh.vertices.size()), back = front + 1;
    add(centre[0], 0, centre[1]);
    add(centre[0], length, centre[1]);
    auto at = [&](int j, int i) { return j * n + (i % n); };
    // The outline runs counter-clockwise in (x, z), so (x, z, y) is left-handed: these face outwards.
    for (int j = 0; j < rows; ++j)
        for (int i = 0; i < n; ++i) {
            mesh.faces.emplace_back(at(j, i), at(j, i + 1), at(j + 1, i + 1));
            mesh.faces.emplace_back(at(j, i), at(j + 1, i + 1), at(j + 1, i));
        }
    for (int i = 0; i < n; ++i) {
        mesh.faces.emplace_back(front, at(0, i + 1), at(0, i));
        mesh.faces.emplace_back(back, at(rows, i), at(rows, i + 1));
    }
    return mesh;
}

// The 20 x 10 x 20 mm block with its (+x, +z) edge chamfered `chamfer` mm wide, one facet across.
Mesh chamfered_block(double chamfer, double sigma, unsigned seed) {
    return prism({{0, 0}, {20, 0}, {20, 10 - chamfer}, {20 - chamfer, 10}, {0, 10}}, {20, 10, 1, 20, 10}, 20.0, 20, sigma, seed);
}

// A model of one merged face on z = 0 (normal +z) bounded by `loops` (vertex indices, the outer
// counter-clockwise first), and nothing else: enough for the face check.
PlanarFaceModel one_face(const std::vector<cv::Vec3d>& vertices, const std::vector<std::vector<int>>& loops) {
    PlanarFaceModel model;
    model.vertices = vertices;
    model.vertex_tolerance_mm.assign(vertices.size(), 1e-7);
    model.noise_mm = 0.001;
    BrepFace face;
    face.origin = {0, 0, 0};
    face.normal = {0, 0, 1};
    face.merged = true;
    for (const std::vector<int>& loop : loops) {
        face.wires.emplace_back();
        for (size_t k = 0; k < loop.size(); ++k) {
            model.edges.push_back({loop[k], loop[(k + 1) % loop.size()], 1e-7});
            face.wires.back().push_back(int(model.edges.size()));
        }
    }
    model.faces.push_back(face);
    return model;
}

std::string defects_of(const PlanarFaceModel& model) {
    std::string text;
    for (const std::string& defect : merged_face_defects(model)) text += defect + "\n";
    return text;
}

}  // namespace

TEST(PlanarFaces, FaceCheckFindsBoundariesThatMakeNoValidFace) {
    // A 10 x 10 square with a 2 x 2 hole: a valid face.
    const std::vector<cv::Vec3d> square{{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {0, 10, 0}, {4, 4, 0}, {4, 6, 0}, {6, 6, 0}, {6, 4, 0}};
    EXPECT_EQ(defects_of(one_face(square, {{0, 1, 2, 3}, {4, 5, 6, 7}})), "");
    // Built to fool it, each one: the hole run counter-clockwise,
    EXPECT_NE(defects_of(one_face(square, {{0, 1, 2, 3}, {7, 6, 5, 4}})).find("hole's boundary runs"), std::string::npos);
    // the outer boundary run clockwise,
    EXPECT_NE(defects_of(one_face(square, {{3, 2, 1, 0}})).find("runs clockwise"), std::string::npos);
    // a hole outside the face,
    std::vector<cv::Vec3d> outside = square;
    for (size_t v = 4; v < 8; ++v) outside[v] += cv::Vec3d(20, 0, 0);
    EXPECT_NE(defects_of(one_face(outside, {{0, 1, 2, 3}, {4, 5, 6, 7}})).find("outside its outer"), std::string::npos);
    // a hole touching the outer boundary at one of its corners (the same vertex),
    EXPECT_NE(defects_of(one_face(square, {{0, 1, 2, 3}, {0, 5, 6, 7}})).find("touches itself"), std::string::npos);
    // two squares meeting at a corner as one boundary (a figure of eight through vertex 2),
    const std::vector<cv::Vec3d> eight{{0, 0, 0}, {5, 0, 0}, {5, 5, 0}, {0, 5, 0}, {10, 5, 0}, {10, 10, 0}, {5, 10, 0}};
    EXPECT_NE(defects_of(one_face(eight, {{0, 1, 2, 4, 5, 6, 2, 3}})).find("touches itself"), std::string::npos);
    // a boundary crossing itself (a bow tie),
    EXPECT_NE(defects_of(one_face({{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {10, 10, 0}, {-5, 5, 0}}, {{0, 1, 2, 3, 4}}))
                  .find("crosses or touches"),
              std::string::npos);
    // a corner of the boundary on another of its edges (a sliver of zero width),
    EXPECT_NE(defects_of(one_face({{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {5, 0, 0}, {0, 10, 0}}, {{0, 1, 2, 3, 4}}))
                  .find("crosses or touches"),
              std::string::npos);
    // an edge of zero length (two vertices at one place),
    std::vector<cv::Vec3d> doubled = square;
    doubled.push_back(square[2]);
    EXPECT_NE(defects_of(one_face(doubled, {{0, 1, 2, 8, 3}})).find("no length"), std::string::npos);
    // and a corner lifted off the plane by 0.1 mm (the noise is 1 um).
    std::vector<cv::Vec3d> lifted = square;
    lifted[2][2] = 0.1;
    EXPECT_NE(defects_of(one_face(lifted, {{0, 1, 2, 3}})).find("not planar"), std::string::npos);
}

TEST(PlanarFaces, SliverChamferMergedWithoutTheCheckMakesAnInvalidFaceAndWithItDoesNot) {
    // A chamfer narrower than the noise (a sharpened edge leaves such a sliver): its facets join
    // the top and the side unevenly, and the old merge made a face OpenCASCADE rejects (its
    // boundary touching itself; freecad_headless reads such a solid back). The check puts the
    // few facets there back as triangles; every plane stays one face.
    int fooled = 0;
    for (double chamfer : {0.002, 0.01})
        for (unsigned seed : {1u, 2u, 3u}) {
            const Mesh block = chamfered_block(chamfer, 0.01, seed);
            SCOPED_TRACE("chamfer " + std::to_string(chamfer) + " mm, seed " + std::to_string(seed));
            PlanarFaceOptions unchecked;
            unchecked.min_facets = 10;
            unchecked.check_faces = false;
            const PlanarFaceModel old = planar_face_model(block, unchecked);
            if (!merged_face_defects(old, unchecked).empty()) ++fooled;
            PlanarFaceOptions checked = unchecked;
            checked.check_faces = true;
            const PlanarFaceModel model = planar_face_model(block, checked);
            SCOPED_TRACE(model.summary());
            EXPECT_EQ(defects_of(model), "");
            EXPECT_EQ(model.merged_faces, old.merged_faces);
            EXPECT_GT(model.merged_facets, old.merged_facets * 95 / 100);
            if (!merged_face_defects(old, unchecked).empty()) {
                ASSERT_FALSE(model.refused_merges.empty());
                EXPECT_NE(model.summary().find("would be invalid"), std::string::npos);
            }
        }
    std::printf("the unchecked merge made an invalid face in %d of 6 blocks\n", fooled);
    EXPECT_GE(fooled, 3);
    // A chamfer ten times the noise: nothing is undone (its slivers stay triangles, as before).
    for (unsigned seed : {1u, 2u}) {
        PlanarFaceOptions options;
        options.min_facets = 10;
        const PlanarFaceModel model = planar_face_model(chamfered_block(0.1, 0.01, seed), options);
        EXPECT_TRUE(model.refused_merges.empty()) << model.summary();
        EXPECT_EQ(model.merged_faces, 4u) << model.summary();
    }
}
