// Cylindrical faces: a plate with a boss and a hole through both, meshed and noisy, must give
// the hole and the boss as cylinders of the true radius and axis (each bounded by circles on the
// planar faces), and a hole that is slightly oval or drilled obliquely must stay triangles with
// the reason. (FreeCAD reads these B-reps back in the freecad_headless suite.)
#include "picoscan/solid.h"
#include "support/test_support.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The part: a 30 x 30 x 6 mm plate, a boss of radius 8 mm and 4 mm high on it, a hole of radius
// 4 mm through both, all about the vertical axis through `kCentre`.
const cv::Vec3d kCentre(12.3, -7.1, 2.5);
constexpr double kHalf = 15, kThickness = 6, kBossRadius = 8, kBossHeight = 4, kHoleRadius = 4;

// Its mesh: 96 segments round, rings between the circles and the square on the flat faces, every
// vertex moved by Gaussian noise. oval_mm: the hole's radius varies by +- this (twice round);
// tilt_deg: the hole is a round cylinder leaning by this from the vertical (cut obliquely by the
// plate's faces).
Mesh bushing_plate(double sigma, unsigned seed, double oval_mm = 0, double tilt_deg = 0) {
    const int segments = 96, rings = 4;
    std::vector<cv::Vec3d> positions;
    std::map<std::array<double, 3>, int> index_of;
    auto vertex = [&](const cv::Vec3d& p) {
        const std::array<double, 3> key{p[0], p[1], p[2]};
        const auto found = index_of.find(key);
        if (found != index_of.end()) return found->second;
        positions.push_back(p);
        return index_of[key] = int(positions.size()) - 1;
    };
    auto angle = [&](int k) { return 2 * kPi * k / segments; };
    auto square = [&](int k, double z) {
        const double a = angle(k), reach = kHalf / std::max(std::abs(std::cos(a)), std::abs(std::sin(a)));
        return kCentre + cv::Vec3d(reach * std::cos(a), reach * std::sin(a), z);
    };
    auto boss = [&](int k, double z) { return kCentre + cv::Vec3d(kBossRadius * std::cos(angle(k)), kBossRadius * std::sin(angle(k)), z); };
    const double tilt = tilt_deg * kPi / 180;
    auto hole = [&](int k, double z) {
        const double a = angle(k), radius = kHoleRadius + oval_mm * std::cos(2 * a);
        return kCentre + cv::Vec3d(z * std::tan(tilt) + radius * std::cos(a) / std::cos(tilt), radius * std::sin(a), z);
    };
    using Ring = std::vector<int>;
    auto ring = [&](auto&& at, double z) {
        Ring indices;
        for (int k = 0; k <= segments; ++k) indices.push_back(vertex(at(k % segments, z)));
        return indices;
    };
    Mesh mesh;
    auto strip = [&](const Ring& a, const Ring& b) {  // outward when a runs counter-clockwise below b
        for (int k = 0; k < segments; ++k) {
            mesh.faces.emplace_back(a[k], a[k + 1], b[k + 1]);
            mesh.faces.emplace_back(a[k], b[k + 1], b[k]);
        }
    };
    // A flat annulus at height z from the inner curve to the outer; facing down or up.
    auto annulus = [&](auto&& inner, auto&& outer, double z, bool up) {
        std::vector<Ring> steps{ring(inner, z)};
        for (int i = 1; i < rings; ++i)
            steps.push_back(ring([&](int k, double h) { return inner(k, h) + (outer(k, h) - inner(k, h)) * (double(i) / rings); }, z));
        steps.push_back(ring(outer, z));
        for (int i = 0; i < rings; ++i) up ? strip(steps[i + 1], steps[i]) : strip(steps[i], steps[i + 1]);
    };
    // A wall from z0 to z1 in millimetre rows; outward or facing the axis.
    auto wall = [&](auto&& curve, double z0, double z1, bool outward) {
        const int rows = int(std::lround(z1 - z0));
        for (int j = 0; j < rows; ++j) {
            const Ring below = ring(curve, z0 + (z1 - z0) * j / rows), above = ring(curve, z0 + (z1 - z0) * (j + 1) / rows);
            outward ? strip(below, above) : strip(above, below);
        }
    };
    const double top = kThickness + kBossHeight;
    annulus(hole, square, 0, false);
    wall(square, 0, kThickness, true);
    annulus(boss, square, kThickness, true);
    wall(boss, kThickness, top, true);
    annulus(hole, boss, top, true);
    wall(hole, 0, top, false);
    std::mt19937 random(seed);
    std::normal_distribution<double> unit_noise;  // scaled: its deviation must be positive, and sigma may be 0
    const auto noise = [&](auto& engine) { return sigma * unit_noise(engine); };
    for (const cv::Vec3d& p : positions)
        mesh.vertices.emplace_back(float(p[0] + noise(random)), float(p[1] + noise(random)), float(p[2] + noise(random)));
    return mesh;
}

const BrepFace* cylinder_of_radius(const PlanarFaceModel& model, double radius) {
    for (const BrepFace& face : model.faces)
        if (face.radius_mm > 0 && std::abs(face.radius_mm - radius) < 0.5) return &face;
    return nullptr;
}

std::string notes_of(const PlanarFaceModel& model) {
    std::string text;
    for (const std::string& note : model.cylinder_notes) text += note + "\n";
    return text;
}

}  // namespace

TEST(CylinderFaces, HoleAndBossBecomeCylindersOfTheTrueRadiusAndAxis) {
    int seed = 11;
    for (double sigma : {0.0, 0.005, 0.01, 0.02}) {
        SCOPED_TRACE("noise " + std::to_string(sigma));
        const Mesh mesh = bushing_plate(sigma, unsigned(++seed));
        const PlanarFaceModel model = planar_face_model(mesh);
        std::printf("bushing plate, noise %.3f mm: %s\n", sigma, model.summary().c_str());
        ASSERT_EQ(model.cylinder_faces, 2u) << notes_of(model);
        EXPECT_TRUE(model.cylinder_notes.empty()) << notes_of(model);
        EXPECT_EQ(model.merged_faces, 7u);  // the plate's 6 sides and the boss's top
        EXPECT_LT(model.faces.size(), model.merged_faces + 2 + 20) << "a few triangles the noise tipped at most";
        for (const auto& [radius, hole] : {std::pair{kHoleRadius, true}, std::pair{kBossRadius, false}}) {
            const BrepFace* face = cylinder_of_radius(model, radius);
            ASSERT_NE(face, nullptr);
            std::printf("  %s: radius %.5f mm (true %.1f), axis through (%.5f, %.5f), direction z %.7f\n", hole ? "hole" : "boss",
                        face->radius_mm, radius, face->origin[0], face->origin[1], std::abs(face->normal[2]));
            EXPECT_NEAR(face->radius_mm, radius, 0.02);
            EXPECT_EQ(face->reversed, hole);
            EXPECT_GT(std::abs(face->normal[2]), 1 - 1e-6);  // square to the plate
            const cv::Vec3d off_axis = face->origin - kCentre;
            EXPECT_NEAR(std::hypot(off_axis[0], off_axis[1]), 0, 0.02);
            ASSERT_EQ(face->wires.size(), 1u);
            ASSERT_EQ(face->wires[0].size(), 4u);  // circle, seam, circle, seam
            EXPECT_EQ(face->wires[0][1], -face->wires[0][3]);
            for (int e : {face->wires[0][0], face->wires[0][2]})
                EXPECT_NEAR(model.edges[size_t(std::abs(e) - 1)].radius_mm, face->radius_mm, 1e-12);
        }
        // The boss's cap: its outer wire the boss's circle, its inner one the hole's.
        size_t caps = 0;
        for (size_t f = 0; f < model.merged_faces; ++f) {
            const BrepFace& face = model.faces[f];
            if (face.wires.size() != 2 || face.wires[0].size() != 1 || face.wires[1].size() != 1) continue;
            ++caps;
            EXPECT_NEAR(model.edges[size_t(std::abs(face.wires[0][0]) - 1)].radius_mm, kBossRadius, 0.02);
            EXPECT_NEAR(model.edges[size_t(std::abs(face.wires[1][0]) - 1)].radius_mm, kHoleRadius, 0.02);
        }
        EXPECT_EQ(caps, 1u);

        // Written as a cylinder surface (type 2) with circles, each seam with its two pcurves.
        const std::string path = test_support::make_temp_dir("cylinder_faces") + "/bushing.brep";
        write_brep(model, path);
        const std::string brep = test_support::read_file_bytes(path);
        const size_t surfaces = brep.find("Surfaces "), triangulations = brep.find("\nTriangulations ");
        ASSERT_NE(surfaces, std::string::npos);
        size_t cylinder_lines = 0;
        for (size_t at = brep.find("\n2 ", surfaces); at < triangulations; at = brep.find("\n2 ", at + 1)) ++cylinder_lines;
        EXPECT_EQ(cylinder_lines, 2u);
        size_t seams = 0;
        for (size_t at = brep.find(" CN "); at != std::string::npos; at = brep.find(" CN ", at + 1)) ++seams;
        EXPECT_EQ(seams, 2u);
    }
}

TEST(CylinderFaces, AnOvalOrObliqueHoleStaysTrianglesWithTheReason) {
    const struct {
        const char* name;
        double oval_mm, tilt_deg;
    } cases[] = {{"oval by 0.03 mm", 0.03, 0}, {"leaning 2 degrees", 0, 2}};
    for (const auto& hole : cases) {
        SCOPED_TRACE(hole.name);
        const PlanarFaceModel model = planar_face_model(bushing_plate(0.005, 7, hole.oval_mm, hole.tilt_deg));
        std::printf("bushing plate, hole %s: %s\n", hole.name, model.summary().c_str());
        ASSERT_EQ(model.cylinder_faces, 1u) << notes_of(model);
        EXPECT_NE(cylinder_of_radius(model, kBossRadius), nullptr);
        EXPECT_EQ(cylinder_of_radius(model, kHoleRadius), nullptr);
        ASSERT_EQ(model.cylinder_notes.size(), 1u) << notes_of(model);
        EXPECT_NE(model.cylinder_notes[0].find("not a cylinder square to its planes"), std::string::npos) << notes_of(model);
        EXPECT_NE(model.summary().find("not a cylinder square to its planes"), std::string::npos);
        EXPECT_GT(model.faces.size(), model.merged_faces + 1);  // the hole's triangles (simplified)
    }
}

TEST(CylinderFaces, NoneWhenNotAsked) {
    PlanarFaceOptions options;
    options.cylinders = false;
    const PlanarFaceModel model = planar_face_model(bushing_plate(0.005, 3), options);
    EXPECT_EQ(model.cylinder_faces, 0u);
    for (const BrepEdge& edge : model.edges) EXPECT_EQ(edge.radius_mm, 0);
}

namespace {

// A shaft: a cylinder of radius 5 mm and 30 mm long with flat ends, 64 segments round, its wall in
// 1 mm rows (long flat strips in the noise, each of more facets than an end), turned to an
// oblique axis and moved; every vertex moved by Gaussian noise.
Mesh shaft(double sigma, unsigned seed, const cv::Matx33d& turn, const cv::Vec3d& shift) {
    const int segments = 64, rows = 30, rings = 4;
    const double radius = 5, length = 30;
    Mesh mesh;
    std::mt19937 random(seed);
    std::normal_distribution<double> unit_noise;  // scaled: its deviation must be positive, and sigma may be 0
    const auto noise = [&](auto& engine) { return sigma * unit_noise(engine); };
    auto add = [&](double r, int k, double z) {
        const double a = 2 * kPi * k / segments;
        const cv::Vec3d p = turn * cv::Vec3d(r * std::cos(a), r * std::sin(a), z) + shift;
        mesh.vertices.emplace_back(float(p[0] + noise(random)), float(p[1] + noise(random)), float(p[2] + noise(random)));
        return int(mesh.vertices.size()) - 1;
    };
    auto quads = [&](const std::vector<int>& a, const std::vector<int>& b) {  // outward when a runs counter-clockwise below b
        for (int k = 0; k < segments; ++k) {
            const int next = (k + 1) % segments;
            mesh.faces.emplace_back(a[k], a[next], b[next]);
            mesh.faces.emplace_back(a[k], b[next], b[k]);
        }
    };
    auto ring = [&](double r, double z) {
        std::vector<int> indices;
        for (int k = 0; k < segments; ++k) indices.push_back(add(r, k, z));
        return indices;
    };
    std::vector<std::vector<int>> wall;
    for (int j = 0; j <= rows; ++j) wall.push_back(ring(radius, length * j / rows));
    for (int j = 0; j < rows; ++j) quads(wall[j], wall[j + 1]);
    for (const bool top : {false, true}) {  // each end: rings inwards, then a fan to its centre
        const double z = top ? length : 0;
        std::vector<int> outer = wall[top ? rows : 0];
        for (int i = rings - 1; i >= 1; --i) {
            const std::vector<int> inner = ring(radius * i / rings, z);
            top ? quads(outer, inner) : quads(inner, outer);
            outer = inner;
        }
        const int centre = add(0, 0, z);
        for (int k = 0; k < segments; ++k) {
            const int next = (k + 1) % segments;
            if (top) mesh.faces.emplace_back(outer[k], outer[next], centre);
            else mesh.faces.emplace_back(outer[next], outer[k], centre);
        }
    }
    return mesh;
}

}  // namespace

TEST(CylinderFaces, AnObliqueShaftBecomesOneCylinderBetweenItsEnds) {
    cv::Matx33d turn;
    cv::Rodrigues(cv::Vec3d(0.5, -0.3, 0.2), turn);
    const cv::Vec3d shift(3, -4, 7), axis = turn * cv::Vec3d(0, 0, 1);
    for (double sigma : {0.0, 0.01}) {
        SCOPED_TRACE("noise " + std::to_string(sigma));
        const PlanarFaceModel model = planar_face_model(shaft(sigma, 5, turn, shift));
        std::printf("shaft, noise %.3f mm: %s\n", sigma, model.summary().c_str());
        ASSERT_EQ(model.cylinder_faces, 1u) << notes_of(model);
        const BrepFace* face = cylinder_of_radius(model, 5);
        ASSERT_NE(face, nullptr);
        EXPECT_NEAR(face->radius_mm, 5, 0.02);
        EXPECT_FALSE(face->reversed);
        EXPECT_GT(std::abs(face->normal.dot(axis)), 1 - 1e-6);
        const cv::Vec3d off = face->origin - shift;
        EXPECT_NEAR(cv::norm(off - off.dot(axis) * axis), 0, 0.02);
        EXPECT_EQ(model.merged_faces, 2u);  // its ends
    }
}
