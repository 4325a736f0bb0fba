// Deviation map: signed distances to a reference mesh must be exact (to float precision) and on
// the right side everywhere, including next to edges and corners, where the side of the nearest
// face alone is wrong; the figures and the histogram must agree with the distances.
#include "picoscan/deviation.h"
#include "picoscan/error.h"
#include "picoscan/register.h"
#include "picoscan/simulate.h"

#include "support/test_support.h"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>

using namespace picoscan;

namespace {

// The box [0, size]^3, faces counter-clockwise seen from outside; `shared` = false repeats the
// vertices in every face, as a tessellated B-rep does.
Mesh box(double size, bool shared) {
    Mesh mesh;
    const float s = float(size);
    const cv::Vec3f corner[8] = {{0, 0, 0}, {s, 0, 0}, {s, s, 0}, {0, s, 0}, {0, 0, s}, {s, 0, s}, {s, s, s}, {0, s, s}};
    const int quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};
    if (shared) mesh.vertices.assign(corner, corner + 8);
    for (const auto& q : quads) {
        for (const auto& tri : {cv::Vec3i(q[0], q[1], q[2]), cv::Vec3i(q[0], q[2], q[3])}) {
            if (shared) {
                mesh.faces.push_back(tri);
            } else {
                const int base = int(mesh.vertices.size());
                for (int k = 0; k < 3; ++k) mesh.vertices.push_back(corner[tri[k]]);
                mesh.faces.emplace_back(base, base + 1, base + 2);
            }
        }
    }
    return mesh;
}

// Exact signed distance to the box [0, s]^3 (positive outside).
double box_distance(const cv::Vec3d& p, double s) {
    cv::Vec3d outside, inside;
    for (int k = 0; k < 3; ++k) outside[k] = std::max({0.0, -p[k], p[k] - s});
    const double out = cv::norm(outside);
    if (out > 0) return out;
    double nearest = HUGE_VAL;
    for (int k = 0; k < 3; ++k) nearest = std::min({nearest, p[k], s - p[k]});
    return -nearest;
}

}  // namespace

TEST(Deviation, ExactSignedDistancesToABoxNearFacesEdgesAndCorners) {
    for (const bool shared : {true, false}) {
        const Mesh reference = box(10, shared);
        std::mt19937 random(3);
        std::uniform_real_distribution<double> coordinate(-1.0, 11.0);
        std::vector<cv::Vec3f> points;
        // Near the edges and corners: where the nearest face's own normal gives the wrong side.
        for (int i = 0; i < 20000; ++i) points.emplace_back(float(coordinate(random)), float(coordinate(random)), float(coordinate(random)));
        points.emplace_back(10.5f, 10.5f, 5.f);   // outside, nearest to an edge
        points.emplace_back(9.9f, 9.8f, 5.f);     // inside, near an edge
        points.emplace_back(10.3f, 10.3f, 10.3f); // outside, nearest to a corner
        points.emplace_back(9.95f, 9.9f, 9.9f);   // inside, near a corner
        DeviationOptions options;
        options.tolerance_mm = 0.5;
        const DeviationMap map = measure_deviation(points, reference, options);
        ASSERT_EQ(map.distances_mm.size(), points.size());
        int wrong = 0;
        for (size_t i = 0; i < points.size(); ++i) {
            const double truth = box_distance(cv::Vec3d(points[i][0], points[i][1], points[i][2]), 10);
            if (std::abs(map.distances_mm[i] - truth) > 2e-5) ++wrong;
        }
        EXPECT_EQ(wrong, 0) << (shared ? "shared vertices" : "vertices repeated per face");
        EXPECT_NEAR(map.distances_mm[points.size() - 4], std::sqrt(0.5), 1e-5);
        EXPECT_NEAR(map.distances_mm[points.size() - 3], -0.1, 1e-5);
        EXPECT_NEAR(map.distances_mm[points.size() - 2], std::sqrt(0.27), 1e-5);
        EXPECT_NEAR(map.distances_mm[points.size() - 1], -0.05, 1e-5);
    }
}

TEST(Deviation, KnownOffsetsFromTheMechanicalPartAndTheirFigures) {
    // The demo part (closed, with a through hole: concave and convex edges), points moved off its
    // faces' centroids by known signed offsets (one face in 7).
    const Mesh part = mechanical_part();
    std::mt19937 random(11);
    std::normal_distribution<double> offset(0.01, 0.03);
    std::vector<cv::Vec3f> points;
    std::vector<double> truth;
    for (size_t f = 0; f < part.faces.size(); f += 7) {
        const cv::Vec3d a(part.vertices[part.faces[f][0]]), b(part.vertices[part.faces[f][1]]), c(part.vertices[part.faces[f][2]]);
        const cv::Vec3d cross = (b - a).cross(c - a);
        const double area2 = cv::norm(cross);
        if (area2 < 1e-4) continue;  // slivers have no reliable normal
        // The boss is a separate closed cylinder sunk 1 mm into the block: the block's top under it,
        // its foot and its bottom cap are inside the part, where a surface distance means nothing.
        const cv::Vec3d centroid = (a + b + c) / 3;
        if (std::hypot(centroid[0] - 12, centroid[1] + 2) < 7.3 && centroid[2] < 24.7) continue;
        const cv::Vec3d normal = cross / area2;
        // The centroid is a third of the smallest height away from the nearest edge: an offset below
        // that keeps it the nearest point of the surface, also inside convex edges.
        const double longest = std::max({cv::norm(b - a), cv::norm(c - b), cv::norm(a - c)});
        const double room = 0.8 * area2 / longest / 3;
        const double d = std::clamp(offset(random), -room, room);
        points.emplace_back((a + b + c) / 3 + d * normal);
        truth.push_back(d);
    }
    DeviationOptions options;
    options.tolerance_mm = 0.03;
    const DeviationMap map = measure_deviation(points, part, options);
    double worst = 0, sum = 0, sum_abs = 0;
    size_t within = 0;
    for (size_t i = 0; i < points.size(); ++i) {
        worst = std::max(worst, std::abs(map.distances_mm[i] - truth[i]));
        sum += truth[i];
        sum_abs += std::abs(truth[i]);
        within += std::abs(truth[i]) <= 0.03;
    }
    EXPECT_LT(worst, 2e-4);  // float coordinates of a part 400 mm from nothing: single precision
    const DeviationStatistics& s = map.statistics;
    EXPECT_EQ(s.count, points.size());
    EXPECT_NEAR(s.mean_mm, sum / points.size(), 1e-5);
    EXPECT_NEAR(s.mean_abs_mm, sum_abs / points.size(), 1e-5);
    EXPECT_NEAR(s.within_tolerance, double(within) / points.size(), 0.002);
    EXPECT_GT(s.p95_abs_mm, s.mean_abs_mm);
    EXPECT_LE(s.p95_abs_mm, s.max_abs_mm);
    size_t histogram_total = map.below_range + map.above_range;
    for (const size_t count : map.histogram) histogram_total += count;
    EXPECT_EQ(histogram_total, s.count);
    EXPECT_DOUBLE_EQ(map.range_mm, 0.12);
}

TEST(Deviation, FarPointsAreIgnoredAndColoured) {
    const Mesh reference = box(10, true);
    const std::vector<cv::Vec3f> points = {{5, 5, 10.01f}, {5, 5, 9.9f}, {5, 5, 30}, {5, 5, 10.3f}};
    DeviationOptions options;
    options.tolerance_mm = 0.05;
    options.max_distance_mm = 5;
    const DeviationMap map = measure_deviation(points, reference, options);
    EXPECT_TRUE(std::isnan(map.distances_mm[2]));
    EXPECT_EQ(map.statistics.count, 3u);
    EXPECT_EQ(map.statistics.ignored, 1u);
    EXPECT_NEAR(map.statistics.within_tolerance, 1.0 / 3, 1e-9);
    const auto colours = deviation_colours(map);
    EXPECT_EQ(colours[0], cv::Vec3b(0, 200, 0));    // within tolerance: green
    EXPECT_EQ(colours[1], cv::Vec3b(0, 170, 255));  // 0.1 inside: a third of the way to blue
    EXPECT_EQ(colours[2], cv::Vec3b(128, 128, 128));
    EXPECT_EQ(colours[3], cv::Vec3b(255, 0, 0));    // beyond the range outside: red
}

TEST(Deviation, WritesPlyWithQualityAndAReport) {
    const std::string folder = test_support::make_temp_dir("deviation");
    const Mesh reference = box(10, true);
    const std::vector<cv::Vec3f> points = {{5, 5, 10.01f}, {5, 5, 9.9f}, {5, 5, 10.2f}};
    const DeviationMap map = measure_deviation(points, reference);
    write_deviation_ply(points, map, folder + "/map.ply");
    std::ifstream ply(folder + "/map.ply", std::ios::binary);
    std::string header((std::istreambuf_iterator<char>(ply)), {});
    header = header.substr(0, header.find("end_header"));
    EXPECT_NE(header.find("element vertex 3"), std::string::npos);
    EXPECT_NE(header.find("property float quality"), std::string::npos);
    EXPECT_NE(header.find("property uchar red"), std::string::npos);
    write_deviation_report(map, "box <test>", folder + "/report.html");
    std::ifstream html(folder + "/report.html");
    const std::string text((std::istreambuf_iterator<char>(html)), {});
    EXPECT_NE(text.find("box &lt;test&gt;"), std::string::npos);
    EXPECT_NE(text.find("report.html.png"), std::string::npos);
    EXPECT_NE(text.find("33.33 %"), std::string::npos);  // one of three within 0.05 mm
    std::ifstream png(folder + "/report.html.png", std::ios::binary | std::ios::ate);
    EXPECT_GT(int(png.tellg()), 5000);
    EXPECT_THROW(write_deviation_ply({{0, 0, 0}}, map, folder + "/bad.ply"), Error);
}

// The histogram's colour scale is the map's legend: every label of it, the range's ends included,
// must be whole on the picture (the last one, "+0.200", was cut off at its right edge).
TEST(Deviation, HistogramLegendLabelsFitOnThePicture) {
    const Mesh reference = box(10, true);
    const DeviationMap map = measure_deviation({{5, 5, 10.01f}, {5, 5, 9.9f}, {5, 5, 10.2f}}, reference);
    const cv::Mat image = plot_deviation_histogram(map, "box");
    int inked_edge_pixels = 0;  // text or lines touching the left or right edge
    for (int y = 0; y < image.rows; ++y)
        for (const int x : {0, 1, image.cols - 2, image.cols - 1}) {
            const cv::Vec3b pixel = image.at<cv::Vec3b>(y, x);
            inked_edge_pixels += pixel[0] < 200 || pixel[1] < 200 || pixel[2] < 200;
        }
    EXPECT_EQ(inked_edge_pixels, 0);
}

TEST(Deviation, RefusesBadInputNamingIt) {
    const Mesh reference = box(10, true);
    const std::vector<cv::Vec3f> points = {{5, 5, 11}};
    const auto message = [&](const Mesh& mesh, const std::vector<cv::Vec3f>& p, const DeviationOptions& options,
                             const ProgressCallback& progress = nullptr) {
        try {
            measure_deviation(p, mesh, options, progress);
        } catch (const Error& error) {
            return std::string(error.what());
        }
        return std::string("no error");
    };
    EXPECT_EQ(message(Mesh(), points, {}), "reference: has no triangles");
    Mesh broken = reference;
    broken.faces[3][1] = 99;
    EXPECT_NE(message(broken, points, {}).find("reference: triangle 3 uses vertex 99"), std::string::npos);
    Mesh flat = reference;
    for (auto& face : flat.faces) face = cv::Vec3i(face[0], face[0], face[1]);
    EXPECT_NE(message(flat, points, {}).find("degenerate"), std::string::npos);
    EXPECT_EQ(message(reference, {}, {}), "points: none to measure");
    DeviationOptions bad;
    bad.tolerance_mm = 0;
    EXPECT_EQ(message(reference, points, bad), "tolerance_mm: must be positive");
    bad = DeviationOptions();
    bad.histogram_bins = 1;
    EXPECT_NE(message(reference, points, bad).find("histogram_bins"), std::string::npos);
    bad = DeviationOptions();
    bad.max_distance_mm = 0.1;  // the only point is 1 mm away
    EXPECT_NE(message(reference, points, bad).find("points: none lies within"), std::string::npos);
    const auto stop = [](double, const std::string&) { return false; };
    EXPECT_NE(message(reference, points, {}, stop).find("cancelled"), std::string::npos);
}

namespace {

cv::Matx44d rigid(double degrees, const cv::Vec3d& axis, const cv::Vec3d& shift) {
    cv::Matx33d rotation;
    cv::Rodrigues(cv::normalize(axis) * (degrees * CV_PI / 180), rotation);
    cv::Matx44d transform = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) transform(r, c) = rotation(r, c);
        transform(r, 3) = shift[r];
    }
    return transform;
}

std::vector<cv::Vec3f> moved(const std::vector<cv::Vec3f>& points, const cv::Matx44d& transform) {
    std::vector<cv::Vec3f> result;
    for (const cv::Vec3f& p : points) {
        const cv::Vec4d q = transform * cv::Vec4d(p[0], p[1], p[2], 1);
        result.emplace_back(float(q[0]), float(q[1]), float(q[2]));
    }
    return result;
}

}  // namespace

TEST(BestFit, PutsAMovedNoisyScanBackOnTheModelDespiteOutliers) {
    const Mesh part = mechanical_part();
    std::mt19937 random(4);
    std::normal_distribution<float> noise(0, 0.02f);
    std::uniform_real_distribution<float> stray(2, 6);
    std::vector<cv::Vec3f> scan;
    for (size_t i = 0; i < part.vertices.size(); i += 3) {
        const cv::Vec3f& p = part.vertices[i];
        if (std::hypot(p[0] - 12, p[1] + 2) < 7.05 && p[2] < 24.05) continue;  // inside the part: the boss's foot
        scan.push_back(p + cv::Vec3f(noise(random), noise(random), noise(random)));
    }
    const size_t clean = scan.size();
    for (size_t i = 0; i < clean / 20; ++i) scan.push_back(scan[i * 7] + cv::Vec3f(0, 0, stray(random)));  // 5 % stray
    const cv::Matx44d misplaced = rigid(3.0, {0.3, -0.5, 1}, {1.5, -0.8, 0.6});
    const BestFit fit = best_fit_to_reference(moved(scan, misplaced), part);
    EXPECT_TRUE(fit.converged);
    const cv::Matx44d residual = fit.transform * misplaced;  // the identity when the fit undid the move
    const PoseDifference error = pose_difference(residual, cv::Matx44d::eye(), {0, 0, 12});
    std::printf("best fit: %d iterations, rms %.4f mm over %zu pairs; left %.5f deg, %.5f mm\n", fit.iterations,
                fit.rms_mm, fit.pairs, error.rotation_deg, error.translation_mm);
    EXPECT_LT(error.rotation_deg, 0.005);
    EXPECT_LT(error.translation_mm, 0.003);
    EXPECT_LT(fit.rms_mm, 0.03);
}

TEST(BestFit, RefusesPointsThatCanSlide) {
    const Mesh reference = box(10, true);
    std::vector<cv::Vec3f> top;  // only the top face: it can slide in x and y and turn about z
    for (int i = 1; i < 10; ++i)
        for (int k = 1; k < 10; ++k) top.emplace_back(float(i), float(k), 10.05f);
    try {
        best_fit_to_reference(top, reference);
        ADD_FAILURE() << "a single plane was fitted";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("do not fix all six degrees of freedom"), std::string::npos) << error.what();
    }
    BestFitOptions bad;
    bad.keep_fraction = 0;
    EXPECT_THROW(best_fit_to_reference(top, reference, bad), Error);
    EXPECT_THROW(best_fit_to_reference({{0, 0, 0}}, reference), Error);
}
