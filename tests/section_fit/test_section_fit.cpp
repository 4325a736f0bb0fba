// Fitted sections: outlines sampled from known lines and arcs, with the noise of a scan, must
// come back as the same number of lines and arcs, with angles within 0.05 degrees and radii
// within 20 um; constraints are proposed only where the points allow them.
#include "picoscan/cloud.h"
#include "picoscan/error.h"
#include "picoscan/section_fit.h"
#include "picoscan/simulate.h"
#include "section_counts.h"
#include "support/test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <tuple>
#include <cstdio>
#include <map>
#include <random>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A polyline built from lines and arcs, sampled every `spacing` mm, with Gaussian noise across it.
struct Outline {
    std::vector<cv::Vec2d> points;
    std::mt19937 random{5};
    std::normal_distribution<double> noise;
    double spacing;
    Outline(double sigma_mm, double spacing_mm) : noise(0.0, sigma_mm > 0 ? sigma_mm : 1e-12), spacing(spacing_mm) {}
    void line(cv::Vec2d a, cv::Vec2d b) {
        const int steps = std::max(1, int(std::round(cv::norm(b - a) / spacing)));
        const cv::Vec2d along = (b - a) / cv::norm(b - a), across(-along[1], along[0]);
        for (int i = 0; i < steps; ++i) points.push_back(a + (b - a) * (double(i) / steps) + noise(random) * across);
    }
    void arc(cv::Vec2d centre, double radius, double from_deg, double to_deg) {
        const double sweep = (to_deg - from_deg) * kPi / 180;
        const int steps = std::max(2, int(std::round(std::abs(sweep) * radius / spacing)));
        for (int i = 0; i < steps; ++i) {
            const double angle = from_deg * kPi / 180 + sweep * i / steps;
            const cv::Vec2d radial(std::cos(angle), std::sin(angle));
            points.push_back(centre + (radius + noise(random)) * radial);
        }
    }
};

// The demo part's outline at mid height: a 50 x 36 block with its (+x, +y) corner chamfered 8 mm.
const std::vector<cv::Vec2d> kDemoCorners = {{-25, -18}, {25, -18}, {25, 10}, {17, 18}, {-25, 18}};

std::vector<cv::Vec2d> rotated(const std::vector<cv::Vec2d>& points, double degrees) {
    const double c = std::cos(degrees * kPi / 180), s = std::sin(degrees * kPi / 180);
    std::vector<cv::Vec2d> result;
    for (const auto& p : points) result.emplace_back(c * p[0] - s * p[1], s * p[0] + c * p[1]);
    return result;
}

double direction_deg(const cv::Vec2d& a, const cv::Vec2d& b) { return std::atan2(b[1] - a[1], b[0] - a[0]) * 180 / kPi; }

double angle_error_deg(double a, double b) {
    double d = std::fmod(std::abs(a - b), 180.0);
    return std::min(d, 180 - d);
}

}  // namespace

TEST(SectionFit, DemoOutlineGivesFiveLinesAtTheRightAngles) {
    for (const double sigma : {0.0, 0.01, 0.02, 0.04}) {
        for (const double turn : {0.0, 17.0}) {
            Outline outline(sigma, 0.3);
            const auto corners = rotated(kDemoCorners, turn);
            for (size_t i = 0; i < corners.size(); ++i) outline.line(corners[i], corners[(i + 1) % corners.size()]);
            // Start in the middle of a side: the fit must find the corners, not take the first point as one.
            std::rotate(outline.points.begin(), outline.points.begin() + 40, outline.points.end());
            const SectionFit fit = fit_section(outline.points, true);
            SCOPED_TRACE("sigma " + std::to_string(sigma) + " turn " + std::to_string(turn));
            ASSERT_EQ(fit.elements.size(), 5u);
            EXPECT_EQ(count(fit, SectionElementKind::Line), 5);
            if (sigma > 0) {
                EXPECT_NEAR(fit.noise_mm, sigma, 0.3 * sigma);
            }
            for (const auto& e : fit.elements) {
                // Which true side: the one whose corners the element's ends are nearest to.
                double angle_error = HUGE_VAL, corner_error = HUGE_VAL, length = 0;
                for (size_t i = 0; i < corners.size(); ++i) {
                    const cv::Vec2d a = corners[i], b = corners[(i + 1) % corners.size()];
                    const double error = std::max(cv::norm(e.start - a), cv::norm(e.end - b));
                    if (error < corner_error) {
                        corner_error = error;
                        angle_error = angle_error_deg(direction_deg(e.start, e.end), direction_deg(a, b));
                        length = cv::norm(b - a);
                    }
                }
                // 0.05 degrees, or 4 standard errors of a least-squares direction from n points
                // sigma apart from the line over its length L: sigma / (L sqrt(n / 12)) radians.
                const double points = length / 0.3;
                const double bound = std::max(0.05, 4 * sigma / (length * std::sqrt(points / 12)) * 180 / kPi);
                EXPECT_LT(angle_error, bound) << "side of " << length << " mm";
                if (sigma <= 0.01) {
                    EXPECT_LT(angle_error, 0.05);
                }
                EXPECT_LT(corner_error, 0.05 + 3 * sigma);  // the corners are the lines' intersections
                EXPECT_LE(e.max_mm, fit.tolerance_mm);
            }
            // Horizontal/vertical only when the outline is not turned; perpendicular and parallel always.
            EXPECT_EQ(count(fit, SectionConstraintKind::Horizontal), turn == 0 ? 2 : 0);
            EXPECT_EQ(count(fit, SectionConstraintKind::Vertical), turn == 0 ? 2 : 0);
            EXPECT_EQ(count(fit, SectionConstraintKind::Parallel), 2);
            EXPECT_EQ(count(fit, SectionConstraintKind::Perpendicular), 4);
        }
    }
}

TEST(SectionFit, HoleIsOneCircleWithinTwentyMicrons) {
    for (const double sigma : {0.0, 0.02, 0.04}) {
        Outline outline(sigma, 0.3);
        outline.arc({-11, 0}, 5, 0, 360);
        const SectionFit fit = fit_section(outline.points, true);
        ASSERT_EQ(fit.elements.size(), 1u);
        const auto& circle = fit.elements[0];
        EXPECT_EQ(circle.kind, SectionElementKind::Circle);
        EXPECT_NEAR(circle.radius_mm, 5.0, 0.02);
        EXPECT_NEAR(circle.centre[0], -11, 0.02);
        EXPECT_NEAR(circle.centre[1], 0, 0.02);
        EXPECT_TRUE(circle.counter_clockwise);
    }
}

TEST(SectionFit, SlotAndRoundedRectangleGiveTangentArcsOfEqualRadius) {
    for (const double sigma : {0.0, 0.02}) {
        // A slot: two 40 mm lines joined by half circles of radius 6.
        Outline slot(sigma, 0.25);
        slot.line({0, -6}, {40, -6});
        slot.arc({40, 0}, 6, -90, 90);
        slot.line({40, 6}, {0, 6});
        slot.arc({0, 0}, 6, 90, 270);
        SectionFit fit = fit_section(slot.points, true);
        ASSERT_EQ(fit.elements.size(), 4u) << "sigma " << sigma;
        EXPECT_EQ(count(fit, SectionElementKind::Arc), 2);
        for (const auto& e : fit.elements) {
            EXPECT_TRUE(e.tangent_to_next);
            if (e.kind == SectionElementKind::Arc) {
                EXPECT_NEAR(e.radius_mm, 6.0, 0.02);
            }
        }
        EXPECT_EQ(count(fit, SectionConstraintKind::EqualRadius), 1);
        EXPECT_EQ(count(fit, SectionConstraintKind::Horizontal), 2);

        // A 60 x 30 rectangle with 4 mm fillets, run clockwise.
        Outline rounded(sigma, 0.25);
        rounded.line({0, 4}, {0, 26});
        rounded.arc({4, 26}, 4, 180, 90);
        rounded.line({4, 30}, {56, 30});
        rounded.arc({56, 26}, 4, 90, 0);
        rounded.line({60, 26}, {60, 4});
        rounded.arc({56, 4}, 4, 0, -90);
        rounded.line({56, 0}, {4, 0});
        rounded.arc({4, 4}, 4, -90, -180);
        fit = fit_section(rounded.points, true);
        ASSERT_EQ(fit.elements.size(), 8u) << "sigma " << sigma;
        EXPECT_EQ(count(fit, SectionElementKind::Arc), 4);
        for (const auto& e : fit.elements) {
            EXPECT_TRUE(e.tangent_to_next);
            if (e.kind == SectionElementKind::Arc) {
                // 25 points on a 90 degree fillet: with 20 um of noise its radius is known to about
                // 15 um (one standard error), so the bound is 4 of them.
                EXPECT_NEAR(e.radius_mm, 4.0, sigma > 0 ? 0.06 : 1e-6);
                EXPECT_FALSE(e.counter_clockwise);
            }
        }
        EXPECT_EQ(count(fit, SectionConstraintKind::EqualRadius), 6);  // every pair of the four
    }
}

TEST(SectionFit, OpenProfileAndSnapsOnlyWithinTolerance) {
    Outline profile(0.01, 0.3);
    // An L, its long leg 1 degree off horizontal (within the snap window): 50 mm at 1 degree is
    // 0.87 mm of rise, far more than the tolerance, so it must not be made horizontal, nor
    // perpendicular to the vertical leg.
    const double rise = 50 * std::tan(1.0 * kPi / 180);
    profile.line({0, 20}, {0, 0});
    profile.line({0, 0}, {50, rise});
    profile.points.push_back({50, rise});
    const SectionFit fit = fit_section(profile.points, false);
    ASSERT_EQ(fit.elements.size(), 2u);
    EXPECT_FALSE(fit.closed);
    EXPECT_LT(fit.tolerance_mm, 0.1);
    EXPECT_EQ(count(fit, SectionConstraintKind::Vertical), 1);
    EXPECT_EQ(count(fit, SectionConstraintKind::Horizontal), 0);
    EXPECT_EQ(count(fit, SectionConstraintKind::Perpendicular), 0);
    EXPECT_NEAR(direction_deg(fit.elements[1].start, fit.elements[1].end), 1.0, 0.05);
    EXPECT_NEAR(fit.elements[0].end[0], 0, 0.02);
    EXPECT_NEAR(fit.elements[0].end[1], 0, 0.02);
}

TEST(SectionFit, APolygonIsNotMistakenForACircle) {
    // A regular 12-gon of radius 20: its sides bulge 0.68 mm from the circle, far beyond the tolerance.
    Outline polygon(0.01, 0.2);
    for (int i = 0; i < 12; ++i) {
        const double a = 2 * kPi * i / 12, b = 2 * kPi * (i + 1) / 12;
        polygon.line({20 * std::cos(a), 20 * std::sin(a)}, {20 * std::cos(b), 20 * std::sin(b)});
    }
    const SectionFit fit = fit_section(polygon.points, true);
    EXPECT_EQ(fit.elements.size(), 12u);
    EXPECT_EQ(count(fit, SectionElementKind::Line), 12);
}

namespace {
// A regular polygon of `sides` round the origin (corners at `radius`) cut with `per_side` points a
// side (its first corner and points evenly along it), each `sigma` across the side at random.
std::vector<cv::Vec2d> polygon_cut(int sides, double radius, int per_side, double sigma, unsigned seed) {
    std::mt19937 random(seed);
    std::normal_distribution<double> noise;
    std::vector<cv::Vec2d> points;
    for (int k = 0; k < sides; ++k) {
        const cv::Vec2d a = radius * cv::Vec2d(std::cos(2 * kPi * k / sides), std::sin(2 * kPi * k / sides));
        const cv::Vec2d b = radius * cv::Vec2d(std::cos(2 * kPi * (k + 1) / sides), std::sin(2 * kPi * (k + 1) / sides));
        const cv::Vec2d across = cv::Vec2d(a[1] - b[1], b[0] - a[0]) / cv::norm(b - a);
        for (int i = 0; i < per_side; ++i) points.push_back(a + (b - a) * (double(i) / per_side) + sigma * noise(random) * across);
    }
    return points;
}
}  // namespace

// Built to fool the noise estimate: a 12-sided prism cut with one point in the middle of each side
// (24 points, r 10 mm) came back as one circle. Every run of 9 points took in 4 corners, which read
// as 0.23 mm of noise, and the circle passed within 5 x that. Polygons of 6, 8, 12 and 16 sides
// (sides of 3.9-20 mm), sparse (2 or 3 points a side) and dense (5, 20), with and without noise:
// never a circle or arc. Dense, they are their lines; sparse, a side of 3 points (its corners and
// middle) is too few for a line (min_line_points), so the fit is refused, saying so. The estimate
// itself sees the noise, not the corners.
TEST(SectionFit, APolygonsCornersAreNoNoiseSparseOrDense) {
    double worst_noise_free = 0;
    for (const int sides : {6, 8, 12, 16})
        for (const double radius : {10.0, 20.0})
            for (const int per_side : {2, 3, 5, 20})
                for (const double sigma : {0.0, 0.002, 0.01}) {
                    SCOPED_TRACE(std::to_string(sides) + " sides, r " + std::to_string(radius) + ", " + std::to_string(per_side) +
                                 " points a side, sigma " + std::to_string(sigma));
                    const std::vector<cv::Vec2d> points = polygon_cut(sides, radius, per_side, sigma, unsigned(sides + per_side));
                    SectionFit fit;
                    const std::string why = test_support::error_of([&] { fit = fit_section(points, true); });
                    EXPECT_EQ(count(fit, SectionElementKind::Circle) + count(fit, SectionElementKind::Arc), 0);
                    if (per_side >= 5) {
                        EXPECT_EQ(why, "");
                        EXPECT_EQ(count(fit, SectionElementKind::Line), sides);
                        EXPECT_LT(fit.noise_mm, 1.7 * sigma + 1e-6);
                        if (sigma == 0) worst_noise_free = std::max(worst_noise_free, fit.noise_mm);
                    } else {
                        // 2 a side: no line of min_line_points starts anywhere; 3: the one that does is off its points.
                        EXPECT_EQ(why.rfind(per_side == 2 ? "polyline: no line of 4 points or more (min_line_points)" : "polyline: ", 0), 0u) << why;
                    }
                }
    EXPECT_LT(worst_noise_free, 1e-6);
    // The case of the issue: the noise seen is the cut's own, not the corners'.
    SectionFitOptions given;
    given.tolerance_mm = 0.05;
    for (const double sigma : {0.0, 0.002, 0.01}) {
        const std::vector<cv::Vec2d> sparse = polygon_cut(12, 10, 2, sigma, 3);
        std::vector<SectionPolyline> polylines{{sparse, true}};
        std::string why = test_support::error_of([&] { fit_section_polylines(polylines, {}, SectionFitOptions{}); });
        EXPECT_NE(why, "");  // too few points a side for lines; never a circle
        // Noise-free: below 1e-6 (was 0.23 mm); with noise: within 40 % of it.
        const double noise = [&] {
            SectionFitOptions options;
            options.tolerance_mm = 10;  // the noise is still measured; a tolerance this loose fits anything
            return fit_section(sparse, true, options).noise_mm;
        }();
        std::printf("12-gon of 24 points, sigma %.3f: noise %.4f mm; %s\n", sigma, noise, why.c_str());
        EXPECT_LT(noise, sigma == 0 ? 1e-6 : 1.4 * sigma);
        // A tolerance set by the user below the polygon's bulge from its circle: still no circle.
        SectionFit loose;
        why = test_support::error_of([&] { loose = fit_section(sparse, true, given); });
        EXPECT_EQ(why.rfind("polyline: ", 0), 0u) << why;
        EXPECT_EQ(count(loose, SectionElementKind::Circle), 0);
    }
}

// The other side of it: a true circle sampled as sparsely (24 points, r 10 mm) stays one circle, of
// its radius, with or without noise, whatever the seed; its noise is read, not its sagitta.
TEST(SectionFit, ASparseCircleStaysACircle) {
    int circles = 0, cases = 0;
    double worst_radius = 0;
    for (const int n : {24, 48})
        for (const double sigma : {0.0, 0.002, 0.01})
            for (unsigned seed = 1; seed <= 10; ++seed) {
                std::mt19937 random(seed);
                std::normal_distribution<double> noise;
                std::vector<cv::Vec2d> points;
                for (int i = 0; i < n; ++i)
                    points.push_back((10 + sigma * noise(random)) * cv::Vec2d(std::cos(2 * kPi * i / n), std::sin(2 * kPi * i / n)));
                SectionFit fit;
                const std::string why = test_support::error_of([&] { fit = fit_section(points, true); });
                ++cases;
                if (!why.empty() || fit.elements.size() != 1 || fit.elements[0].kind != SectionElementKind::Circle) continue;
                ++circles;
                worst_radius = std::max(worst_radius, std::abs(fit.elements[0].radius_mm - 10));
                if (sigma > 0) {
                    EXPECT_GT(fit.noise_mm, 0.5 * sigma);
                }
            }
    std::printf("sparse circles: %d of %d one circle, radius within %.4f mm\n", circles, cases, worst_radius);
    EXPECT_EQ(circles, cases);
    EXPECT_LT(worst_radius, 0.01);
}

TEST(SectionFit, RefusesBadInput) {
    const auto message = [](const std::vector<cv::Vec2d>& points, double tolerance) {
        SectionFitOptions options;
        options.tolerance_mm = tolerance;
        try {
            fit_section(points, true, options);
        } catch (const Error& error) {
            return std::string(error.what());
        }
        return std::string("no error");
    };
    EXPECT_EQ(message({{0, 0}, {1, 0}, {1, 1}}, 0), "polyline: needs at least 4 distinct points, has 3");
    EXPECT_EQ(message({{0, 0}, {1, 0}, {1, 0}, {1, 1}, {0, 0}}, 0), "polyline: needs at least 4 distinct points, has 3");
    EXPECT_EQ(message({{0, 0}, {1, 0}, {NAN, 1}, {0, 1}}, 0), "polyline: has a non-finite point");
    EXPECT_EQ(message({{0, 0}, {1, 0}, {1, 1}, {0, 1}}, -1), "tolerance_mm: must be 0 (from the noise) or positive");
}

// A prismatic outline cut 33 times (independent noise per cut): refitted with the 32 parallel
// cuts, every side's direction is within 0.05 degrees up to 40 um of noise, where one cut of the
// 11 mm chamfer is not; a hole stays one circle, its radius within 5 um; a 3 mm fillet within 0.1 mm.
// A parallel cut of another profile (the outline 0.5 mm higher: where a part is not prismatic)
// adds nothing but the points that lie on the outline's own sides.
TEST(SectionFit, ExtrudedOutlineRefitsEveryElementWithTheParallelCuts) {
    const auto outline_with_fillet_and_hole = [](double sigma, unsigned seed, double raise) {
        Outline outline(sigma, 0.3);
        outline.random.seed(seed);
        const double r = 3;  // the fillet at (-25, -18)
        outline.line({-25 + r, -18}, {25, -18});
        outline.line({25, -18}, {25, 10});
        outline.line({25, 10}, {17, 18});
        outline.line({17, 18}, {-25, 18});
        outline.line({-25, 18}, {-25, -18 + r});
        outline.arc({-25 + r, -18 + r}, r, 180, 270);
        Outline hole(sigma, 0.3);
        hole.random.seed(seed + 1000);
        hole.arc({-11, 0}, 5, 0, 360);
        for (auto& p : outline.points) p[1] += raise;
        for (auto& p : hole.points) p[1] += raise;
        return std::pair{outline.points, hole.points};
    };
    const std::vector<std::pair<cv::Vec2d, cv::Vec2d>> sides = {
        {{-22, -18}, {25, -18}}, {{25, -18}, {25, 10}}, {{25, 10}, {17, 18}}, {{17, 18}, {-25, 18}}, {{-25, 18}, {-25, -15}}};
    double single_chamfer_error = 0;
    for (const double sigma : {0.01, 0.02, 0.04}) {
        SCOPED_TRACE("sigma " + std::to_string(sigma));
        const auto [outline, hole] = outline_with_fillet_and_hole(sigma, 1, 0);
        std::vector<ParallelCut> parallel;  // 0.2 mm apart
        for (unsigned cut = 2; cut <= 33; ++cut) {
            const auto [other_outline, other_hole] = outline_with_fillet_and_hole(sigma, cut, 0);
            parallel.push_back({0.2 * (cut - 1), other_outline});
            parallel.push_back({0.2 * (cut - 1), other_hole});
        }
        const auto [raised_outline, raised_hole] = outline_with_fillet_and_hole(sigma, 99, 0.5);
        parallel.push_back({6.6, raised_outline});
        parallel.push_back({6.6, raised_hole});
        const SectionFit fit = fit_extruded_section(outline, true, parallel);
        ASSERT_EQ(fit.elements.size(), 6u);
        EXPECT_EQ(count(fit, SectionElementKind::Line), 5);
        EXPECT_EQ(count(fit, SectionElementKind::Arc), 1);
        for (const auto& e : fit.elements) {
            if (e.kind == SectionElementKind::Arc) {
                // The fillet is fitted with its tangent lines as one curve: where its 16 points per cut
                // are split from the lines' no longer biases the radius (fitted alone: +62 to +72 um).
                std::printf("extruded outline, noise %.2f mm: fillet radius error %+.4f mm, centre off by %.4f mm\n", sigma,
                            e.radius_mm - 3.0, cv::norm(e.centre - cv::Vec2d(-22, -15)));
                EXPECT_NEAR(e.radius_mm, 3.0, 0.01);
                EXPECT_LT(cv::norm(e.centre - cv::Vec2d(-22, -15)), 0.01);
                continue;
            }
            double error = HUGE_VAL;
            for (const auto& [a, b] : sides)
                if (cv::norm(e.end - b) < 0.5) error = angle_error_deg(direction_deg(e.start, e.end), direction_deg(a, b));
            ASSERT_LT(error, HUGE_VAL) << "no side ends at " << e.end;
            EXPECT_LT(error, 0.05) << "line from " << e.start << " to " << e.end;
        }
        const SectionFit circle = fit_extruded_section(hole, true, parallel);
        ASSERT_EQ(circle.elements.size(), 1u);
        EXPECT_EQ(circle.elements[0].kind, SectionElementKind::Circle);
        EXPECT_NEAR(circle.elements[0].radius_mm, 5.0, 0.005);
        if (sigma == 0.04) {
            for (const auto& e : fit_section(outline, true).elements)
                if (e.kind == SectionElementKind::Line && cv::norm(e.end - cv::Vec2d(17, 18)) < 0.5)
                    single_chamfer_error = angle_error_deg(direction_deg(e.start, e.end), 135.0);
        }
    }
    // The reason for the parallel cuts: one cut alone misses 0.05 degrees on the chamfer at 40 um.
    EXPECT_GT(single_chamfer_error, 0.05);
}

// A fillet between tangent lines, fitted with them as one curve, whatever the noise and however the
// points fall on the arc; and inputs built to fool the arc finder: a sharp corner (no arc, however
// the noise falls at it) and a true small fillet (2 mm, 10 points on its arc, kept).
TEST(SectionFit, FilletIsFittedWithItsTangentLinesAndOnlyWhereThereIsOne) {
    const auto l_shape = [](double sigma, unsigned seed, double fillet, double spacing) {
        Outline outline(sigma, spacing);
        outline.random.seed(seed);
        // An L-shaped outline, all corners sharp but the one at (0, 0), rounded with `fillet`; the
        // spacing of the samples moves where they fall on the arc.
        outline.line({-20, 0}, {-fillet, 0});
        if (fillet > 0) outline.arc({-fillet, fillet}, fillet, 270, 360);
        outline.line({0, fillet}, {0, 20});
        outline.line({0, 20}, {-10, 20});
        outline.line({-10, 20}, {-10, 10});
        outline.line({-10, 10}, {-20, 10});
        outline.line({-20, 10}, {-20, 0});
        return outline.points;
    };
    double worst_single = 0, worst_parallel = 0;
    for (const double sigma : {0.01, 0.02}) {
        for (const double spacing : {0.28, 0.3, 0.32}) {
            SCOPED_TRACE("sigma " + std::to_string(sigma) + ", spacing " + std::to_string(spacing));
            const auto outline = l_shape(sigma, 3, 3.0, spacing);
            const SectionFit single = fit_section(outline, true);
            ASSERT_EQ(count(single, SectionElementKind::Arc), 1);
            std::vector<ParallelCut> parallel;
            for (unsigned cut = 4; cut < 20; ++cut) parallel.push_back({0.2 * (cut - 3), l_shape(sigma, cut, 3.0, spacing)});
            const SectionFit extruded = fit_extruded_section(outline, true, parallel);
            ASSERT_EQ(count(extruded, SectionElementKind::Arc), 1);
            for (const auto& [fit, worst] : {std::pair{&single, &worst_single}, std::pair{&extruded, &worst_parallel}})
                for (const auto& e : fit->elements)
                    if (e.kind == SectionElementKind::Arc) {
                        *worst = std::max(*worst, std::abs(e.radius_mm - 3.0));
                        EXPECT_TRUE(fit->elements[(&e - fit->elements.data() + fit->elements.size() - 1) % fit->elements.size()]
                                        .tangent_to_next);
                        EXPECT_TRUE(e.tangent_to_next);
                    }
        }
    }
    std::printf("fillet of 3 mm: radius error up to %.4f mm from one cut, %.4f mm with 16 parallel cuts\n", worst_single,
                worst_parallel);
    // One cut: 16 points on the arc, scattered (fitted alone, the arc was off by up to 0.15 mm here).
    EXPECT_LT(worst_single, 0.04);
    EXPECT_LT(worst_parallel, 0.01);  // 17 cuts (fitted alone and refitted: up to 0.044 mm)

    for (const double sigma : {0.0, 0.01, 0.02, 0.04}) {
        for (unsigned seed = 1; seed <= 5; ++seed) {
            SCOPED_TRACE("sigma " + std::to_string(sigma) + ", seed " + std::to_string(seed));
            const SectionFit sharp = fit_section(l_shape(sigma, seed, 0.0, 0.3), true);
            EXPECT_EQ(count(sharp, SectionElementKind::Arc), 0);
            EXPECT_EQ(count(sharp, SectionElementKind::Line), 6);
        }
    }
    for (const double sigma : {0.0, 0.005, 0.01}) {
        SCOPED_TRACE("sigma " + std::to_string(sigma));
        const SectionFit small = fit_section(l_shape(sigma, 7, 2.0, 0.3), true);
        ASSERT_EQ(count(small, SectionElementKind::Arc), 1);
        for (const auto& e : small.elements)
            if (e.kind == SectionElementKind::Arc) {
                EXPECT_NEAR(e.radius_mm, 2.0, 0.03);
            }
    }
}

// Stray points in the middle of a side (a burst of noise, a speck on the part): no line or arc of
// the minimum size fits where they start. They used to be handed, with every point after them, to
// the element before, which made one "line" across the rest of the outline with an RMS of
// millimetres. Now every returned line lies along a side of the outline (its RMS still counts the
// stray points it took), or the fit is refused with the reason.
TEST(SectionFit, StrayPointsNeverMakeALineAcrossCorners) {
    int fitted = 0;
    for (const double offset_mm : {0.1, 0.3, 1.0}) {
        Outline outline(0.005, 0.4);
        for (size_t k = 0; k < kDemoCorners.size(); ++k) outline.line(kDemoCorners[k], kDemoCorners[(k + 1) % kDemoCorners.size()]);
        const size_t middle = size_t(50 / 0.4) + size_t(14 / 0.4);  // halfway up the right side
        for (size_t i = middle; i < middle + 3; ++i) outline.points[i][0] += offset_mm;
        SectionFitOptions options;
        options.tolerance_mm = 0.03;
        try {
            const SectionFit fit = fit_section(outline.points, true, options);
            ++fitted;
            for (const SectionElement& e : fit.elements) {
                if (e.kind != SectionElementKind::Line) continue;
                EXPECT_LE(cv::norm(e.end - e.start), 50.1) << offset_mm;
                double error = 180;  // to the nearest true side
                for (size_t k = 0; k < kDemoCorners.size(); ++k)
                    error = std::min(error, angle_error_deg(direction_deg(e.start, e.end),
                                                            direction_deg(kDemoCorners[k], kDemoCorners[(k + 1) % kDemoCorners.size()])));
                EXPECT_LT(error, 0.05) << offset_mm;
            }
            EXPECT_GE(count(fit, SectionElementKind::Line), 5) << offset_mm;
        } catch (const Error& error) {
            EXPECT_NE(std::string(error.what()).find("tolerance"), std::string::npos) << error.what();
        }
    }
    std::printf("stray points: %d of 3 outlines fitted, the others refused\n", fitted);
}

// Inputs built to fool the joining of splits the points do not ask for (what makes a wavering
// side of a scan one line): a side that really bends by 1 degree stays two lines, and a 3 mm
// fillet on a wavering outline (noise, plus 20 um of waviness every 7 mm) stays one arc between
// two lines, never a run of short lines.
TEST(SectionFit, JoiningKeepsARealBendAndAWaveringFilletStaysOneArc) {
    const auto wavering = [](std::vector<cv::Vec2d> points, double amplitude, double period) {
        std::vector<cv::Vec2d> result = points;
        double along = 0;
        for (size_t i = 0; i < points.size(); ++i) {
            const cv::Vec2d& next = points[(i + 1) % points.size()];
            const cv::Vec2d& previous = points[(i + points.size() - 1) % points.size()];
            const cv::Vec2d tangent = (next - previous) / cv::norm(next - previous);
            if (i > 0) along += cv::norm(points[i] - points[i - 1]);
            result[i] += amplitude * std::sin(2 * kPi * along / period) * cv::Vec2d(-tangent[1], tangent[0]);
        }
        return result;
    };
    for (const unsigned seed : {1u, 2u, 3u}) {
        for (const double sigma : {0.01, 0.02}) {
            SCOPED_TRACE("seed " + std::to_string(seed) + ", sigma " + std::to_string(sigma));
            Outline bent(sigma, 0.3);
            bent.random.seed(seed);
            const double rise = 20 * std::tan(1.0 * kPi / 180);
            bent.line({-20, -10}, {0, -10});
            bent.line({0, -10}, {20, -10 + rise});
            bent.line({20, -10 + rise}, {20, 10});
            bent.line({20, 10}, {-20, 10});
            bent.line({-20, 10}, {-20, -10});
            const SectionFit fit = fit_section(bent.points, true);
            EXPECT_EQ(fit.elements.size(), 5u);
            EXPECT_EQ(count(fit, SectionElementKind::Line), 5);

            Outline filleted(sigma, 0.3);
            filleted.random.seed(seed);
            filleted.line({-20, 0}, {-3, 0});
            filleted.arc({-3, 3}, 3, 270, 360);
            filleted.line({0, 3}, {0, 20});
            filleted.line({0, 20}, {-20, 20});
            filleted.line({-20, 20}, {-20, 0});
            const SectionFit rounded = fit_section(wavering(filleted.points, 0.02, 7), true);
            ASSERT_EQ(count(rounded, SectionElementKind::Arc), 1);
            EXPECT_EQ(count(rounded, SectionElementKind::Line), 4);
            for (const auto& e : rounded.elements)
                if (e.kind == SectionElementKind::Arc) {
                    std::printf("wavering 3 mm fillet, sigma %.2f, seed %u: radius %.4f mm\n", sigma, seed, e.radius_mm);
                    EXPECT_NEAR(e.radius_mm, 3.0, 0.1);
                }
        }
    }
}

// A section's polylines judged as one (fit_section_polylines), with inputs built to fool a fit of
// each loop on its own: beside the demo outline, a crumb a Poisson surface leaves (35 points round
// 3.2 mm, 0.3 mm of noise: its own noise sets a tolerance of 1.5 mm, within which it is "a
// circle") and a 6-point crumb must be left out, each with its reason; a real 2 mm hole of 25
// points must be kept as one circle within 20 um. Leaving out the outline itself is an error.
// (What the rebuild from the simulated scan's Poisson mesh met at z = 12 mm: the hole's trace, 76
// points scattering by 0.087 mm, fitted with its own tolerance of 0.44 mm as an arc and a line.)
TEST(SectionFit, TheDefaultToleranceComesFromTheScansNoiseWhenGiven) {
    // A flattened mesh's cut: the demo outline without noise. From the cut alone the tolerance is
    // its 5 um floor; with the noise of the scan the mesh was made from, 5 x that.
    Outline outline(0.0, 0.3);
    for (size_t i = 0; i < kDemoCorners.size(); ++i) outline.line(kDemoCorners[i], kDemoCorners[(i + 1) % kDemoCorners.size()]);
    const std::vector<SectionPolyline> polylines = {{outline.points, true}};
    const SectionFits from_cut = fit_section_polylines(polylines);
    EXPECT_LT(from_cut.noise_mm, 1e-4);
    EXPECT_DOUBLE_EQ(from_cut.tolerance_mm, 0.005);
    SectionFitOptions options;
    options.scan_noise_mm = 0.02;
    const SectionFits from_scan = fit_section_polylines(polylines, {}, options);
    EXPECT_DOUBLE_EQ(from_scan.tolerance_mm, 0.1);
    EXPECT_DOUBLE_EQ(from_scan.noise_mm, from_cut.noise_mm);  // the cut's own, still reported
    ASSERT_EQ(from_scan.fits.size(), 1u);
    EXPECT_EQ(count(from_scan.fits[0], SectionElementKind::Line), 5);
    options.tolerance_mm = 0.04;  // a given tolerance wins
    EXPECT_DOUBLE_EQ(fit_section_polylines(polylines, {}, options).tolerance_mm, 0.04);
    options.scan_noise_mm = -0.01;
    EXPECT_THROW(fit_section_polylines(polylines, {}, options), Error);
}

TEST(SectionFit, ASectionLeavesOutCrumbsAndKeepsASmallRealHole) {
    for (const double sigma : {0.0, 0.01, 0.02}) {
        for (const unsigned seed : {1u, 2u, 3u}) {
            SCOPED_TRACE("sigma " + std::to_string(sigma) + ", seed " + std::to_string(seed));
            Outline outline(sigma, 0.3);
            outline.random.seed(seed);
            for (size_t i = 0; i < kDemoCorners.size(); ++i) outline.line(kDemoCorners[i], kDemoCorners[(i + 1) % kDemoCorners.size()]);
            Outline hole(sigma, 2 * kPi * 1.0 / 25);  // 2 mm across, 25 points
            hole.random.seed(seed + 10);
            hole.arc({8, -4}, 1.0, 0, 360);
            Outline blob(0.3, 2 * kPi * 3.2 / 35);
            blob.random.seed(seed + 20);
            blob.arc({-11, 2}, 3.2, 0, 360);
            Outline crumb(0.05, 0.2);
            crumb.random.seed(seed + 30);
            crumb.arc({0, 10}, 0.2, 0, 360);
            ASSERT_EQ(hole.points.size(), 25u);
            ASSERT_EQ(blob.points.size(), 35u);
            ASSERT_EQ(crumb.points.size(), 6u);
            // On its own, the blob is fitted as a circle with its own (large) tolerance: the defect.
            const SectionFit alone = fit_section(blob.points, true);
            EXPECT_EQ(alone.elements.size(), 1u);
            EXPECT_GT(alone.tolerance_mm, 0.5);

            const std::vector<SectionPolyline> polylines = {
                {outline.points, true}, {blob.points, true}, {hole.points, true}, {crumb.points, true}};
            const SectionFits section = fit_section_polylines(polylines);
            std::printf("section, sigma %.2f, seed %u: noise %.4f mm, tolerance %.4f mm\n", sigma, seed, section.noise_mm,
                        section.tolerance_mm);
            for (const LeftOutPolyline& left : section.left_out)
                std::printf("  left out %d (%d points): %s\n", left.index, left.point_count, left.reason.c_str());
            EXPECT_LE(section.tolerance_mm, std::max(0.005, 5 * 1.3 * sigma));
            ASSERT_EQ(section.fitted_index, (std::vector<int>{0, 2}));
            ASSERT_EQ(section.left_out.size(), 2u);
            EXPECT_EQ(section.left_out[0].index, 1);
            EXPECT_EQ(section.left_out[0].point_count, 35);
            EXPECT_NE(section.left_out[0].reason.find("scatter"), std::string::npos) << section.left_out[0].reason;
            EXPECT_LT(cv::norm(section.left_out[0].centre - cv::Vec2d(-11, 2)), 0.3);
            EXPECT_NEAR(section.left_out[0].across_mm, 6.4, 1.0);
            EXPECT_EQ(section.left_out[1].index, 3);
            EXPECT_EQ(section.left_out[1].point_count, 6);
            EXPECT_NE(section.left_out[1].reason.find("fewer points than the 16"), std::string::npos) << section.left_out[1].reason;

            const SectionFit& block = section.fits[0];
            EXPECT_EQ(block.elements.size(), 5u);
            EXPECT_EQ(count(block, SectionElementKind::Line), 5);
            EXPECT_EQ(block.tolerance_mm, section.tolerance_mm);
            const SectionFit& small = section.fits[1];
            ASSERT_EQ(small.elements.size(), 1u);
            EXPECT_EQ(small.elements[0].kind, SectionElementKind::Circle);
            EXPECT_NEAR(small.elements[0].radius_mm, 1.0, 0.02);
            EXPECT_NEAR(small.elements[0].centre[0], 8.0, 0.02);
            EXPECT_NEAR(small.elements[0].centre[1], -4.0, 0.02);
        }
    }
    // A mesher that flattens the sides (a sharpened Poisson mesh) leaves the section no noise: the
    // tolerance is min_tolerance_mm. A hole with 10 um of noise is still a measured hole (its
    // noise within loop_noise_limit_mm): kept, fitted with its own noise's tolerance, within 20
    // um; the blob beside it is still left out. With a tolerance set (0.05 mm) it is kept too,
    // and with one set below its noise (0.02 mm is 2 sigma) the user's tolerance holds.
    {
        Outline flat(0.0, 0.3);
        for (size_t i = 0; i < kDemoCorners.size(); ++i) flat.line(kDemoCorners[i], kDemoCorners[(i + 1) % kDemoCorners.size()]);
        Outline hole(0.01, 2 * kPi * 1.0 / 25);
        hole.arc({8, -4}, 1.0, 0, 360);
        Outline blob(0.3, 2 * kPi * 3.2 / 35);
        blob.arc({-11, 2}, 3.2, 0, 360);
        const std::vector<SectionPolyline> polylines = {{flat.points, true}, {hole.points, true}, {blob.points, true}};
        const SectionFits by_default = fit_section_polylines(polylines);
        EXPECT_EQ(by_default.tolerance_mm, SectionFitOptions().min_tolerance_mm);
        ASSERT_EQ(by_default.fitted_index, (std::vector<int>{0, 1}));
        ASSERT_EQ(by_default.fits[1].elements.size(), 1u);
        EXPECT_EQ(by_default.fits[1].elements[0].kind, SectionElementKind::Circle);
        EXPECT_NEAR(by_default.fits[1].elements[0].radius_mm, 1.0, 0.02);
        EXPECT_GT(by_default.fits[1].tolerance_mm, by_default.tolerance_mm);
        ASSERT_EQ(by_default.left_out.size(), 1u);
        EXPECT_EQ(by_default.left_out[0].index, 2);
        EXPECT_NE(by_default.left_out[0].reason.find("loop_noise_limit_mm"), std::string::npos) << by_default.left_out[0].reason;
        SectionFitOptions options;
        options.tolerance_mm = 0.05;
        const SectionFits set = fit_section_polylines(polylines, {}, options);
        ASSERT_EQ(set.fitted_index, (std::vector<int>{0, 1}));
        ASSERT_EQ(set.fits[1].elements.size(), 1u);
        EXPECT_NEAR(set.fits[1].elements[0].radius_mm, 1.0, 0.02);
        options.tolerance_mm = 0.008;
        const SectionFits tight = fit_section_polylines(polylines, {}, options);
        EXPECT_EQ(tight.fitted_index, (std::vector<int>{0}));
        EXPECT_EQ(tight.left_out.size(), 2u);
    }
    // The outline itself too noisy for the tolerance the user sets: an error, not a sketch of the rest.
    Outline outline(0.05, 0.3);
    for (size_t i = 0; i < kDemoCorners.size(); ++i) outline.line(kDemoCorners[i], kDemoCorners[(i + 1) % kDemoCorners.size()]);
    Outline hole(0.0, 0.3);
    hole.arc({-11, 0}, 5, 0, 360);
    SectionFitOptions tight;
    tight.tolerance_mm = 0.01;
    try {
        fit_section_polylines({{hole.points, true}, {outline.points, true}}, {}, tight);
        ADD_FAILURE() << "no error";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("the section's biggest polyline (" + std::to_string(outline.points.size()) + " points)"),
                  std::string::npos)
            << error.what();
    }
    EXPECT_THROW(fit_section_polylines({}), Error);
    // An open chain round the outline: a gap of 0.6 mm (a hole in a scan's mesh) is bridged, the
    // side it is in one line; a gap of 4.2 mm (above max_bridged_gap_mm) is not.
    for (const auto& [dropped, bridged] : {std::pair{1, true}, std::pair{13, false}}) {
        std::vector<cv::Vec2d> chain;
        for (size_t i = 0; i < outline.points.size(); ++i) {
            const cv::Vec2d& p = outline.points[(i + 60) % outline.points.size()];  // starts in the bottom side
            if (i + size_t(dropped) < outline.points.size()) chain.push_back(p);
        }
        const SectionFits fits = fit_section_polylines({{chain, false}});
        SCOPED_TRACE("gap of " + std::to_string(cv::norm(chain.front() - chain.back())) + " mm");
        ASSERT_EQ(fits.fits.size(), 1u);
        EXPECT_EQ(fits.fits[0].closed, bridged);
        EXPECT_EQ(fits.fits[0].elements.size(), bridged ? 5u : 6u);
    }
    for (const double bad : {-1.0, std::nan("")}) {
        SectionFitOptions options;
        options.loop_noise_limit_mm = bad;
        EXPECT_THROW(fit_section_polylines({{outline.points, true}}, {}, options), Error);
        options = {};
        options.max_bridged_gap_mm = bad;
        EXPECT_THROW(fit_section_polylines({{outline.points, true}}, {}, options), Error);
    }
}

// Real holes in a flattened mesh: the demo part's true mesh (its flat sides exact, so the
// section's tolerance is min_tolerance_mm), the rims of its 10 mm through hole moved by 15 um of
// radial noise per vertex (about 11 um across its wall at mid height) (what a scanned, meshed hole keeps), cut across Z at three heights. The
// hole must be one circle within 20 um; the 35-point blob of radius 3.21 mm (0.29 mm of noise)
// in the same section must be left out, with its reason.
TEST(SectionFit, AFlattenedMeshKeepsItsRealHoleAndLeavesOutTheBlob) {
    const MechanicalPartShape shape;
    Mesh part = mechanical_part(shape);
    std::mt19937 random(11);
    std::normal_distribution<float> noise(0.0f, 0.015f);
    const cv::Vec2f centre(float(shape.hole_centre_mm[0]), float(shape.hole_centre_mm[1]));
    std::map<std::tuple<float, float, float>, cv::Vec3f> moved;  // one move per position: the mesh stays joined
    for (cv::Vec3f& v : part.vertices) {
        const cv::Vec2f radial(v[0] - centre[0], v[1] - centre[1]);
        const float r = float(cv::norm(radial));
        if (std::abs(r - 5.0f) > 0.01f) continue;  // the wall's top and bottom rims (the top and bottom faces stay flat)
        const auto key = std::make_tuple(v[0], v[1], v[2]);
        if (!moved.count(key)) {
            const cv::Vec2f shifted = radial * ((r + noise(random)) / r);
            moved[key] = cv::Vec3f(centre[0] + shifted[0], centre[1] + shifted[1], v[2]);
        }
        v = moved[key];
    }
    for (const double z : {6.0, 12.0, 18.0}) {
        std::vector<SectionPolyline> polylines = cut_mesh(part, {0, 0, z}, {1, 0, 0}, {0, 1, 0});
        ASSERT_EQ(polylines.size(), 2u) << "z = " << z;
        Outline blob(0.29, 2 * kPi * 3.21 / 35);
        blob.random.seed(unsigned(z));
        blob.arc({10, 8}, 3.21, 0, 360);
        polylines.push_back({blob.points, true});
        const SectionFits section = fit_section_polylines(polylines);
        int lines = 0, circles = 0;
        for (const SectionFit& fit : section.fits) {
            lines += count(fit, SectionElementKind::Line);
            for (const SectionElement& e : fit.elements) {
                if (e.kind == SectionElementKind::Line) continue;
                ++circles;
                std::printf("flattened mesh, z = %4.1f mm: section tolerance %.4f mm, hole's own %.4f mm: %s of radius %.4f mm (%+.1f um), centre off by %.1f um\n",
                            z, section.tolerance_mm, fit.tolerance_mm, to_string(e.kind).c_str(), e.radius_mm,
                            1000 * (e.radius_mm - 5), 1000 * cv::norm(e.centre - shape.hole_centre_mm));
                EXPECT_EQ(e.kind, SectionElementKind::Circle);
                EXPECT_NEAR(e.radius_mm, 5.0, 0.02);
                EXPECT_LT(cv::norm(e.centre - shape.hole_centre_mm), 0.02);
            }
        }
        EXPECT_EQ(section.tolerance_mm, SectionFitOptions().min_tolerance_mm) << "z = " << z;
        EXPECT_EQ(lines, 5) << "z = " << z;
        EXPECT_EQ(circles, 1) << "z = " << z;
        ASSERT_EQ(section.left_out.size(), 1u) << "z = " << z;
        EXPECT_EQ(section.left_out[0].index, 2);
        EXPECT_EQ(section.left_out[0].point_count, 35);
        EXPECT_NE(section.left_out[0].reason.find("scatter"), std::string::npos) << section.left_out[0].reason;
    }
}

namespace {

// A side wall of a part as a scan's mesh gives it: the closed outline `loop(z)` (counter-clockwise,
// the same number of points at every height) at heights z0, z0 + dz, ... z1, joined row to row by
// triangles, every vertex moved along the outline's outward normal by Gaussian noise `sigma`.
Mesh lofted_wall(const std::function<std::vector<cv::Vec2d>(double)>& loop, double z0, double z1, double dz, double sigma,
                 unsigned seed) {
    Mesh mesh;
    std::mt19937 random(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    const int rows = int(std::lround((z1 - z0) / dz)) + 1;
    size_t columns = 0;
    for (int row = 0; row < rows; ++row) {
        const double z = z0 + row * dz;
        const std::vector<cv::Vec2d> points = loop(z);
        columns = points.size();
        for (size_t i = 0; i < columns; ++i) {
            const cv::Vec2d along = points[(i + 1) % columns] - points[(i + columns - 1) % columns];
            const cv::Vec2d outward = cv::Vec2d(along[1], -along[0]) / cv::norm(along);
            const cv::Vec2d p = points[i] + noise(random) * outward;
            mesh.vertices.emplace_back(float(p[0]), float(p[1]), float(z));
        }
    }
    for (int row = 0; row + 1 < rows; ++row)
        for (size_t i = 0; i < columns; ++i) {
            const int a = int(row * columns + i), b = int(row * columns + (i + 1) % columns);
            const int c = a + int(columns), d = b + int(columns);
            mesh.faces.emplace_back(a, b, d);
            mesh.faces.emplace_back(a, d, c);
        }
    return mesh;
}

// What the Cross-section command fits at height z: the cut and its Band (kSectionBandCuts more
// cuts over +-band, each with its offset), or the cut alone (band 0).
SectionFits band_section(const Mesh& mesh, double z, double band, const SectionFitOptions& options = {}) {
    const MeshSection section = cut_mesh_section(mesh, {0, 0, z}, {1, 0, 0}, {0, 1, 0}, band);
    return fit_section_polylines(section.polylines, section.parallel_cuts, options);
}

std::vector<cv::Vec2d> circle_loop(double radius, int count) {
    std::vector<cv::Vec2d> points;
    for (int i = 0; i < count; ++i) points.emplace_back(radius * std::cos(2 * kPi * i / count), radius * std::sin(2 * kPi * i / count));
    return points;
}

}  // namespace

// The Band on parts that are not prismatic, built to fool it: parallel cuts that follow an element
// within the tolerance but lie off it by amounts that change with their height. A sphere near its
// equator (radius 10 mm, cut 0.5 mm above it: the cuts below it are nearly the same size, those
// above smaller), a box whose sides are drafted by 2 degrees cut 1 mm above its bottom (the band
// reaches below the part: only the cuts above it, all smaller, follow it), and a cone of 3
// degrees cut 1 mm from its end; as a scan's mesh (vertices 0.1 mm apart in height, 10 um of
// noise), with the tolerance from the noise and with 0.1 mm set by the user. Each element must be
// fitted to its own cut only and say why (band_note), and so equal the single cut's fit within the
// tolerance, within 20 um of the true size at the cut's height. The same band without the check
// (band_trend_fraction huge) is printed: averaging the cuts put the sphere 27 um, the box's side 34
// um and the cone 21 um off the truth with the user's 0.1 mm (9, 7 and 0 um with the tolerance
// from the noise) when this was written.
TEST(SectionFit, BandFallsBackToTheCutWhereThePartIsNotPrismatic) {
    constexpr double kRadius = 10, kDraftDeg = 2, kConeDeg = 3;
    const double draft = std::tan(kDraftDeg * kPi / 180), cone_slope = std::tan(kConeDeg * kPi / 180);
    const auto sphere_radius = [&](double z) { return std::sqrt(kRadius * kRadius - z * z); };
    const auto cone_radius = [&](double z) { return 8 - z * cone_slope; };
    const auto box = [&](double z) {  // 40 x 30 mm at its bottom (z = 0)
        const double a = 20 - z * draft, b = 15 - z * draft;
        const cv::Vec2d corners[4] = {{-a, -b}, {a, -b}, {a, b}, {-a, b}};
        std::vector<cv::Vec2d> points;
        for (int k = 0; k < 4; ++k)
            for (int i = 0; i < 150; ++i) points.push_back(corners[k] + (corners[(k + 1) % 4] - corners[k]) * (i / 150.0));
        return points;
    };
    struct Case {
        const char* name;
        Mesh mesh;
        double z;
    };
    const Case cases[] = {
        {"sphere", lofted_wall([&](double z) { return circle_loop(sphere_radius(z), 360); }, -3.5, 4.5, 0.1, 0.01, 1), 0.5},
        {"drafted box", lofted_wall(box, 0, 5, 0.1, 0.01, 2), 1.0},
        {"cone", lofted_wall([&](double z) { return circle_loop(cone_radius(z), 360); }, 0, 5, 0.1, 0.01, 3), 1.0}};
    double worst_unchecked = 0;
    for (const double set_tolerance : {0.0, 0.1}) {
        for (const Case& c : cases) {
            SCOPED_TRACE(std::string(c.name) + ", tolerance set " + std::to_string(set_tolerance));
            SectionFitOptions options, unchecked;
            options.tolerance_mm = unchecked.tolerance_mm = set_tolerance;
            unchecked.band_trend_fraction = 1e9;
            const SectionFits single = band_section(c.mesh, c.z, 0, options);
            const SectionFits band = band_section(c.mesh, c.z, kDefaultSectionBandMm, options);
            const SectionFits averaged = band_section(c.mesh, c.z, kDefaultSectionBandMm, unchecked);
            ASSERT_EQ(band.fits.size(), 1u);
            ASSERT_EQ(single.fits.size(), 1u);
            ASSERT_EQ(averaged.fits.size(), 1u);
            const std::vector<SectionElement>& elements = band.fits[0].elements;
            ASSERT_EQ(elements.size(), single.fits[0].elements.size());
            ASSERT_EQ(elements.size(), averaged.fits[0].elements.size());
            // The error of an element against the truth at the cut's height: a circle's radius, a
            // line's distance from the true side (at its middle).
            const auto error = [&](const SectionElement& e) {
                if (e.kind != SectionElementKind::Line)
                    return e.radius_mm - (c.name[0] == 's' ? sphere_radius(c.z) : cone_radius(c.z));
                const cv::Vec2d middle = 0.5 * (e.start + e.end);
                const double a = 20 - c.z * draft, b = 15 - c.z * draft;
                return std::abs(e.end[0] - e.start[0]) < std::abs(e.end[1] - e.start[1]) ? std::abs(middle[0]) - a
                                                                                          : std::abs(middle[1]) - b;
            };
            for (size_t k = 0; k < elements.size(); ++k) {
                const SectionElement& e = elements[k];
                std::printf("%s at z = %.1f mm (tolerance %.4f mm): %s %+.1f um from the band, %+.1f um from one cut, %+.1f um "
                            "from the band unchecked (%d cuts); %s\n",
                            c.name, c.z, band.tolerance_mm, to_string(e.kind).c_str(), 1000 * error(e),
                            1000 * error(single.fits[0].elements[k]), 1000 * error(averaged.fits[0].elements[k]),
                            averaged.fits[0].elements[k].band_cuts, e.band_note.c_str());
                worst_unchecked = std::max(worst_unchecked, std::abs(error(averaged.fits[0].elements[k])));
                EXPECT_EQ(e.kind, single.fits[0].elements[k].kind);
                EXPECT_NEAR(error(e), 0.0, 0.020);
                EXPECT_NEAR(error(e), error(single.fits[0].elements[k]), band.tolerance_mm);
                if (averaged.fits[0].elements[k].band_cuts > 0) {  // cuts followed it: the check must have spoken
                    EXPECT_EQ(e.band_cuts, 0);
                    EXPECT_NE(e.band_note.find("not prismatic"), std::string::npos) << e.band_note;
                }
            }
        }
    }
    // The inputs do fool a band that does not check itself.
    EXPECT_GT(worst_unchecked, 0.020);
}

// cut_mesh_section is the section's cut and the Band's cuts at section_band_offsets, point for
// point as cut_mesh makes each (a tilted plane, so the offsets move along its normal), with the
// fit unchanged; it refuses a plane that misses or grazes the mesh, a negative band, and stops
// when told to.
TEST(SectionFit, CutMeshSectionIsTheCutAndItsBandInOneCall) {
    const Mesh part = mechanical_part();
    const double tilt = 10 * kPi / 180;
    const cv::Vec3d origin(1, 2, 12), u(std::cos(tilt), 0, std::sin(tilt)), v(0, 1, 0), normal = u.cross(v);
    const std::vector<double> offsets = section_band_offsets(2.0);
    ASSERT_EQ(offsets.size(), size_t(kSectionBandCuts));
    EXPECT_DOUBLE_EQ(offsets.front(), -2.0);
    EXPECT_DOUBLE_EQ(offsets.back(), 2.0);
    EXPECT_EQ(std::count(offsets.begin(), offsets.end(), 0.0), 0);
    EXPECT_TRUE(section_band_offsets(0).empty());

    std::vector<std::pair<double, std::string>> told;
    const MeshSection section = cut_mesh_section(part, origin, u, v, 2.0, [&](double fraction, const std::string& stage) {
        told.emplace_back(fraction, stage);
        return true;
    });
    const auto same = [](const std::vector<cv::Vec2d>& a, const std::vector<cv::Vec2d>& b) {
        return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](const cv::Vec2d& p, const cv::Vec2d& q) {
                   return p[0] == q[0] && p[1] == q[1];
               });
    };
    const std::vector<SectionPolyline> own = cut_mesh(part, origin, u, v);
    ASSERT_EQ(section.polylines.size(), own.size());
    ASSERT_EQ(own.size(), 2u);  // the outline and the hole
    for (size_t k = 0; k < own.size(); ++k) {
        EXPECT_TRUE(same(section.polylines[k].points, own[k].points)) << k;
        EXPECT_EQ(section.polylines[k].closed, own[k].closed);
    }
    std::vector<ParallelCut> expected;
    for (const double offset : offsets)
        for (SectionPolyline& cut : cut_mesh(part, origin + offset * normal, u, v)) expected.push_back({offset, cut.points});
    ASSERT_EQ(section.parallel_cuts.size(), expected.size());
    for (size_t k = 0; k < expected.size(); ++k) {
        EXPECT_EQ(section.parallel_cuts[k].offset_mm, expected[k].offset_mm);
        EXPECT_TRUE(same(section.parallel_cuts[k].points, expected[k].points)) << k;
    }
    const SectionFits one_call = fit_section_polylines(section.polylines, section.parallel_cuts);
    const SectionFits by_hand = fit_section_polylines(own, expected);
    ASSERT_EQ(one_call.fits.size(), by_hand.fits.size());
    for (size_t k = 0; k < by_hand.fits.size(); ++k) {
        ASSERT_EQ(one_call.fits[k].elements.size(), by_hand.fits[k].elements.size());
        for (size_t e = 0; e < by_hand.fits[k].elements.size(); ++e) {
            EXPECT_EQ(one_call.fits[k].elements[e].start, by_hand.fits[k].elements[e].start);
            EXPECT_EQ(one_call.fits[k].elements[e].band_cuts, by_hand.fits[k].elements[e].band_cuts);
        }
    }
    // Progress: from the section's cut to the parallel cuts, never backwards, within 0..1.
    ASSERT_FALSE(told.empty());
    EXPECT_EQ(told.front().second, "cutting the mesh");
    for (size_t k = 1; k < told.size(); ++k) EXPECT_GE(told[k].first, told[k - 1].first);
    EXPECT_LE(told.back().first, 1.0);

    // A plane above the part (32 mm high) and one that only touches a single triangle.
    EXPECT_NE(test_support::error_of([&] { cut_mesh_section(part, {0, 0, 40}, {1, 0, 0}, {0, 1, 0}); })
                  .find("plane: does not cut the mesh: the mesh lies from -40.00 mm to -8.00 mm"),
              std::string::npos);
    Mesh triangle;
    triangle.vertices = {{0, 0, -1}, {1, 0, 1}, {0, 1, 1}};
    triangle.faces = {{0, 1, 2}};
    EXPECT_NE(test_support::error_of([&] { cut_mesh_section(triangle, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}); }).find("plane: only grazes"),
              std::string::npos);
    EXPECT_NE(test_support::error_of([&] { cut_mesh_section(part, origin, u, v, -1); }).find("band_mm: must be 0"), std::string::npos);
    EXPECT_NE(test_support::error_of([&] { cut_mesh_section(part, origin, u, {0, 0, 1}); }).find("v_axis"), std::string::npos);
    // Cancelled in the parallel cuts.
    const std::string cancelled = test_support::error_of([&] {
        cut_mesh_section(part, origin, u, v, 2.0, [](double, const std::string& stage) { return stage != "parallel cuts"; });
    });
    EXPECT_EQ(cancelled.rfind("cancelled", 0), 0u) << cancelled;
}

// A NaN or infinite vertex made the plane "not cut" the mesh (or, in the CLI's default plane, a
// plane through NaN), and a vertex at 1e20 mm made it "only graze" it: the mesh is refused, naming
// the vertex.
TEST(SectionFit, AMeshWithANonFiniteOrFarVertexIsRefusedNamingIt) {
    const cv::Vec3d origin(1, 2, 12), u(1, 0, 0), v(0, 1, 0);
    for (const float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
        Mesh part = mechanical_part();
        part.vertices[5][1] = bad;
        EXPECT_NE(test_support::error_of([&] { cut_mesh_section(part, origin, u, v, 2.0); })
                      .find("mesh: vertex 5 is not a finite point (NaN or infinite)"),
                  std::string::npos);
    }
    Mesh far = mechanical_part();
    far.vertices[7][0] = 1e20f;
    const std::string refusal = test_support::error_of([&] { cut_mesh(far, origin, u, v); });
    EXPECT_NE(refusal.find("mesh: vertex 7 lies 1e+20 mm from the origin, beyond 1 km"), std::string::npos) << refusal;
    Mesh near = mechanical_part();
    near.vertices[7][0] = 9e5f;  // within 1 km: cut as before
    EXPECT_NO_THROW(cut_mesh(near, origin, u, v));
}

// A cut's loops run counter-clockwise around the material seen from the plane's normal (the
// outline positive, the hole negative), however the mesh stores its triangles: each triangle's
// corners rotated (FreeCAD's STL reader starts every triangle at its third corner) and the
// triangles shuffled. Before, the walk followed the first crossed triangle's corner order.
TEST(SectionFit, LoopsRunTheWayTheTrianglesWindWhateverTheirStorageOrder) {
    const Mesh part = mechanical_part();
    const auto signed_areas = [](const Mesh& mesh) {
        std::vector<double> areas;
        for (const SectionPolyline& loop : cut_mesh(mesh, {0, 0, 12}, {1, 0, 0}, {0, 1, 0})) {
            double twice = 0;
            for (size_t k = 0; k < loop.points.size(); ++k) {
                const cv::Vec2d& a = loop.points[k];
                const cv::Vec2d& b = loop.points[(k + 1) % loop.points.size()];
                twice += a[0] * b[1] - a[1] * b[0];
            }
            areas.push_back(twice / 2);
        }
        std::sort(areas.begin(), areas.end());
        return areas;
    };
    std::vector<Mesh> stored(3, part);
    for (auto& face : stored[1].faces) face = {face[2], face[0], face[1]};
    for (auto& face : stored[2].faces) face = {face[1], face[2], face[0]};
    std::mt19937 random(7);
    for (int shuffle = 0; shuffle < 4; ++shuffle) {
        stored.push_back(part);
        std::shuffle(stored.back().faces.begin(), stored.back().faces.end(), random);
    }
    for (size_t k = 0; k < stored.size(); ++k) {
        const std::vector<double> areas = signed_areas(stored[k]);
        ASSERT_EQ(areas.size(), 2u) << k;
        EXPECT_NEAR(areas[0], -kPi * 25, 0.5) << k;  // the hole, radius 5, clockwise
        EXPECT_GT(areas[1], 1000) << k;              // the outline, counter-clockwise
    }
}

// Cuts across the demo part's through hole, near its rim, leave short stubs of the top and
// bottom faces (0.37 mm at y = -2) at the open ends of the hole wall's chain. Merged into the
// wall's line they made one line 70 um off its points with a 5 um tolerance, reported as fitted.
// Not yet held: stubs of fewer points than a line needs stay in their neighbour's points (y = 4:
// a 0.24 mm stub of 10 points raises the wall's RMS to 64 um; the line itself is where it belongs).
TEST(SectionFit, EveryElementHoldsItsPointsWithinTheTolerance) {
    const MechanicalPartShape shape;
    const Mesh part = mechanical_part(shape);
    int checked = 0;
    for (const double y : {-4.5, -3.0, -2.0, -1.0, 0.5, 2.0}) {
        const std::vector<SectionPolyline> polylines = cut_mesh(part, {0, y, 0}, {1, 0, 0}, {0, 0, 1});
        const SectionFits section = fit_section_polylines(polylines);
        for (const SectionFit& fit : section.fits)
            for (const SectionElement& e : fit.elements) {
                ++checked;
                EXPECT_LE(e.rms_mm, fit.tolerance_mm)
                    << "y = " << y << ": " << to_string(e.kind) << " of " << e.point_count << " points from ("
                    << e.start[0] << ", " << e.start[1] << ") to (" << e.end[0] << ", " << e.end[1] << ")";
            }
    }
    EXPECT_GT(checked, 20);
}

// The cut of an outline whose 5 mm fillet is meshed with 8 chords (0.98 mm each), without noise, as
// cut_mesh gives it: points every 0.4 mm along the sides and each chord (its ends and its middle, where
// a cut crosses a facet's diagonal). The chords' ends lie at `radius(k)` from the fillet's centre
// (-20, -13); 5 mm for a true mesh of the fillet.
namespace {
std::vector<cv::Vec2d> faceted_fillet_outline(const std::function<double(int)>& radius) {
    std::vector<cv::Vec2d> corners = {{25, -18}, {25, 18}, {-25, 18}, {-25, -13}};
    for (int k = 1; k <= 8; ++k) {
        const double angle = kPi + kPi / 2 * k / 8;
        corners.push_back(cv::Vec2d(-20, -13) + radius(k) * cv::Vec2d(std::cos(angle), std::sin(angle)));
    }
    std::vector<cv::Vec2d> polyline;
    for (size_t k = 0; k < corners.size(); ++k) {
        const cv::Vec2d a = corners[k], b = corners[(k + 1) % corners.size()];
        const int steps = std::max(1, int(std::round(cv::norm(b - a) / 0.4)));
        for (int i = 0; i < steps; ++i) polyline.push_back(a + (b - a) * (double(i) / steps));
    }
    return polyline;
}
}  // namespace

// The chords' middles lie c^2 / (8 r) = 0.024 mm inside the arc, far beyond the 5 um tolerance of a
// noise-free cut: no circle holds every point, so lines covered the fillet 0.16-0.25 mm off their
// points and (since 20321ab) the section was refused. The chords' ends lie on the true arc: fitted to
// them (the chords' middles not fitted, their sag reported), the fillet is one arc of 5 mm, tangent to
// its lines.
TEST(SectionFit, AFilletOfCoarseChordsIsFittedToItsCornersAsOneArc) {
    const std::vector<cv::Vec2d> polyline = faceted_fillet_outline([](int) { return 5.0; });
    const SectionFit fit = fit_section(polyline, true);
    EXPECT_NEAR(fit.tolerance_mm, 0.005, 1e-9);
    ASSERT_EQ(fit.elements.size(), 5u);
    int arcs = 0, covered = 0;
    for (size_t j = 0; j < fit.elements.size(); ++j) {
        const SectionElement& e = fit.elements[j];
        covered += e.point_count;
        EXPECT_LE(e.rms_mm, fit.tolerance_mm) << to_string(e.kind) << " " << j;
        if (e.kind != SectionElementKind::Arc) {
            EXPECT_EQ(e.chord_sag_mm, 0);
            continue;
        }
        ++arcs;
        std::printf("arc: radius %.6f mm, centre (%.6f, %.6f), %.2f deg, %d points, rms %.6f mm, chord sag %.5f mm\n",
                    e.radius_mm, e.centre[0], e.centre[1], swept_angle_deg(e), e.point_count, e.rms_mm, e.chord_sag_mm);
        EXPECT_NEAR(e.radius_mm, 5.0, 0.020);  // issue 14's target for arcs
        EXPECT_NEAR(cv::norm(e.centre - cv::Vec2d(-20, -13)), 0, 0.020);
        EXPECT_NEAR(swept_angle_deg(e), 90, 0.5);
        EXPECT_NEAR(e.chord_sag_mm, std::pow(10 * std::sin(kPi / 32), 2) / 40, 1e-4);
        EXPECT_TRUE(e.tangent_to_next) << "to the bottom line";
        EXPECT_TRUE(fit.elements[(j + fit.elements.size() - 1) % fit.elements.size()].tangent_to_next) << "from the left line";
    }
    EXPECT_EQ(arcs, 1);
    // Each point fitted belongs to one element; the 8 chords' middles are fitted by none.
    EXPECT_EQ(covered, int(polyline.size()) - 8);
}

// Built to fool that: the same chords, but their ends alternately on 5.00 and 5.04 mm (a polygon
// whose corners are on no one circle, +-20 um about the best one). A tolerance widened by the chords'
// sag (24 um) would take it as an arc; judged on its corners (5 um) it is no arc, and nothing else
// holds it: refused, never handed on as fitted.
TEST(SectionFit, CornersOffOneCircleAreNoArc) {
    const std::vector<cv::Vec2d> polyline = faceted_fillet_outline([](int k) { return k % 2 ? 5.04 : 5.0; });
    std::string refused;
    try {
        const SectionFit fit = fit_section(polyline, true);
        for (const SectionElement& e : fit.elements) {
            EXPECT_NE(e.kind, SectionElementKind::Arc) << "radius " << e.radius_mm;
            EXPECT_LE(e.rms_mm, 2 * fit.tolerance_mm) << to_string(e.kind) << " of " << e.point_count << " points";
        }
    } catch (const Error& e) {
        refused = e.what();
    }
    std::printf("refused: %s\n", refused.c_str());
    EXPECT_EQ(refused.rfind("polyline", 0), 0u) << refused;
}


// The whole Cross-section in one call (section_mesh, as FreeCAD's Cross-section and picoscan section
// run it) on a mesh as a CAD tool exports it: a 10 mm prism of the outline above, its 5 mm fillet
// meshed with 8 chords of 0.98 mm (each chord one quad of two triangles), its sides with quads every
// 0.4 mm. The cut and the Band's 16 cuts cross the fillet's vertical edges (on the true arc) and its
// diagonals (on the chords, up to 24 um inside). The fillet: one arc of 5 mm within 20 um, tangent to
// both lines, fitted with its band; the same elements as the two steps by hand; the report names it;
// progress runs from the cut to the fit and Cancel in the fit stops it.
TEST(SectionFit, SectionMeshFitsAFacetedFilletAsOneArc) {
    std::vector<cv::Vec2d> ring;  // the outline's corners and the quads' edges, counter-clockwise
    {
        std::vector<cv::Vec2d> corners = {{25, -18}, {25, 18}, {-25, 18}, {-25, -13}};
        for (int k = 1; k <= 8; ++k) {
            const double angle = kPi + kPi / 2 * k / 8;
            corners.push_back(cv::Vec2d(-20, -13) + 5 * cv::Vec2d(std::cos(angle), std::sin(angle)));
        }
        for (size_t k = 0; k < corners.size(); ++k) {
            const cv::Vec2d a = corners[k], b = corners[(k + 1) % corners.size()];
            const int steps = cv::norm(b - a) < 1 ? 1 : int(std::round(cv::norm(b - a) / 0.4));
            for (int i = 0; i < steps; ++i) ring.push_back(a + (b - a) * (double(i) / steps));
        }
    }
    Mesh prism;
    const int n = int(ring.size());
    for (const double z : {0.0, 10.0})
        for (const cv::Vec2d& p : ring) prism.vertices.push_back(cv::Vec3f(float(p[0]), float(p[1]), float(z)));
    for (int i = 0; i < n; ++i) {
        const int j = (i + 1) % n;
        prism.faces.push_back({i, j, n + j});
        prism.faces.push_back({i, n + j, n + i});
    }
    const cv::Vec3d origin(0, 0, 5), u(1, 0, 0), v(0, 1, 0);
    std::vector<std::pair<double, std::string>> told;
    const MeshSectionFit section = section_mesh(prism, origin, u, v, kDefaultSectionBandMm, {}, [&](double f, const std::string& stage) {
        told.emplace_back(f, stage);
        return true;
    });
    for (const std::string& line : section.report) std::printf("%s\n", line.c_str());
    ASSERT_EQ(section.fits.fits.size(), 1u);
    const SectionFit& fit = section.fits.fits[0];
    ASSERT_EQ(fit.elements.size(), 5u);
    int arcs = 0;
    for (size_t j = 0; j < fit.elements.size(); ++j) {
        const SectionElement& e = fit.elements[j];
        if (e.kind != SectionElementKind::Arc) continue;
        ++arcs;
        EXPECT_NEAR(e.radius_mm, 5.0, 0.020);
        EXPECT_NEAR(cv::norm(e.centre - cv::Vec2d(-20, -13)), 0, 0.020);
        EXPECT_GT(e.band_cuts, 0) << e.band_note;
        EXPECT_NEAR(e.chord_sag_mm, 0.024, 0.001);
        EXPECT_TRUE(e.tangent_to_next);
        EXPECT_TRUE(fit.elements[(j + 4) % 5].tangent_to_next);
    }
    EXPECT_EQ(arcs, 1);
    const auto in_report = [&](const std::string& text) {
        return std::any_of(section.report.begin(), section.report.end(),
                           [&](const std::string& line) { return line.find(text) != std::string::npos; });
    };
    EXPECT_TRUE(in_report("band +- 3.000 mm")) << "the cuts";
    EXPECT_TRUE(in_report("arc    radius    5.0000 mm")) << "the fillet";
    EXPECT_TRUE(in_report("chords sag up to 0.0240 mm")) << "the chords";

    // The same as the two steps by hand.
    const MeshSection cut = cut_mesh_section(prism, origin, u, v);
    const SectionFits by_hand = fit_section_polylines(cut.polylines, cut.parallel_cuts);
    ASSERT_EQ(by_hand.fits.size(), 1u);
    ASSERT_EQ(by_hand.fits[0].elements.size(), fit.elements.size());
    for (size_t j = 0; j < fit.elements.size(); ++j) EXPECT_EQ(by_hand.fits[0].elements[j].start, fit.elements[j].start);

    // Progress: the cut, then the fit, never backwards, ending at 1.
    ASSERT_FALSE(told.empty());
    EXPECT_EQ(told.front().second, "cutting the mesh");
    for (size_t k = 1; k < told.size(); ++k) EXPECT_GE(told[k].first, told[k - 1].first);
    EXPECT_TRUE(std::any_of(told.begin(), told.end(), [](const auto& t) { return t.second == "fitting lines and arcs" && t.first >= 0.5; }));
    EXPECT_DOUBLE_EQ(told.back().first, 1.0);
    const std::string cancelled = test_support::error_of([&] {
        section_mesh(prism, origin, u, v, kDefaultSectionBandMm, {},
                     [](double, const std::string& stage) { return stage != "fitting lines and arcs"; });
    });
    EXPECT_EQ(cancelled.rfind("cancelled", 0), 0u) << cancelled;
    // The plane's errors are cut_mesh_section's.
    EXPECT_NE(test_support::error_of([&] { section_mesh(prism, {0, 0, 20}, u, v); }).find("plane: does not cut the mesh"),
              std::string::npos);
}

// The drawing's frames the CLI and MeshLab share: across x the right view (y, z), across y the front
// view (x, z), across z the top view (x, y); any normal: x square to Z, the normal towards the viewer.
TEST(SectionFit, SectionPlanesAreTheRightFrontAndTopViews) {
    const cv::Vec3d expected_u[3] = {{0, 1, 0}, {1, 0, 0}, {1, 0, 0}}, expected_v[3] = {{0, 0, 1}, {0, 0, 1}, {0, 1, 0}};
    for (int axis = 0; axis < 3; ++axis) {
        const SectionPlane plane = section_plane_across(axis, 12);
        EXPECT_EQ(plane.origin[axis], 12.0);
        EXPECT_LT(cv::norm(plane.u - expected_u[axis]), 1e-12) << axis;
        EXPECT_LT(cv::norm(plane.v - expected_v[axis]), 1e-12) << axis;
        EXPECT_LT(cv::norm(plane.u.cross(plane.v) - plane.normal), 1e-12) << axis;
    }
    const SectionPlane oblique = section_plane({1, 2, 3}, {3, 0, 4});
    EXPECT_LT(cv::norm(oblique.normal - cv::Vec3d(0.6, 0, 0.8)), 1e-12);
    EXPECT_NEAR(oblique.u[2], 0.0, 1e-12);
    EXPECT_EQ(test_support::error_of([] { section_plane_across(3, 0); }), "axis: must be 0, 1 or 2 (x, y, z), is 3");
    EXPECT_EQ(test_support::error_of([] { section_plane({0, 0, 0}, {0, 0, 0}); }).rfind("normal: ", 0), 0u);
}

// section_mesh given the scan behind a flattened mesh (an exact 40 x 20 x 10 mm box: its cut has no
// noise; the scan: points over its surface with 20 um of noise): the tolerance is 5 x the noise
// measured on the scan, and the report says so; without the scan it is the cut's 0.005 mm floor and
// the report says to set it; given, it says given. A scan with a tolerance, or with too few points,
// is refused naming the scan.
TEST(SectionFit, SectionMeshTakesItsToleranceFromTheScanBehindTheMesh) {
    Mesh box;  // its sides, in quads every 0.4 mm (as a CAD tool meshes them)
    const std::vector<cv::Vec2d> corners = {{20, -10}, {20, 10}, {-20, 10}, {-20, -10}};
    std::vector<cv::Vec2d> ring;
    for (size_t k = 0; k < corners.size(); ++k)
        for (int i = 0; i < int(cv::norm(corners[(k + 1) % 4] - corners[k]) / 0.4); ++i)
            ring.push_back(corners[k] + (corners[(k + 1) % 4] - corners[k]) * (i * 0.4 / cv::norm(corners[(k + 1) % 4] - corners[k])));
    const int n = int(ring.size());
    for (const double z : {0.0, 10.0})
        for (const cv::Vec2d& p : ring) box.vertices.push_back(cv::Vec3f(float(p[0]), float(p[1]), float(z)));
    for (int i = 0; i < n; ++i) {
        box.faces.push_back({i, (i + 1) % n, n + (i + 1) % n});
        box.faces.push_back({i, n + (i + 1) % n, n + i});
    }
    PointCloud scan;
    scan.points = test_support::noisy_surface_points(box.vertices, box.faces, 10, 0.02, 7);
    const cv::Vec3d origin(0, 0, 5), u(1, 0, 0), v(0, 1, 0);
    const auto report_has = [](const MeshSectionFit& section, const std::string& text) {
        return std::any_of(section.report.begin(), section.report.end(),
                           [&](const std::string& line) { return line.find(text) != std::string::npos; });
    };

    const MeshSectionFit with_scan = section_mesh(box, origin, u, v, 0, {}, nullptr, &scan);
    std::printf("box with a 20 um scan: scan noise %.4f mm, tolerance %.4f mm; %s\n", with_scan.scan_noise_mm,
                with_scan.fits.tolerance_mm, with_scan.tolerance_from.c_str());
    EXPECT_EQ(with_scan.tolerance_source, SectionToleranceSource::ScanNoise);
    EXPECT_NEAR(with_scan.scan_noise_mm, 0.02, 0.004);
    EXPECT_DOUBLE_EQ(with_scan.fits.tolerance_mm, 5 * with_scan.scan_noise_mm);
    EXPECT_LT(with_scan.fits.noise_mm, 1e-4);  // the flattened mesh's own cut shows none of it
    EXPECT_TRUE(report_has(with_scan, with_scan.tolerance_from));
    EXPECT_EQ(with_scan.tolerance_from.find("5 x the noise of the scan the mesh was made from"), 21u) << with_scan.tolerance_from;
    ASSERT_EQ(with_scan.fits.fits.size(), 1u);
    EXPECT_EQ(count(with_scan.fits.fits[0], SectionElementKind::Line), 4);
    // The outline is fitted with that tolerance too (it got the cut's 0.005 mm floor).
    EXPECT_DOUBLE_EQ(with_scan.fits.fits[0].tolerance_mm, with_scan.fits.tolerance_mm);

    const MeshSectionFit from_cut = section_mesh(box, origin, u, v, 0);
    EXPECT_EQ(from_cut.tolerance_source, SectionToleranceSource::CutNoise);
    EXPECT_EQ(from_cut.scan_noise_mm, 0.0);
    EXPECT_EQ(from_cut.fits.tolerance_mm, 0.005);
    EXPECT_NE(from_cut.tolerance_from.find("set it yourself"), std::string::npos) << from_cut.tolerance_from;
    SectionFitOptions given;
    given.tolerance_mm = 0.05;
    const MeshSectionFit set = section_mesh(box, origin, u, v, 0, given);
    EXPECT_EQ(set.tolerance_source, SectionToleranceSource::Given);
    EXPECT_EQ(set.tolerance_from, "tolerance 0.0500 mm: given");

    EXPECT_EQ(test_support::error_of([&] { section_mesh(box, origin, u, v, 0, given, nullptr, &scan); }),
              "scan: sets the default tolerance: give either the scan or a tolerance, not both");
    PointCloud few;
    few.points.assign(scan.points.begin(), scan.points.begin() + 10);
    EXPECT_EQ(test_support::error_of([&] { section_mesh(box, origin, u, v, 0, {}, nullptr, &few); }).rfind("scan: 10 points", 0), 0u);
}

// A cut of a mesh with planar facets (a CAD export, an extruded outline): `vertices` are where the cut
// crosses the mesh's edges along the outline (on the true curve, up to the noise given to them), joined
// by straight chords, each with `inner` points between its ends (where the cut crosses facets'
// diagonals: exactly on the chord).
namespace {
std::vector<cv::Vec2d> chorded(const std::vector<cv::Vec2d>& vertices, int inner) {
    std::vector<cv::Vec2d> polyline;
    for (size_t k = 0; k < vertices.size(); ++k) {
        const cv::Vec2d a = vertices[k], b = vertices[(k + 1) % vertices.size()];
        for (int i = 0; i <= inner; ++i) polyline.push_back(a + (b - a) * (double(i) / (inner + 1)));
    }
    return polyline;
}

// `chords` vertices (chords + 1 ends) on an arc from `from_deg` to `to_deg`, the last one left out (it
// starts what follows), each `sigma` off the circle at random.
void add_faceted_arc(std::vector<cv::Vec2d>& vertices, cv::Vec2d centre, double radius, double from_deg, double to_deg,
                     int chords, double sigma, std::mt19937& random) {
    std::normal_distribution<double> noise;
    for (int k = 0; k < chords; ++k) {
        const double angle = (from_deg + (to_deg - from_deg) * k / chords) * kPi / 180;
        vertices.push_back(centre + (radius + sigma * noise(random)) * cv::Vec2d(std::cos(angle), std::sin(angle)));
    }
}

// Vertices every 0.4 mm from a to b (b left out), each `sigma` across the side at random.
void add_side(std::vector<cv::Vec2d>& vertices, cv::Vec2d a, cv::Vec2d b, double sigma, std::mt19937& random) {
    std::normal_distribution<double> noise;
    const int steps = std::max(1, int(std::round(cv::norm(b - a) / 0.4)));
    const cv::Vec2d across = cv::Vec2d(a[1] - b[1], b[0] - a[0]) / cv::norm(b - a);
    for (int i = 0; i < steps; ++i) vertices.push_back(a + (b - a) * (double(i) / steps) + sigma * noise(random) * across);
}

// The 50 x 36 block with its (-25, -18) corner a fillet of `radius` meshed with `chords` chords.
std::vector<cv::Vec2d> block_with_faceted_fillet(double radius, int chords, int inner, double sigma, unsigned seed) {
    std::mt19937 random(seed);
    std::vector<cv::Vec2d> vertices;
    add_side(vertices, {25, -18}, {25, 18}, sigma, random);
    add_side(vertices, {25, 18}, {-25, 18}, sigma, random);
    add_side(vertices, {-25, 18}, {-25, -18 + radius}, sigma, random);
    add_faceted_arc(vertices, {-25 + radius, -18 + radius}, radius, 180, 270, chords, sigma, random);
    add_side(vertices, {-25 + radius, -18}, {25, -18}, sigma, random);
    return chorded(vertices, inner);
}
}  // namespace

// A faceted fillet whose chords sag 1-2 x the tolerance: every point's circle misses the chords'
// middles by less than 2 x the tolerance, so the all-points fit did not refuse but covered the fillet
// another way. The chords' ends lie on one circle within the tolerance and turn alike: the fillet
// is one arc of its radius, fitted to the chords' ends, tangent to both sides; its point_count is
// those ends (not the chords' middles).
TEST(SectionFit, AFilletWhoseChordsSagAboutTheToleranceIsOneArc) {
    for (const double radius : {3.0, 5.0, 10.0}) {
        for (const double sag_in_tolerances : {1.2, 1.8}) {
            // Chords of the fillet's sag with the 5 um tolerance a noise-free or 1 um-noise cut gets.
            const double chord = std::sqrt(8 * radius * sag_in_tolerances * 0.005);
            const int chords = int(std::round(radius * kPi / 2 / chord));
            for (const int inner : {1, 3}) {
                for (const double sigma : {0.0, 0.001}) {
                    SCOPED_TRACE("radius " + std::to_string(radius) + ", " + std::to_string(chords) + " chords, " +
                                 std::to_string(inner) + " inner points, sigma " + std::to_string(sigma));
                    const std::vector<cv::Vec2d> polyline = block_with_faceted_fillet(radius, chords, inner, sigma, 11);
                    SectionFit fit;
                    ASSERT_EQ(test_support::error_of([&] { fit = fit_section(polyline, true); }), "");
                    const double c = 2 * radius * std::sin(kPi / 4 / chords), sag = c * c / (8 * radius);
                    std::printf("r %4.1f mm, %2d chords of %.3f mm (%d inner, sigma %.3f): sag %.4f mm = %.2f x tolerance: "
                                "%d lines, %d arcs\n",
                                radius, chords, c, inner, sigma, sag, sag / fit.tolerance_mm, count(fit, SectionElementKind::Line),
                                count(fit, SectionElementKind::Arc));
                    EXPECT_GE(sag, fit.tolerance_mm);
                    EXPECT_LE(sag, 2 * fit.tolerance_mm);
                    ASSERT_EQ(count(fit, SectionElementKind::Arc), 1);
                    EXPECT_EQ(count(fit, SectionElementKind::Line), 4);
                    for (size_t j = 0; j < fit.elements.size(); ++j) {
                        const SectionElement& e = fit.elements[j];
                        if (e.kind != SectionElementKind::Arc) continue;
                        EXPECT_NEAR(e.radius_mm, radius, 0.020);
                        EXPECT_NEAR(swept_angle_deg(e), 90, 0.5);
                        EXPECT_NEAR(e.chord_sag_mm, sag, 1e-3);
                        EXPECT_TRUE(e.tangent_to_next);
                        EXPECT_TRUE(fit.elements[(j + 4) % 5].tangent_to_next);
                        // The points it fitted: the chords' ends (chords + 1, give or take one at each tangent
                        // point), and none of the chords' inner points.
                        EXPECT_GE(e.point_count, chords - 1);
                        EXPECT_LT(e.point_count, chords + chords * inner / 2);
                    }
                    int fitted = 0;
                    for (const SectionElement& e : fit.elements) fitted += e.point_count;
                    EXPECT_EQ(fitted, int(polyline.size()) - chords * inner) << "each point but the chords' inner ones, once";
                }
            }
        }
    }
}

// A hole of a coarse mesh: chords of 1-3 mm (a Poisson mesh of 1-2 mm spacing, an STL at a coarse
// angular deflection) on radii of 10-20 mm, with and without noise on its vertices: one circle of
// its radius, fitted to the chords' ends.
TEST(SectionFit, AHoleOfLongChordsIsOneCircle) {
    double worst = 0;
    for (const double radius : {10.0, 15.0, 20.0}) {
        for (const double chord : {1.0, 2.0, 3.0}) {
            for (const double sigma : {0.0, 0.001}) {
                const int chords = int(std::round(2 * kPi * radius / chord));
                SCOPED_TRACE("radius " + std::to_string(radius) + ", " + std::to_string(chords) + " chords, sigma " +
                             std::to_string(sigma));
                std::mt19937 random(17);
                std::vector<cv::Vec2d> vertices;
                add_faceted_arc(vertices, {3, -4}, radius, 0, 360, chords, sigma, random);
                const std::vector<cv::Vec2d> polyline = chorded(vertices, 1);
                SectionFit fit;
                ASSERT_EQ(test_support::error_of([&] { fit = fit_section(polyline, true); }), "");
                ASSERT_EQ(fit.elements.size(), 1u);
                const SectionElement& hole = fit.elements[0];
                EXPECT_EQ(hole.kind, SectionElementKind::Circle);
                EXPECT_NEAR(hole.radius_mm, radius, 0.020);
                worst = std::max(worst, std::abs(hole.radius_mm - radius));
                EXPECT_NEAR(cv::norm(hole.centre - cv::Vec2d(3, -4)), 0, 0.020);
                EXPECT_EQ(hole.point_count, chords);
                const double c = 2 * radius * std::sin(kPi / chords);
                EXPECT_NEAR(hole.chord_sag_mm, c * c / (8 * radius), 1e-3);
            }
        }
    }
    std::printf("holes of 10-20 mm in chords of 1-3 mm, 0 and 1 um noise: radius within %.4f mm\n", worst);
}

// Built to fool the chords' test: a slot of two faceted half circles (10 mm, 1 mm chords) joined by
// real straight sides of 2 mm (each split by facets' diagonals like a chord): the sides turn into
// the arcs by half a chord's turn, so they stay lines; and real polygons whose corners lie on one
// circle and turn alike, but by more than a curve's facets: RealPolygonsWithShortSidesStayLines.
TEST(SectionFit, ShortRealSidesBetweenFacetedArcsStayLines) {
    int unknown_sigmas = 0;
    for (const double sigma : {0.0, 0.001}) {
        SCOPED_TRACE("sigma " + std::to_string(sigma));
        std::mt19937 random(23);
        std::vector<cv::Vec2d> vertices;
        add_faceted_arc(vertices, {1, 0}, 10, -90, 90, 31, sigma, random);
        vertices.push_back({1, 10});
        add_faceted_arc(vertices, {-1, 0}, 10, 90, 270, 31, sigma, random);
        vertices.push_back({-1, -10});
        // A side of one facet (3 points: fewer than min_line_points) is still a line: its middle lies
        // 0.05 mm outside the arc before it, where no chord of that arc can lie (short_side). Refused
        // before; with 3 points per chord it always was a line.
        for (const int inner : {1, 3}) {
        SCOPED_TRACE(std::to_string(inner) + " inner points per chord");
        SectionFit slot;
        ASSERT_EQ(test_support::error_of([&] { slot = fit_section(chorded(vertices, inner), true); }), "");
        ASSERT_EQ(count(slot, SectionElementKind::Arc), 2);
        ASSERT_EQ(count(slot, SectionElementKind::Line), 2);
        for (const SectionElement& e : slot.elements) {
            const std::string text = section_element_text(e);
            if (e.kind == SectionElementKind::Arc) {
                EXPECT_NEAR(e.radius_mm, 10, 0.020);
                EXPECT_TRUE(std::isfinite(e.radius_sigma_mm)) << text;
            } else {
                EXPECT_NEAR(cv::norm(e.end - e.start), 2, 0.05);
                EXPECT_TRUE(e.tangent_to_next);
                // About 2 mm is too short for the jackknife's 3 runs of 1 mm: said so, not "sigma nan".
                const bool unknown = !std::isfinite(e.angle_sigma_deg);
                unknown_sigmas += unknown;
                EXPECT_EQ(text.find("sigma unknown: under 3 mm of points") != std::string::npos, unknown) << text;
            }
            EXPECT_EQ(text.find("nan"), std::string::npos) << text;
        }
        }
    }
    EXPECT_GT(unknown_sigmas, 0) << "no line short enough to have no standard error";
}

// Built to fool short_side: a hole of 10 mm radius in 1.1 mm chords with one chord of 2.4 mm, too
// long for its neighbours' facet run (more than 2 x), so its middle is fitted like the slot's 2 mm
// side's: 3 points on one line after a faceted arc, the middle off the arc. It is a facet: its middle
// lies 0.07 mm inside the circle, and it must not become a line (a rule that took any 3 points off
// the arc by more than the tolerance made it one). The fit cannot place that middle on the circle
// either: it refuses, as before short_side.
TEST(SectionFit, ALongFacetOfAHoleIsNoShortSide) {
    for (const double sigma : {0.0, 0.001}) {
        SCOPED_TRACE("sigma " + std::to_string(sigma));
        std::mt19937 random(31);
        std::vector<cv::Vec2d> vertices;
        const double long_chord_deg = 2 * std::asin(1.2 / 10) * 180 / kPi;  // 13.8 deg
        add_faceted_arc(vertices, {0, 0}, 10, long_chord_deg, 360, 55, sigma, random);
        vertices.push_back({10, 0});  // the long chord runs from here to the first vertex
        SectionFit fit;
        const std::string why = test_support::error_of([&] { fit = fit_section(chorded(vertices, 1), true); });
        std::printf("hole with a 2.4 mm facet, sigma %.3f: %s%d lines, %d arcs, %d circles\n", sigma, why.c_str(),
                    count(fit, SectionElementKind::Line), count(fit, SectionElementKind::Arc),
                    count(fit, SectionElementKind::Circle));
        EXPECT_EQ(count(fit, SectionElementKind::Line), 0);
        EXPECT_EQ(why.rfind("polyline: ", 0), 0u) << why;
    }
}

// Real polygons whose corners lie on one circle and turn alike, but by more than a curve's facets:
// hexagons of 5.77 and 2 mm sides (60 deg), 12-gons of 3 and 1.5 mm sides (30 deg), each side split
// by facets' diagonals; and the block's corner chamfered 0.5 mm (45 deg): lines, no arc.
TEST(SectionFit, RealPolygonsWithShortSidesStayLines) {
    const auto polygon = [](int sides, double side) {
        std::vector<cv::Vec2d> vertices;
        const double radius = side / (2 * std::sin(kPi / sides));
        for (int k = 0; k < sides; ++k) vertices.push_back(radius * cv::Vec2d(std::cos(2 * kPi * k / sides), std::sin(2 * kPi * k / sides)));
        return vertices;
    };
    for (const auto& [sides, side] : {std::pair{6, 5.77}, std::pair{12, 3.0}, std::pair{6, 2.0}, std::pair{12, 1.5}}) {
        SCOPED_TRACE(std::to_string(sides) + " sides");
        // Alone, such a small loop reads its corners as noise (1.65 mm for the hexagon of 5.77 mm sides)
        // and is taken as a circle within that; in a section its tolerance is the outline's.
        SectionFitOptions options;
        options.tolerance_mm = 0.005;
        const std::string why = test_support::error_of([&] { fit_section(chorded(polygon(sides, side), 3), true, options); });
        ASSERT_EQ(why, "");
        const SectionFit fit = fit_section(chorded(polygon(sides, side), 3), true, options);
        std::printf("%d sides of %.2f mm: tolerance %.4f mm, %d lines, %d arcs, %d circles\n", sides, side, fit.tolerance_mm,
                    count(fit, SectionElementKind::Line), count(fit, SectionElementKind::Arc), count(fit, SectionElementKind::Circle));
        EXPECT_EQ(count(fit, SectionElementKind::Arc) + count(fit, SectionElementKind::Circle), 0);
        EXPECT_EQ(count(fit, SectionElementKind::Line), sides);
    }
    std::mt19937 random(29);
    std::vector<cv::Vec2d> vertices;
    add_side(vertices, {25, -18}, {25, 18}, 0, random);
    add_side(vertices, {25, 18}, {-25, 18}, 0, random);
    add_side(vertices, {-25, 18}, {-25, -17.5}, 0, random);
    vertices.push_back({-25, -17.5});  // the chamfer's chord to the next side's first vertex
    add_side(vertices, {-24.5, -18}, {25, -18}, 0, random);
    EXPECT_EQ(test_support::error_of([&] { fit_section(chorded(vertices, 1), true); }), "");
    const SectionFit chamfered = fit_section(chorded(vertices, 1), true);
    EXPECT_EQ(count(chamfered, SectionElementKind::Arc), 0);
}

// A coarse mesh's chamfer, bowed by 35-50 um over its 11.3 mm, its corner with the side rounded
// off 0.12 mm deep (FreeCAD's eight-view walkthrough, its Poisson mesh cut at z = 12 mm): the
// corner and part of the chamfer were fitted as one arc of radius 419 +- 88 mm, whose unknown
// radius then refused the whole outline (on the old code: 27 of 192 outlines of bows 0-50 um, corners
// of 0-2 mm, 1-8 seeds, 10-20 um noise, in a study with the Python module). A curve whose
// points cannot tell its radius shows no curve: a line that holds the same points within the
// tolerance takes its place. Built to fool it: a real fillet of 8 mm radius in place of the
// chamfer stays one arc of its radius.
TEST(SectionFit, AChamferBowedFarBelowTheToleranceIsALine) {
    SectionFitOptions options;
    options.tolerance_mm = 0.1;
    const cv::Vec2d b(17, 18), outward = cv::Vec2d(1, 1) / std::sqrt(2.0);
    const auto angle_deg = [](cv::Vec2d p, cv::Vec2d centre) { return std::atan2(p[1] - centre[1], p[0] - centre[0]) * 180 / kPi; };
    for (const double bow_mm : {0.035, 0.05}) {
        for (const double round_mm : {0.0, 1.5, 2.0, -8.0}) {  // the corner's radius; -8: the fillet in place of the chamfer
            for (const double sigma : {0.01, 0.02}) {
                for (const unsigned seed : {1u, 2u, 3u, 4u, 5u, 6u}) {
                    SCOPED_TRACE("bow " + std::to_string(bow_mm) + " corner " + std::to_string(round_mm) + " sigma " +
                                 std::to_string(sigma) + " seed " + std::to_string(seed));
                    Outline outline(sigma, 0.3);
                    outline.random.seed(seed);
                    outline.line({-25, -18}, {25, -18});
                    if (round_mm < 0) {
                        outline.line({25, -18}, {25, 10});
                        outline.arc({17, 10}, 8, 0, 90);
                    } else {
                        // The corner at (25, 10): an arc tangent to the side x = 25 and to the chamfer x + y = 35.
                        const cv::Vec2d centre(25 - round_mm, 10 + round_mm - round_mm * std::sqrt(2.0));
                        const cv::Vec2d a = centre + round_mm * outward;  // where the chamfer starts
                        outline.line({25, -18}, {25, centre[1]});
                        if (round_mm > 0) outline.arc(centre, round_mm, 0, 45);
                        // The chamfer: an arc from a to b that bulges out by bow_mm.
                        const double half_chord = cv::norm(b - a) / 2;
                        const double radius = (half_chord * half_chord + bow_mm * bow_mm) / (2 * bow_mm);
                        const cv::Vec2d bow_centre = (a + b) / 2 - (radius - bow_mm) * outward;
                        outline.arc(bow_centre, radius, angle_deg(a, bow_centre), angle_deg(b, bow_centre));
                    }
                    outline.line(b, {-25, 18});
                    outline.line({-25, 18}, {-25, -18});
                    SectionFit fit;
                    ASSERT_NO_THROW(fit = fit_section(outline.points, true, options));
                    int chamfers = 0, fillets = 0;
                    for (const auto& e : fit.elements) {
                        EXPECT_LE(e.rms_mm, options.tolerance_mm);
                        if (e.kind == SectionElementKind::Arc) {
                            EXPECT_LT(e.radius_mm, 10.0);  // a corner or the fillet, never the chamfer's bow
                            fillets += std::abs(e.radius_mm - 8.0) < 0.05;
                        } else if (cv::norm(e.end - e.start) > 8) {
                            chamfers += angle_error_deg(direction_deg(e.start, e.end), 135.0) < 0.3;
                        }
                    }
                    std::string elements;
                    for (const auto& e : fit.elements) elements += section_element_text(e) + "\n";
                    EXPECT_EQ(chamfers, round_mm < 0 ? 0 : 1) << elements;
                    EXPECT_EQ(fillets, round_mm < 0 ? 1 : 0);
                }
            }
        }
    }
}

// A faceted hole whose vertices carry 1 um of noise, cut through the middle point of one facet (where
// a cut crosses its diagonal: on the chord, c^2 / (8 r) inside the circle). Built to fool the fit: the
// chord ends lie on one circle, but that one middle point turns with the noise and is fitted too. Main
// handed back one arc of 345-351 degrees (its closing chord not drawn) whose RMS over its points was
// 1.3-1.9 x the tolerance, accepted because the check ran on its points without the ends while the
// report counted them all. Either the fit is refused with the reason, or every element it gives holds
// the figures it reports within the tolerance.
TEST(SectionFit, AHoleCutThroughOneFacetsMiddleIsNoArcOffItsPoints) {
    struct Case {
        int sides;
        double radius;
    };
    int refused = 0;
    for (const Case c : {Case{24, 8.0}, Case{24, 10.0}, Case{32, 15.0}, Case{36, 20.0}, Case{40, 20.0}})
        for (const unsigned seed : {1u, 2u}) {
            std::mt19937 random(seed);
            std::normal_distribution<double> noise(0.0, 0.001);
            std::vector<cv::Vec2d> points;
            for (int i = 0; i < c.sides; ++i) {
                const double a = 2 * kPi * i / c.sides, b = 2 * kPi * (i + 1) / c.sides;
                const cv::Vec2d from(std::cos(a), std::sin(a)), to(std::cos(b), std::sin(b));
                points.push_back((c.radius + noise(random)) * from);
                if (i == 0) points.push_back(c.radius * 0.5 * (from + to));  // the facet's middle point
            }
            SCOPED_TRACE(std::to_string(c.sides) + " chords on r " + std::to_string(c.radius) + ", seed " + std::to_string(seed));
            try {
                const SectionFit fit = fit_section(points, true);
                ASSERT_FALSE(fit.elements.empty());
                for (const SectionElement& e : fit.elements) {
                    EXPECT_LE(e.rms_mm, fit.tolerance_mm) << to_string(e.kind) << " of " << swept_angle_deg(e) << " deg";
                    // A closed outline of one arc leaves its closing gap out of the sketch.
                    EXPECT_FALSE(fit.elements.size() == 1 && e.kind == SectionElementKind::Arc) << swept_angle_deg(e) << " deg";
                }
            } catch (const Error& error) {
                ++refused;
                EXPECT_EQ(error.subject(), "polyline");
                EXPECT_NE(std::string(error.what()).find("no circle within the tolerance"), std::string::npos) << error.what();
            }
        }
    // 40 chords on 20 mm, seed 1: main's arc swept 351 degrees at 0.0095 mm RMS, tolerance 0.0050 mm.
    EXPECT_EQ(refused, 10);
}

// The same with 48 facets (r 5 mm, 1 um of noise): main gave a circle's worth of arc (339 deg, 45
// points) and a second arc of 19 deg over 4 points, below min_arc_points: moving the splits
// (refine) let an arc shrink to min_line_points. Now no element has fewer points than its kind
// needs, and the hole is one circle of its radius or refused with the reason.
TEST(SectionFit, AFacetedHoleGivesNoArcOfTooFewPoints) {
    int circles = 0, refused = 0;
    for (const int sides : {36, 48, 64})
        for (const double radius : {5.0, 10.0, 20.0})
            for (const unsigned seed : {1u, 2u, 3u}) {
                std::mt19937 random(seed);
                std::normal_distribution<double> noise(0.0, 0.001);
                std::vector<cv::Vec2d> points;
                for (int i = 0; i < sides; ++i) {
                    const double a = 2 * kPi * i / sides, b = 2 * kPi * (i + 1) / sides;
                    const cv::Vec2d from(std::cos(a), std::sin(a)), to(std::cos(b), std::sin(b));
                    points.push_back((radius + noise(random)) * from);
                    if (i == 0) points.push_back(radius * 0.5 * (from + to));  // the facet's middle point
                }
                SCOPED_TRACE(std::to_string(sides) + " facets on r " + std::to_string(radius) + ", seed " + std::to_string(seed));
                SectionFit fit;
                const std::string why = test_support::error_of([&] { fit = fit_section(points, true); });
                if (!why.empty()) {
                    ++refused;
                    EXPECT_NE(why.find("no circle within the tolerance"), std::string::npos) << why;
                    continue;
                }
                for (const SectionElement& e : fit.elements)
                    EXPECT_GE(e.point_count, e.kind == SectionElementKind::Line ? 4 : 8) << section_element_text(e);
                ASSERT_EQ(fit.elements.size(), 1u);
                EXPECT_EQ(fit.elements[0].kind, SectionElementKind::Circle);
                EXPECT_NEAR(fit.elements[0].radius_mm, radius, 0.005);
                ++circles;
            }
    std::printf("faceted holes cut through one facet's middle: %d circles, %d refused\n", circles, refused);
    EXPECT_EQ(circles + refused, 27);
    EXPECT_GE(circles, 9);
}
