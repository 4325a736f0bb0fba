// Fitted sections of a real simulated scan: the demo part on the turntable (8 views and one from
// above, camera noise 1 DN, the shared cached views), merged in the part's frame by the true
// poses and meshed as an open band surface, cut across its sides. The cuts carry what stand-in
// outlines do not: a side that wavers by more than its short-range noise where views overlap,
// corners the mesh rounds off, stray points there, the hole seen only in part.
#include "picoscan/mesh.h"
#include "picoscan/section_fit.h"
#include "section_counts.h"
#include "support/turntable_scan.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <tuple>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The demo part's outline (MechanicalPartShape defaults), counter-clockwise: its sides' directions.
const std::vector<cv::Vec2d> kOutline = {{-25, -18}, {25, -18}, {25, 10}, {17, 18}, {-25, 18}};

double direction_deg(const cv::Vec2d& a, const cv::Vec2d& b) { return std::atan2(b[1] - a[1], b[0] - a[0]) * 180 / kPi; }

double angle_error_deg(double a, double b) {
    const double d = std::fmod(std::abs(a - b), 180.0);
    return std::min(d, 180 - d);
}

// The band mesh of the whole scan, every second point (one mesh for every test of the suite).
const Mesh& scan_mesh() {
    static const Mesh mesh = [] {
        const test_support::TurntableScan& scan = test_support::turntable_scan();
        std::vector<ScanView> views = scan.views;
        for (size_t i = 0; i < views.size(); ++i) views[i].pose = scan.part_to_camera[i].inv();
        const PointCloud merged = merge_views(views);
        PointCloud thinned;
        for (size_t i = 0; i < merged.points.size(); i += 2) {
            thinned.points.push_back(merged.points[i]);
            thinned.normals.push_back(merged.normals[i]);
        }
        return band_surface(thinned, 0.3);
    }();
    return mesh;
}

// The cut of the mesh at height z that goes round the outline (the longest).
SectionPolyline outline_cut(double z) {
    SectionPolyline longest;
    for (SectionPolyline& cut : cut_mesh(scan_mesh(), {0, 0, z}, {1, 0, 0}, {0, 1, 0}))
        if (cut.points.size() > longest.points.size()) longest = std::move(cut);
    return longest;
}

// Each fitted line against the side of the outline it runs along: the largest angle error, or
// a failure when a line matches no side or two lines match one.
double worst_angle_error_deg(const SectionFit& fit) {
    double worst = 0;
    std::vector<int> matched(kOutline.size(), 0);
    for (const SectionElement& e : fit.elements) {
        const double fitted = direction_deg(e.start, e.end);
        size_t side = kOutline.size();
        for (size_t k = 0; k < kOutline.size(); ++k) {
            const double truth = direction_deg(kOutline[k], kOutline[(k + 1) % kOutline.size()]);
            if (angle_error_deg(fitted, truth) < 2 && cv::norm(0.5 * (e.start + e.end) - 0.5 * (kOutline[k] + kOutline[(k + 1) % kOutline.size()])) < 3)
                side = k;
        }
        if (side == kOutline.size()) {
            ADD_FAILURE() << "a line from (" << e.start[0] << ", " << e.start[1] << ") to (" << e.end[0] << ", " << e.end[1]
                          << ") runs along no side of the outline";
            continue;
        }
        ++matched[side];
        worst = std::max(worst, angle_error_deg(fitted, direction_deg(kOutline[side], kOutline[(side + 1) % kOutline.size()])));
    }
    for (size_t k = 0; k < kOutline.size(); ++k) EXPECT_EQ(matched[k], 1) << "side " << k;
    return worst;
}

}  // namespace

TEST(SectionFitScan, OutlineCutsAreFiveLinesAtTheRightAngles) {
    for (const double z : {4.0, 9.0, 12.0, 15.0, 20.0}) {
        const SectionPolyline cut = outline_cut(z);
        // Where the mesh has a hole the cut is one open chain round the outline: its gap is bridged.
        const double gap = cut.closed ? 0 : cv::norm(cut.points.front() - cut.points.back());
        ASSERT_LT(gap, 3) << "z = " << z;
        const SectionFit fit = fit_section(cut.points, true);
        const double worst = fit.elements.size() == 5 ? worst_angle_error_deg(fit) : 180;
        std::printf("z = %4.1f mm: %zu points, gap %.2f mm, noise %.4f mm, tolerance %.4f mm, %zu elements, worst line angle %.4f deg\n",
                    z, cut.points.size(), gap, fit.noise_mm, fit.tolerance_mm, fit.elements.size(), worst);
        EXPECT_EQ(count(fit, SectionElementKind::Line), 5) << "z = " << z;
        EXPECT_EQ(fit.elements.size(), 5u) << "z = " << z;
        EXPECT_LT(worst, 0.1) << "z = " << z;  // one cut: see the band fit below for 0.05
    }

    std::vector<std::vector<cv::Vec2d>> parallel;
    for (double z = 4; z <= 20.01; z += 1) {
        if (std::abs(z - 12) < 0.01) continue;
        parallel.push_back(outline_cut(z).points);
    }
    const SectionPolyline cut = outline_cut(12);
    const SectionFit fit = fit_extruded_section(cut.points, true, parallel);
    ASSERT_EQ(fit.elements.size(), 5u);
    EXPECT_EQ(count(fit, SectionElementKind::Line), 5);
    const double worst = worst_angle_error_deg(fit);
    std::printf("band of 17 cuts (z = 4 .. 20 mm): 5 lines, worst angle %.4f deg\n", worst);
    EXPECT_LT(worst, 0.05);

    // Built to fool it: the cut with a 3 mm gap at the chamfer's corner (no point shows where the
    // sides meet), and the cut opened at a corner (an open chain, its ends at the corner).
    std::vector<cv::Vec2d> gapped, opened;
    for (const cv::Vec2d& p : cut.points)
        if (cv::norm(p - cv::Vec2d(25, 10)) > 1.5) gapped.push_back(p);
    size_t corner = 0;
    for (size_t i = 0; i < cut.points.size(); ++i)
        if (cv::norm(cut.points[i] - kOutline[0]) < cv::norm(cut.points[corner] - kOutline[0])) corner = i;
    for (size_t i = 0; i < cut.points.size(); ++i) opened.push_back(cut.points[(corner + i) % cut.points.size()]);
    for (const auto& [name, points, closed] : {std::tuple{"gap at a corner", gapped, true}, std::tuple{"open chain", opened, false}}) {
        const SectionFit fooled = fit_section(points, closed);
        const double worst_fooled = fooled.elements.size() == 5 ? worst_angle_error_deg(fooled) : 180;
        std::printf("%s: %zu points, %zu elements, worst angle %.4f deg\n", name, points.size(), fooled.elements.size(), worst_fooled);
        for (const auto& e : fooled.elements)
            std::printf("  %s n=%d (%.3f,%.3f)->(%.3f,%.3f) r=%.3f rms %.4f\n", to_string(e.kind).c_str(), e.point_count, e.start[0], e.start[1], e.end[0], e.end[1], e.radius_mm, e.rms_mm);
        EXPECT_EQ(count(fooled, SectionElementKind::Line), 5) << name;
        EXPECT_EQ(fooled.elements.size(), 5u) << name;
        EXPECT_LT(worst_fooled, 0.1) << name;
    }

    // Measured, not asserted: the hole (10 mm, centre (-11, 0), 24 mm deep) is seen from the
    // turntable only in slivers, open arcs of a few mm whose radius is known to a tenth of a mm.
    for (const double z : {4.0, 9.0, 12.0, 15.0, 20.0}) {
        for (const SectionPolyline& piece : cut_mesh(scan_mesh(), {0, 0, z}, {1, 0, 0}, {0, 1, 0})) {
            if (piece.points.size() < 20 || cv::norm(piece.points[0] - cv::Vec2d(-11, 0)) > 7) continue;
            try {
                const SectionFit hole = fit_section(piece.points, piece.closed);
                for (const auto& e : hole.elements)
                    std::printf("hole z=%.0f: %zu pts noise %.4f tol %.4f: %s r=%.4f c=(%.4f,%.4f) n=%d rms %.4f\n", z,
                                piece.points.size(), hole.noise_mm, hole.tolerance_mm, to_string(e.kind).c_str(),
                                e.radius_mm, e.centre[0], e.centre[1], e.point_count, e.rms_mm);
            } catch (const std::exception& error) {
                std::printf("hole z=%.0f: %s\n", z, error.what());
            }
        }
    }
}
