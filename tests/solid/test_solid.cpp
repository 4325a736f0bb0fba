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
#include <limits>
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
    std::normal_distribution<double> unit_noise;  // scaled: its deviation must be positive, and sigma may be 0
    const auto noise = [&](auto& engine) { return sigma * unit_noise(engine); };
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
    // (Without simplifying the curved facets: the CurvedRegions tests below.)
    Mesh ball = sphere(10, 60, 120);
    PlanarFaceOptions options;
    options.simplify = false;
    const PlanarFaceModel model = planar_face_model(ball, options);
    SCOPED_TRACE(model.summary());
    EXPECT_LT(model.merged_facets, ball.faces.size() / 10);
    for (const BrepFace& face : model.faces) {
        if (!face.merged) continue;
        EXPECT_GT(std::abs(face.normal[2]), 0.9);  // near the poles only
    }
    const double volume = model.mesh_volume_mm3;
    for (cv::Vec3i& face : ball.faces) std::swap(face[1], face[2]);
    const PlanarFaceModel inward = planar_face_model(ball, options);
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
    // An infinite noise, factor or simplification distance would let every facet fit every
    // plane: refused, naming the option.
    for (const auto& [name, value] : {std::pair{"noise_mm", &PlanarFaceOptions::noise_mm},
                                      std::pair{"distance_factor", &PlanarFaceOptions::distance_factor},
                                      std::pair{"distance_factor", &PlanarFaceOptions::max_rms_factor},
                                      std::pair{"simplify_mm", &PlanarFaceOptions::simplify_mm}}) {
        PlanarFaceOptions infinite;
        infinite.*value = HUGE_VAL;
        try {
            planar_face_model(grid_box(2, 2, 2, 1.0, 0.0), infinite);
            ADD_FAILURE() << name << " = inf was accepted";
        } catch (const Error& error) {
            EXPECT_EQ(error.subject(), name) << error.what();
        }
    }
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
    std::normal_distribution<double> unit_noise;  // scaled: its deviation must be positive, and sigma may be 0
    const auto noise = [&](auto& engine) { return sigma * unit_noise(engine); };
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

// Curved regions (the facets in no planar face) become fewer, larger triangles: each mesh vertex
// stays within the tolerance of them, the volume within 0.05 %, and the planar faces beside them as
// they were. Fooling inputs: waves (curved, but no cylinder or sphere; small enough to look flat),
// a spike of one vertex (a feature a one-sided bound would cut off).
namespace {

double segment_distance3(const cv::Vec3d& p, const cv::Vec3d& a, const cv::Vec3d& b) {
    const cv::Vec3d ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / ab.dot(ab), 0.0, 1.0);
    return cv::norm(p - (a + t * ab));
}

double triangle_distance(const cv::Vec3d& p, const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c) {
    const cv::Vec3d n = cv::normalize((b - a).cross(c - a));
    const cv::Vec3d q = p - (p - a).dot(n) * n;  // p's foot on the plane: inside when on the inner side of each edge
    if ((b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 && (a - c).cross(q - c).dot(n) >= 0)
        return std::abs((p - a).dot(n));
    return std::min({segment_distance3(p, a, b), segment_distance3(p, b, c), segment_distance3(p, c, a)});
}

// The farthest of every `step`-th vertex of the curved facets of `before` from the facets of
// `model` (brute force).
double farthest_from_model(const PlanarFaceModel& before, const PlanarFaceModel& model, size_t step) {
    std::vector<int> curved;
    for (const BrepFace& face : before.faces)
        if (!face.merged)
            for (const cv::Vec3i& t : face.triangles) curved.insert(curved.end(), {t[0], t[1], t[2]});
    std::sort(curved.begin(), curved.end());
    curved.erase(std::unique(curved.begin(), curved.end()), curved.end());
    double farthest = 0;
    for (size_t v = 0; v < curved.size(); v += step) {
        const cv::Vec3d& p = before.vertices[size_t(curved[v])];
        double nearest = std::numeric_limits<double>::infinity();
        for (const BrepFace& face : model.faces)
            for (const cv::Vec3i& t : face.triangles)
                nearest = std::min(nearest, triangle_distance(p, model.vertices[t[0]], model.vertices[t[1]], model.vertices[t[2]]));
        farthest = std::max(farthest, nearest);
    }
    return farthest;
}

size_t triangle_count(const PlanarFaceModel& model) {
    size_t count = 0;
    for (const BrepFace& face : model.faces) count += face.triangles.size();
    return count;
}

void add_noise(Mesh& mesh, double sigma, unsigned seed) {
    std::mt19937 random(seed);
    std::normal_distribution<double> unit_noise;  // scaled: its deviation must be positive, and sigma may be 0
    const auto noise = [&](auto& engine) { return sigma * unit_noise(engine); };
    for (cv::Vec3f& v : mesh.vertices) v += cv::Vec3f(float(noise(random)), float(noise(random)), float(noise(random)));
}

// What every simplified model of `mesh` must hold: fewer facets, the vertices of the curved facets
// it had without simplifying within the tolerance of it (checked here on every `step`-th, and as
// the core measured it), the volume kept, the planar faces as they were.
PlanarFaceModel expect_simplified_within(const Mesh& mesh, const PlanarFaceOptions& options, size_t step) {
    PlanarFaceOptions plain = options;
    plain.simplify = false;
    const PlanarFaceModel before = planar_face_model(mesh, plain);
    const PlanarFaceModel model = planar_face_model(mesh, options);
    SCOPED_TRACE(model.summary());
    EXPECT_EQ(model.mesh_volume_mm3, before.mesh_volume_mm3);
    EXPECT_EQ(model.curved_facets_before, before.facet_count - before.merged_facets);
    EXPECT_EQ(model.merged_faces, before.merged_faces);
    for (size_t f = 0; f < std::min(model.merged_faces, before.merged_faces); ++f) {  // the same planar faces, with the same facets
        EXPECT_EQ(model.faces[f].facet_count, before.faces[f].facet_count);
        EXPECT_LT(cv::norm(model.faces[f].normal - before.faces[f].normal), 1e-6);
    }
    EXPECT_LT(model.curved_facets_after, model.curved_facets_before);
    EXPECT_EQ(triangle_count(model), model.facet_count);
    EXPECT_GT(model.simplify_mm, 0);
    EXPECT_LE(model.simplify_deviation_mm, model.simplify_mm);
    EXPECT_LE(farthest_from_model(before, model, step), model.simplify_mm * (1 + 1e-6));
    EXPECT_NEAR(model.simplified_volume_mm3, model.mesh_volume_mm3, options.simplify_max_volume_change * model.mesh_volume_mm3);
    EXPECT_TRUE(merged_face_defects(model).empty());
    // No facet turned over: each against the (outward) mesh facet nearest to its centre.
    double volume = 0;
    for (const cv::Vec3i& m : mesh.faces)
        volume += cv::Vec3d(mesh.vertices[m[0]]).dot(cv::Vec3d(mesh.vertices[m[1]]).cross(cv::Vec3d(mesh.vertices[m[2]])));
    size_t folded = 0, curved = 0;
    for (const BrepFace& face : model.faces) {
        if (face.merged || curved++ % step != 0) continue;
        const cv::Vec3i& t = face.triangles[0];
        const cv::Vec3d n = (model.vertices[t[1]] - model.vertices[t[0]]).cross(model.vertices[t[2]] - model.vertices[t[0]]);
        const cv::Vec3d centre = (model.vertices[t[0]] + model.vertices[t[1]] + model.vertices[t[2]]) / 3;
        double nearest = std::numeric_limits<double>::infinity();
        cv::Vec3d mesh_normal;
        for (const cv::Vec3i& m : mesh.faces) {
            const cv::Vec3d a(mesh.vertices[m[0]]), b(mesh.vertices[m[1]]), c(mesh.vertices[m[2]]);
            const double d = cv::norm((a + b + c) / 3 - centre);
            if (d < nearest) nearest = d, mesh_normal = (b - a).cross(c - a);
        }
        folded += n.dot(volume > 0 ? mesh_normal : -mesh_normal) < -0.5 * cv::norm(n) * cv::norm(mesh_normal);
    }
    EXPECT_EQ(folded, 0u);
    return model;
}

}  // namespace

TEST(CurvedRegions, NoisySphereBecomesAnEighthOfTheFacetsWithinTheTolerance) {
    Mesh ball = sphere(10, 50, 100);
    add_noise(ball, 0.01, 5);
    const PlanarFaceModel model = expect_simplified_within(ball, {}, 5);
    EXPECT_LT(model.faces.size(), ball.faces.size() / 8);
    EXPECT_NEAR(model.simplify_mm, 4 * model.noise_mm, 1e-12);  // the default: distance_factor x the noise
    // Every corner of the curved facets on the sphere, within the tolerance and the noise (but
    // those the planar faces moved onto themselves).
    std::vector<char> on_plane(model.vertices.size(), 0);
    for (size_t f = 0; f < model.merged_faces; ++f)
        for (const cv::Vec3i& t : model.faces[f].triangles) on_plane[t[0]] = on_plane[t[1]] = on_plane[t[2]] = 1;
    for (const BrepFace& face : model.faces) {
        if (face.merged) continue;
        for (const cv::Vec3i& t : face.triangles)
            for (int k = 0; k < 3; ++k) {
                if (on_plane[t[k]]) continue;
                EXPECT_NEAR(cv::norm(model.vertices[t[k]]), 10.0, model.simplify_mm + 4 * 0.01);
            }
    }
    // A given tolerance; and none when merging is off (the fallback to the mesh's own facets).
    PlanarFaceOptions coarse;
    coarse.simplify_mm = 0.2;
    EXPECT_LT(expect_simplified_within(ball, coarse, 5).curved_facets_after, model.curved_facets_after * 2 / 3);
    PlanarFaceOptions unmerged;
    unmerged.merge = false;
    EXPECT_EQ(planar_face_model(ball, unmerged).faces.size(), ball.faces.size());
    // A volume change beyond the limit: the curved facets stay as they were, and the summary says why.
    PlanarFaceOptions strict;
    strict.simplify_max_volume_change = 1e-8;
    const PlanarFaceModel kept = planar_face_model(ball, strict);
    EXPECT_EQ(kept.curved_facets_after, kept.curved_facets_before);
    EXPECT_EQ(kept.facet_count - kept.merged_facets, kept.curved_facets_before);
    EXPECT_NE(kept.summary().find("not simplified: the volume would change"), std::string::npos) << kept.summary();
    coarse.simplify_mm = -1;
    EXPECT_THROW(planar_face_model(ball, coarse), Error);
    // Cancel while simplifying: stopped there, with "cancelled".
    int reports = 0;
    const ProgressCallback cancel = [&](double, const std::string& stage) {
        return stage.find("simplifying") == std::string::npos || ++reports < 3;
    };
    try {
        planar_face_model(ball, {}, cancel);
        ADD_FAILURE() << "not cancelled";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("cancelled"), std::string::npos) << error.what();
    }
    EXPECT_EQ(reports, 3);
}

TEST(CurvedRegions, PlanarFacesBesideARoundedEdgeStayAsTheyWere) {
    // A 20 x 10 block along y with its (+x, +z) edge rounded (radius 5, 40 facets round).
    std::vector<cv::Vec2d> outline{{0, 0}, {20, 0}};
    std::vector<int> segments{40, 10};  // side k runs from outline[k] to the next in segments[k] pieces
    for (int i = 0; i <= 40; ++i) {
        const double angle = kPi / 2 * i / 40;
        outline.emplace_back(15 + 5 * std::cos(angle), 5 + 5 * std::sin(angle));
        segments.push_back(i < 40 ? 1 : 30);
    }
    outline.emplace_back(0, 10);
    segments.push_back(20);
    const Mesh block = prism(outline, segments, 20.0, 40, 0.005, 9);
    const PlanarFaceModel model = expect_simplified_within(block, {}, 3);
    EXPECT_LT(model.curved_facets_after, model.curved_facets_before / 4);
    EXPECT_GE(model.merged_faces, 6u);
}

TEST(CurvedRegions, WavesAreFollowedNotFlattened) {
    // A 40 x 40 x 10 box whose top has waves of amplitude `amplitude` (0 at its edges): curved, but
    // no primitive; at 0.05 mm they are within a few noise widths of flat.
    for (double amplitude : {1.0, 0.05}) {
        Mesh box = grid_box(40, 40, 10, 1.0, 0.0);
        for (cv::Vec3f& v : box.vertices)
            if (v[2] > 9.5) v[2] += float(amplitude * std::sin(kPi * v[0] / 10) * std::sin(kPi * v[1] / 10));
        add_noise(box, 0.005, 11);
        SCOPED_TRACE(amplitude);
        const PlanarFaceModel model = expect_simplified_within(box, {}, 2);
        // The waves need many facets (the planar faces may take in only strips where they are flat
        // within the noise: along the lines where they cross z = 10).
        EXPECT_GT(model.curved_facets_after, amplitude > 0.5 ? 600u : 200u);
        EXPECT_LT(model.curved_facets_after, model.curved_facets_before / 2);
        for (const BrepFace& face : model.faces) {
            if (face.merged) continue;
            for (const cv::Vec3i& t : face.triangles)
                for (int k = 0; k < 3; ++k) {
                    const cv::Vec3d& p = model.vertices[t[k]];
                    if (p[2] < 9) continue;
                    EXPECT_NEAR(p[2], 10 + amplitude * std::sin(kPi * p[0] / 10) * std::sin(kPi * p[1] / 10),
                                model.simplify_mm + 4 * 0.005);
                }
        }
    }
}

TEST(CurvedRegions, ASpikeOfOneVertexStays) {
    Mesh ball = sphere(10, 50, 100);
    add_noise(ball, 0.01, 13);
    const size_t tip = ball.vertices.size() / 2 + 17;
    const cv::Vec3f outward = ball.vertices[tip] / cv::norm(ball.vertices[tip]);
    ball.vertices[tip] += 1.0f * outward;  // 1 mm out, on facets about 0.6 mm wide
    const PlanarFaceModel model = expect_simplified_within(ball, {}, 5);
    double nearest = std::numeric_limits<double>::infinity();
    for (const cv::Vec3d& p : model.vertices) nearest = std::min(nearest, cv::norm(p - cv::Vec3d(ball.vertices[tip])));
    EXPECT_LE(nearest, model.simplify_mm);
}
