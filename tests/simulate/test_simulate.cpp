// The virtual rig: geometry against closed-form answers and OpenCV, lighting, noise,
// shadows, capture sets, the seed rig and scene files.
#include "picoscan/error.h"
#include "picoscan/io.h"
#include "picoscan/patterns.h"
#include "picoscan/simulate.h"
#include "support/test_support.h"

// Private parts of the simulator, tested directly.
#include "../../core/src/simulate/bvh.h"
#include "../../core/src/simulate/lens_model.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <fstream>
#include <random>

using namespace picoscan;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The seed rig with the camera scaled down 4x (same field of view), for fast tests.
Calibration small_rig() {
    Calibration c = seed_rig_calibration();
    c.camera_size = cv::Size(400, 300);
    const double s = 0.25;
    c.camera_matrix = cv::Matx33d(c.camera_matrix(0, 0) * s, 0, (c.camera_matrix(0, 2) + 0.5) * s - 0.5, 0,
                                  c.camera_matrix(1, 1) * s, (c.camera_matrix(1, 2) + 0.5) * s - 0.5, 0, 0, 1);
    return c;
}

SimulationOptions noiseless() {
    SimulationOptions o;
    o.noise_sigma_dn = 0;
    return o;
}

cv::Mat uniform_pattern(const Calibration& c, int level) { return cv::Mat(c.projector_size, CV_8U, cv::Scalar(level)); }

// Independent camera ray through a pixel: OpenCV's iterative undistortion, run to convergence.
cv::Vec3d opencv_ray(const Calibration& c, double x, double y) {
    std::vector<cv::Point2d> in{{x, y}}, out;
    cv::undistortPoints(in, out, cv::Mat(c.camera_matrix), c.camera_distortion, cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-15));
    return cv::normalize(cv::Vec3d(out[0].x, out[0].y, 1.0));
}

cv::Vec2d opencv_project_to_projector(const Calibration& c, const cv::Vec3d& point) {
    cv::Vec3d rvec;
    cv::Rodrigues(cv::Mat(c.R), rvec);
    std::vector<cv::Point3d> in{cv::Point3d(point)};
    std::vector<cv::Point2d> out;
    cv::projectPoints(in, rvec, c.T, cv::Mat(c.projector_matrix), c.projector_distortion, out);
    return {out[0].x, out[0].y};
}

bool valid(const cv::Vec3f& p) { return std::isfinite(p[0]); }

}  // namespace

// ---------------------------------------------------------------------------------------------
// Lens model

TEST(SimulateLens, DistortMatchesOpenCVAndUndistortInvertsIt) {
    const std::vector<cv::Mat> models = {
        (cv::Mat_<double>(1, 5) << -0.08, 0.12, 0.0005, -0.0003, 0.0),                 // the seed camera
        (cv::Mat_<double>(1, 5) << 0.21, -0.35, 0.001, 0.002, 0.15),                   // strong, with k3
        (cv::Mat_<double>(1, 8) << 0.3, -0.1, 0.0008, -0.0006, 0.02, 0.25, -0.05, 0.01),  // rational
        (cv::Mat_<double>(1, 12) << -0.1, 0.05, 0.001, 0.0005, 0, 0.02, 0, 0, 0.001, -0.0005, 0.0007, 0.0002),
    };
    const cv::Matx33d K(2400, 0, 803.2, 0, 2400, 597.6, 0, 0, 1);
    const cv::Size size(1600, 1200);
    for (const cv::Mat& distortion : models) {
        const detail::LensModel lens(K, distortion, size, "test");
        double worst_round_trip_px = 0, worst_opencv_px = 0;
        for (double y = -0.5; y <= size.height - 0.5; y += 59.9) {
            for (double x = -0.5; x <= size.width - 0.5; x += 79.9) {
                cv::Vec3d ray;
                ASSERT_TRUE(lens.pixel_ray(cv::Vec2d(x, y), ray)) << "pixel " << x << "," << y;
                cv::Vec2d back;
                ASSERT_TRUE(lens.project(ray * 400.0, back));
                worst_round_trip_px = std::max(worst_round_trip_px, cv::norm(back - cv::Vec2d(x, y)));

                std::vector<cv::Point3d> in{cv::Point3d(ray * 400.0)};
                std::vector<cv::Point2d> out;
                cv::projectPoints(in, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(K), distortion, out);
                worst_opencv_px = std::max(worst_opencv_px, cv::norm(cv::Vec2d(out[0].x, out[0].y) - back));
            }
        }
        EXPECT_LT(worst_round_trip_px, 1e-6) << distortion;
        EXPECT_LT(worst_opencv_px, 1e-8) << distortion;
    }
}

TEST(SimulateLens, RefusesPointsBeyondTheOneToOneRadius) {
    // k1 < 0 folds the image back beyond r = 1/sqrt(3|k1|): far-off-axis points must not
    // be mapped into the image.
    const detail::LensModel lens(cv::Matx33d(1000, 0, 500, 0, 1000, 500, 0, 0, 1),
                                 (cv::Mat_<double>(1, 5) << -0.3, 0, 0, 0, 0), cv::Size(1000, 1000), "test");
    EXPECT_NEAR(std::sqrt(lens.max_radius_squared()), 1.0 / std::sqrt(0.9), 0.01);
    cv::Vec2d pixel;
    EXPECT_TRUE(lens.project(cv::Vec3d(0.5, 0, 1), pixel));
    EXPECT_FALSE(lens.project(cv::Vec3d(1.5, 0, 1), pixel));
    EXPECT_FALSE(lens.project(cv::Vec3d(0, 0, -1), pixel));  // behind
}

TEST(SimulateLens, BadDistortionIsAnError) {
    EXPECT_THROW(detail::LensModel(cv::Matx33d::eye(), cv::Mat::zeros(1, 6, CV_64F), cv::Size(10, 10), "x"), Error);
    EXPECT_THROW(detail::LensModel(cv::Matx33d(0, 0, 0, 0, 1, 0, 0, 0, 1), cv::Mat(), cv::Size(10, 10), "x"), Error);
}

// ---------------------------------------------------------------------------------------------
// BVH

TEST(SimulateBvh, AgreesWithBruteForceOnATriangleSoup) {
    std::mt19937 random(7);
    std::uniform_real_distribution<double> coordinate(-50, 50), offset(-4, 4);
    std::vector<detail::BvhTriangle> soup;
    for (int i = 0; i < 3000; ++i) {
        const cv::Vec3d centre(coordinate(random), coordinate(random), 400 + coordinate(random));
        detail::BvhTriangle t;
        t.a = centre + cv::Vec3d(offset(random), offset(random), offset(random));
        t.b = centre + cv::Vec3d(offset(random), offset(random), offset(random));
        t.c = centre + cv::Vec3d(offset(random), offset(random), offset(random));
        soup.push_back(t);
    }
    soup.push_back({cv::Vec3d(0, 0, 1), cv::Vec3d(1, 1, 1), cv::Vec3d(2, 2, 1), 0.5f});  // degenerate: dropped
    const detail::TriangleBvh bvh(soup);
    EXPECT_EQ(bvh.triangle_count(), 3000u);

    // Brute force in the same arithmetic (Möller–Trumbore), nearest t.
    auto brute = [&](const cv::Vec3d& o, const cv::Vec3d& d, double t_max) {
        double best = t_max;
        for (size_t i = 0; i + 1 < soup.size(); ++i) {
            const cv::Vec3d e1 = soup[i].b - soup[i].a, e2 = soup[i].c - soup[i].a;
            const cv::Vec3d p = d.cross(e2);
            const double det = e1.dot(p);
            if (det == 0) continue;
            const cv::Vec3d s = o - soup[i].a;
            const double u = s.dot(p) / det;
            if (u < 0 || u > 1) continue;
            const cv::Vec3d q = s.cross(e1);
            const double v = d.dot(q) / det;
            if (v < 0 || u + v > 1) continue;
            const double t = e2.dot(q) / det;
            if (t > 1e-9 && t < best) best = t;
        }
        return best;
    };
    int hits = 0;
    for (int i = 0; i < 3000; ++i) {
        const cv::Vec3d origin = i % 2 ? cv::Vec3d(0, 0, 0) : cv::Vec3d(coordinate(random), coordinate(random), 400);
        const cv::Vec3d target(coordinate(random), coordinate(random), 400 + coordinate(random));
        const cv::Vec3d direction = cv::normalize(target - origin);
        const double limit = i % 3 ? 1e9 : cv::norm(target - origin);
        const double expected = brute(origin, direction, limit);
        double t = limit;
        int triangle = -1;
        const bool hit = bvh.nearest(origin, direction, 1e-9, t, triangle);
        ASSERT_EQ(hit, expected < limit) << "ray " << i;
        ASSERT_EQ(bvh.occluded(origin, direction, 1e-9, limit), hit) << "ray " << i;
        if (hit) {
            ++hits;
            ASSERT_NEAR(t, expected, 1e-9) << "ray " << i;
        }
    }
    EXPECT_GT(hits, 1000);
}

// ---------------------------------------------------------------------------------------------
// Geometry

TEST(SimulateGeometry, SphereMatchesTheAnalyticSurface) {
    const Calibration c = small_rig();
    Scene scene;
    const cv::Vec3d centre(10, -5, 400);
    const double radius = 40;
    scene.spheres.push_back({centre, radius, 0.9});
    const Simulator simulator(c, scene, noiseless());
    const SimulatedGeometry& g = simulator.geometry();
    ASSERT_EQ(g.points.size(), c.camera_size);
    ASSERT_EQ(g.points.type(), CV_32FC3);

    int hits = 0, lit = 0;
    double worst_surface_mm = 0, worst_normal = 0;
    for (int y = 0; y < g.points.rows; ++y) {
        for (int x = 0; x < g.points.cols; ++x) {
            const cv::Vec3d ray = opencv_ray(c, x, y);
            // Distance of the (independent) ray from the centre decides hit or miss.
            const double miss_distance = cv::norm(centre - ray * ray.dot(centre));
            const cv::Vec3f p = g.points.at<cv::Vec3f>(y, x);
            if (std::abs(miss_distance - radius) < 0.01) continue;  // the silhouette: either is fine
            ASSERT_EQ(valid(p), miss_distance < radius) << "pixel " << x << "," << y;
            if (!valid(p)) continue;
            ++hits;
            lit += g.lit.at<uint8_t>(y, x) != 0;
            worst_surface_mm = std::max(worst_surface_mm, std::abs(cv::norm(cv::Vec3d(p) - centre) - radius));
            const cv::Vec3d outward = cv::normalize(cv::Vec3d(p) - centre);
            worst_normal = std::max(worst_normal, 1.0 - outward.dot(cv::Vec3d(g.normals.at<cv::Vec3f>(y, x))));
            EXPECT_FLOAT_EQ(g.albedo.at<float>(y, x), 0.9f);
        }
    }
    EXPECT_GT(hits, 11000);  // a 62 px radius disc
    EXPECT_GT(lit, hits * 6 / 10);  // the projector sees most of what the camera sees
    EXPECT_LT(worst_surface_mm, 1e-3);
    EXPECT_LT(worst_normal, 1e-6);
}

TEST(SimulateGeometry, PointsReprojectOntoTheirPixelCentres) {
    const Calibration c = seed_rig_calibration();
    const Simulator simulator(c, demo_scene(), noiseless());
    const SimulatedGeometry& g = simulator.geometry();
    std::vector<cv::Point3d> points;
    std::vector<cv::Point2d> pixels;
    for (int y = 0; y < g.points.rows; y += 37)
        for (int x = 0; x < g.points.cols; x += 41) {
            const cv::Vec3f p = g.points.at<cv::Vec3f>(y, x);
            ASSERT_TRUE(valid(p)) << "the demo background fills the view";
            points.emplace_back(p[0], p[1], p[2]);
            pixels.emplace_back(x, y);
        }
    std::vector<cv::Point2d> projected;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(c.camera_matrix), c.camera_distortion,
                      projected);
    double worst = 0;
    for (size_t i = 0; i < pixels.size(); ++i) worst = std::max(worst, cv::norm(projected[i] - pixels[i]));
    EXPECT_LT(worst, 2e-3);  // float storage of a point at 400-460 mm: ~3e-5 mm -> ~2e-4 px
}

TEST(SimulateGeometry, PlanePointsAndProjectorCoordinatesMatchADirectComputation) {
    const Calibration c = small_rig();
    Scene scene;
    const cv::Vec3d point(0, 0, 410), normal = cv::normalize(cv::Vec3d(0.3, -0.2, -1));
    scene.planes.push_back({point, normal, 0.7});
    const Simulator simulator(c, scene, noiseless());
    const SimulatedGeometry& g = simulator.geometry();

    int inside = 0;
    double worst_point_mm = 0, worst_projector_px = 0;
    for (int y = 0; y < g.points.rows; y += 3) {
        for (int x = 0; x < g.points.cols; x += 3) {
            const cv::Vec3d ray = opencv_ray(c, x, y);
            const cv::Vec3d expected = ray * (point.dot(normal) / ray.dot(normal));
            const cv::Vec3f p = g.points.at<cv::Vec3f>(y, x);
            ASSERT_TRUE(valid(p));
            worst_point_mm = std::max(worst_point_mm, cv::norm(cv::Vec3d(p) - expected));
            // The plane faces the camera, so the stored normal is the plane's.
            EXPECT_GT(cv::Vec3d(g.normals.at<cv::Vec3f>(y, x)).dot(normal), 1 - 1e-6);

            const cv::Vec2d uv = opencv_project_to_projector(c, expected);
            const cv::Vec2f stored = g.projector.at<cv::Vec2f>(y, x);
            const bool in_image = uv[0] >= -0.5 && uv[0] <= c.projector_size.width - 0.5 && uv[1] >= -0.5 &&
                                  uv[1] <= c.projector_size.height - 0.5;
            if (!in_image) {
                EXPECT_TRUE(std::isnan(stored[0])) << "pixel " << x << "," << y;
                continue;
            }
            ++inside;
            worst_projector_px = std::max(worst_projector_px, cv::norm(cv::Vec2d(stored[0], stored[1]) - uv));
            EXPECT_EQ(g.lit.at<uint8_t>(y, x), 255);

            // Shading: albedo times the cosine towards the projector centre.
            const cv::Vec3d projector_centre = -(c.R.t() * c.T);
            const double cosine = normal.dot(cv::normalize(projector_centre - expected));
            EXPECT_NEAR(g.shading.at<float>(y, x), 0.7 * cosine, 1e-5);
        }
    }
    EXPECT_GT(inside, 10000);
    EXPECT_LT(worst_point_mm, 1e-3);
    EXPECT_LT(worst_projector_px, 1e-3);
}

TEST(SimulateGeometry, TriangleMeshAgreesWithTheSameAnalyticBox) {
    const Calibration c = small_rig();
    // An axis-aligned box with float-exact corners, once analytic and once as 12 triangles.
    const cv::Vec3d lo(-40, -30, 390), hi(30, 25, 420);
    Scene analytic;
    analytic.boxes.push_back({(lo + hi) * 0.5, (hi - lo) * 0.5, cv::Matx33d::eye(), 0.6});
    Scene meshed;
    Mesh mesh;
    for (int i = 0; i < 8; ++i)
        mesh.vertices.emplace_back(float(i & 1 ? hi[0] : lo[0]), float(i & 2 ? hi[1] : lo[1]), float(i & 4 ? hi[2] : lo[2]));
    const int quads[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    for (const auto& q : quads) {
        mesh.faces.emplace_back(q[0], q[1], q[2]);
        mesh.faces.emplace_back(q[0], q[2], q[3]);
    }
    meshed.meshes.push_back({mesh, 0.6});
    for (Scene* scene : {&analytic, &meshed}) scene->planes.push_back({cv::Vec3d(0, 0, 450), cv::Vec3d(0, 0, -1), 0.4});

    const Simulator a(c, analytic, noiseless()), m(c, meshed, noiseless());
    int differing_points = 0, differing_lit = 0, box_pixels = 0;
    double worst_gap_mm = 0;
    for (int y = 0; y < c.camera_size.height; ++y) {
        for (int x = 0; x < c.camera_size.width; ++x) {
            const cv::Vec3f pa = a.geometry().points.at<cv::Vec3f>(y, x), pm = m.geometry().points.at<cv::Vec3f>(y, x);
            ASSERT_TRUE(valid(pa) && valid(pm));
            const double gap = cv::norm(cv::Vec3d(pa) - cv::Vec3d(pm));
            // Only a ray through an edge, to rounding, could see different surfaces.
            if (gap > 1e-4) {
                ++differing_points;
                continue;
            }
            worst_gap_mm = std::max(worst_gap_mm, gap);
            if (pa[2] < 421) {
                ++box_pixels;
                EXPECT_LT(cv::norm(a.geometry().normals.at<cv::Vec3f>(y, x) - m.geometry().normals.at<cv::Vec3f>(y, x)), 1e-6);
                EXPECT_NEAR(a.geometry().shading.at<float>(y, x), m.geometry().shading.at<float>(y, x), 1e-6);
                differing_lit += a.geometry().lit.at<uint8_t>(y, x) != m.geometry().lit.at<uint8_t>(y, x);
            }
        }
    }
    EXPECT_GT(box_pixels, 9000);
    EXPECT_LE(differing_points, 2);
    EXPECT_LE(differing_lit, 2);
    EXPECT_LT(worst_gap_mm, 1e-5);
}

TEST(SimulateGeometry, SphereCastsAProjectorShadowOnThePlaneBehind) {
    const Calibration c = small_rig();
    Scene scene;
    const cv::Vec3d centre(0, 0, 360);
    const double radius = 20;
    scene.spheres.push_back({centre, radius, 0.8});
    const cv::Vec3d plane_point(0, 0, 450), plane_normal(0, 0, -1);
    scene.planes.push_back({plane_point, plane_normal, 0.5});
    const Simulator simulator(c, scene, noiseless());
    const SimulatedGeometry& g = simulator.geometry();
    const cv::Vec3d projector_centre = -(c.R.t() * c.T);

    int shadowed = 0, checked = 0;
    for (int y = 0; y < g.points.rows; ++y) {
        for (int x = 0; x < g.points.cols; ++x) {
            const cv::Vec3f pf = g.points.at<cv::Vec3f>(y, x);
            if (!valid(pf) || pf[2] < 449) continue;  // plane pixels only
            if (std::isnan(g.projector.at<cv::Vec2f>(y, x)[0])) continue;
            const cv::Vec3d p(pf);
            // Distance of the projector->point segment from the sphere centre.
            const cv::Vec3d d = cv::normalize(p - projector_centre);
            const double along = (centre - projector_centre).dot(d);
            const double distance = cv::norm(centre - projector_centre - along * d);
            if (std::abs(distance - radius) < 0.05) continue;  // the shadow's edge
            ++checked;
            const bool expect_shadow = distance < radius;
            shadowed += expect_shadow;
            ASSERT_EQ(g.lit.at<uint8_t>(y, x) == 0, expect_shadow) << "pixel " << x << "," << y;
        }
    }
    EXPECT_GT(shadowed, 2000);
    EXPECT_GT(checked, 50000);

    // And in the rendered image the shadow is dark (ambient only) next to lit plane.
    const cv::Mat image = simulator.render(uniform_pattern(c, 255), 0);
    for (int y = 0; y < image.rows; y += 5)
        for (int x = 0; x < image.cols; x += 5) {
            const cv::Vec3f p = g.points.at<cv::Vec3f>(y, x);
            if (p[2] < 449 || std::isnan(g.projector.at<cv::Vec2f>(y, x)[0])) continue;
            const double expected = g.lit.at<uint8_t>(y, x) ? 220 * g.shading.at<float>(y, x) + 12 * 0.5 : 12 * 0.5;
            EXPECT_NEAR(image.at<uint8_t>(y, x), expected, 0.51);
        }
}

// ---------------------------------------------------------------------------------------------
// Rendering

TEST(SimulateRender, GammaAndBlackLevelGiveTheExpectedLevel) {
    const Calibration c = small_rig();
    Scene scene;
    scene.planes.push_back({cv::Vec3d(0, 0, 400), cv::Vec3d(0, 0, -1), 0.8});
    SimulationOptions options = noiseless();
    options.projector_gamma = 2.2;
    options.projector_black = 0.05;
    options.full_scale_dn = 240;
    options.ambient_dn = 10;
    const Simulator simulator(c, scene, options);
    const cv::Mat image = simulator.render(uniform_pattern(c, 128), 0);
    ASSERT_EQ(image.type(), CV_8UC1);
    ASSERT_EQ(image.size(), c.camera_size);
    const double light = 0.05 + 0.95 * std::pow(128 / 255.0, 2.2);
    int checked = 0;
    for (int y = 0; y < image.rows; ++y)
        for (int x = 0; x < image.cols; ++x) {
            if (!simulator.geometry().lit.at<uint8_t>(y, x)) continue;
            const double expected = 240 * simulator.geometry().shading.at<float>(y, x) * light + 10 * 0.8;
            ASSERT_NEAR(image.at<uint8_t>(y, x), expected, 0.5 + 1e-4) << "pixel " << x << "," << y;
            ++checked;
        }
    EXPECT_GT(checked, image.total() * 9 / 10);
    // A linear projector would be far brighter: the gamma is really applied.
    const cv::Point middle(image.cols / 2, image.rows / 2);
    const double linear = 240 * simulator.geometry().shading.at<float>(middle) * (0.05 + 0.95 * 128 / 255.0) + 8;
    EXPECT_GT(linear - image.at<uint8_t>(middle), 40);
}

TEST(SimulateRender, BilinearSamplingBetweenProjectorPixels) {
    const Calibration c = small_rig();
    Scene scene;
    scene.planes.push_back({cv::Vec3d(0, 0, 400), cv::Vec3d(0, 0, -1), 1.0});
    SimulationOptions options = noiseless();
    options.ambient_dn = 0;
    options.projector_black = 0;
    options.full_scale_dn = 200;
    const Simulator simulator(c, scene, options);
    // A horizontal ramp: level = x (projector column), so light = u / 255.
    cv::Mat ramp(c.projector_size, CV_8U);
    for (int y = 0; y < ramp.rows; ++y)
        for (int x = 0; x < ramp.cols; ++x) ramp.at<uint8_t>(y, x) = uint8_t(std::min(x, 255));
    const cv::Mat image = simulator.render(ramp, 0);
    int checked = 0;
    for (int y = 0; y < image.rows; y += 2)
        for (int x = 0; x < image.cols; x += 2) {
            const cv::Vec2f uv = simulator.geometry().projector.at<cv::Vec2f>(y, x);
            if (!simulator.geometry().lit.at<uint8_t>(y, x) || !(uv[0] > 0 && uv[0] < 254)) continue;
            const double expected = 200 * simulator.geometry().shading.at<float>(y, x) * uv[0] / 255.0;
            ASSERT_NEAR(image.at<uint8_t>(y, x), expected, 0.5 + 1e-3);
            ++checked;
        }
    EXPECT_GT(checked, 2000);
}

TEST(SimulateRender, NoiseIsDeterministicPerFrameAndHasTheRequestedSigma) {
    const Calibration c = small_rig();
    Scene scene;
    scene.planes.push_back({cv::Vec3d(0, 0, 400), cv::Vec3d(0, 0, -1), 0.6});
    SimulationOptions options;
    options.noise_sigma_dn = 1.0;
    options.seed = 1234;
    const cv::Mat pattern = uniform_pattern(c, 160);

    const Simulator first(c, scene, options);
    const int threads = cv::getNumThreads();
    cv::setNumThreads(1);
    const Simulator second(c, scene, options);  // built and rendered on one thread
    const cv::Mat single_thread = second.render(pattern, 3);
    cv::setNumThreads(threads);
    const cv::Mat frame3 = first.render(pattern, 3);
    EXPECT_EQ(cv::norm(frame3, single_thread, cv::NORM_INF), 0.0) << "noise must not depend on threads";
    EXPECT_EQ(cv::norm(frame3, first.render(pattern, 3), cv::NORM_INF), 0.0);

    const cv::Mat frame4 = first.render(pattern, 4);
    EXPECT_GT(cv::norm(frame3, frame4, cv::NORM_L1), 0.5 * frame3.total()) << "other frames, other noise";
    options.seed = 99;
    const cv::Mat other_seed = Simulator(c, scene, options).render(pattern, 3);
    EXPECT_GT(cv::norm(frame3, other_seed, cv::NORM_L1), 0.5 * frame3.total());

    // Sigma from the difference of two frames (removes the shading gradient); 8-bit rounding
    // adds 1/12 DN^2 to each frame.
    cv::Mat difference;
    cv::subtract(frame3, frame4, difference, cv::noArray(), CV_64F);
    cv::Scalar mean, deviation;
    cv::meanStdDev(difference, mean, deviation, first.geometry().lit);
    const double sigma = deviation[0] / std::sqrt(2.0);
    EXPECT_NEAR(sigma, std::sqrt(1.0 + 1.0 / 12.0), 0.1);
    EXPECT_NEAR(mean[0], 0.0, 0.02);
}

TEST(SimulateRender, SixteenBitBlurAndBackground) {
    const Calibration c = small_rig();
    Scene scene;
    scene.spheres.push_back({cv::Vec3d(0, 0, 400), 30, 0.9});  // nothing else: dark background
    SimulationOptions options = noiseless();
    const Simulator eight(c, scene, options);
    options.bit_depth = 16;
    const Simulator sixteen(c, scene, options);
    const cv::Mat pattern = uniform_pattern(c, 255);
    const cv::Mat image8 = eight.render(pattern, 0), image16 = sixteen.render(pattern, 0);
    ASSERT_EQ(image16.type(), CV_16UC1);
    for (int y = 0; y < image8.rows; y += 3)
        for (int x = 0; x < image8.cols; x += 3)
            ASSERT_NEAR(image16.at<uint16_t>(y, x) / 257.0, image8.at<uint8_t>(y, x), 0.5 + 1e-3);
    EXPECT_EQ(image8.at<uint8_t>(2, 2), 0) << "rays that hit nothing stay black";

    // Defocus: a sharp stripe pattern loses contrast at its edges.
    cv::Mat stripes(c.projector_size, CV_8U);
    for (int x = 0; x < stripes.cols; ++x) stripes.col(x).setTo((x / 4) % 2 ? 255 : 0);
    options.bit_depth = 8;
    const cv::Mat sharp = eight.render(stripes, 0);
    options.blur_sigma_px = 2.0;
    const cv::Mat blurred = Simulator(c, scene, options).render(stripes, 0);
    cv::Mat sharp_dx, blurred_dx;
    cv::Sobel(sharp, sharp_dx, CV_32F, 1, 0);
    cv::Sobel(blurred, blurred_dx, CV_32F, 1, 0);
    const cv::Rect centre(150, 100, 100, 100);
    EXPECT_LT(cv::norm(blurred_dx(centre), cv::NORM_L1), 0.6 * cv::norm(sharp_dx(centre), cv::NORM_L1));
}

TEST(SimulateRender, WrongPatternIsAnError) {
    const Calibration c = small_rig();
    Scene scene;
    scene.planes.push_back({cv::Vec3d(0, 0, 400), cv::Vec3d(0, 0, -1), 0.6});
    const Simulator simulator(c, scene);
    EXPECT_THROW(simulator.render(cv::Mat(100, 100, CV_8U, cv::Scalar(0)), 0), Error);
    EXPECT_THROW(simulator.render(cv::Mat(c.projector_size, CV_8UC3, cv::Scalar(0)), 0), Error);
    SimulationOptions bad;
    bad.bit_depth = 12;
    EXPECT_THROW(Simulator(c, scene, bad), Error);
}

// ---------------------------------------------------------------------------------------------
// Capture sets

TEST(SimulateCapture, OneImagePerFrameWithWhiteColourAndProgress) {
    const Calibration c = small_rig();
    PatternOptions patterns;
    patterns.projector_size = c.projector_size;
    patterns.shifts = 4;
    patterns.rows = false;
    const PatternSequence sequence = make_pattern_sequence(patterns);
    std::vector<double> fractions;
    const CaptureSet captures = simulate_capture(sequence, c, demo_scene(), {}, [&](double f, const std::string& stage) {
        EXPECT_EQ(stage, "simulate");
        fractions.push_back(f);
        return true;
    });
    ASSERT_EQ(captures.images.size(), sequence.frames.size());
    EXPECT_EQ(captures.sequence.frames.size(), sequence.frames.size());
    for (const cv::Mat& image : captures.images) {
        EXPECT_EQ(image.size(), c.camera_size);
        EXPECT_EQ(image.type(), CV_8UC1);
    }
    ASSERT_EQ(captures.white_colour.type(), CV_8UC3);
    ASSERT_EQ(captures.white_colour.size(), c.camera_size);
    ASSERT_FALSE(fractions.empty());
    EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
    EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));

    // White is brighter than black on the part, and the colour image is the white frame.
    int white_index = -1, black_index = -1;
    for (size_t i = 0; i < sequence.frames.size(); ++i) {
        if (sequence.frames[i].kind == FrameKind::White) white_index = int(i);
        if (sequence.frames[i].kind == FrameKind::Black) black_index = int(i);
    }
    ASSERT_GE(white_index, 0);
    ASSERT_GE(black_index, 0);
    EXPECT_GT(cv::mean(captures.images[white_index])[0], cv::mean(captures.images[black_index])[0] + 50);
    std::vector<cv::Mat> channels;
    cv::split(captures.white_colour, channels);
    EXPECT_EQ(cv::norm(channels[1], captures.images[white_index], cv::NORM_INF), 0.0);
}

TEST(SimulateCapture, MismatchedProjectorAndCancellationAreErrors) {
    const Calibration c = small_rig();
    PatternOptions patterns;
    patterns.projector_size = cv::Size(1024, 768);
    patterns.shifts = 3;
    try {
        simulate_capture(make_pattern_sequence(patterns), c, demo_scene());
        FAIL() << "expected an error";
    } catch (const Error& e) {
        EXPECT_EQ(e.subject(), "calibration");
        EXPECT_NE(std::string(e.what()).find("854x480"), std::string::npos) << e.what();
    }
    patterns.projector_size = c.projector_size;
    int calls = 0;
    try {
        simulate_capture(make_pattern_sequence(patterns), c, demo_scene(), {},
                         [&](double, const std::string&) { return ++calls < 3; });
        FAIL() << "expected cancellation";
    } catch (const Error& e) {
        EXPECT_EQ(e.subject(), "cancelled");
    }
}

// ---------------------------------------------------------------------------------------------
// The seed rig and the demo part

TEST(SimulateRig, SeedRigConvergesOnTheWorkingDistanceAndTheProjectorCoversTheField) {
    const Calibration c = seed_rig_calibration();
    EXPECT_EQ(c.camera_size, cv::Size(1600, 1200));
    EXPECT_EQ(c.projector_size, cv::Size(854, 480));
    EXPECT_LT(cv::norm(c.R.t() * c.R - cv::Matx33d::eye()), 1e-12);
    EXPECT_NEAR(cv::determinant(c.R), 1.0, 1e-12);
    const cv::Vec3d projector_centre = -(c.R.t() * c.T);
    EXPECT_NEAR(projector_centre[0], 150, 1e-9);
    EXPECT_NEAR(cv::norm(projector_centre), 150, 1e-9);

    // The working point lands near the middle of the projector image.
    const cv::Vec2d centre = opencv_project_to_projector(c, cv::Vec3d(0, 0, 400));
    EXPECT_NEAR(centre[0], 427, 40);
    EXPECT_NEAR(centre[1], 240, 20);

    // Every pixel on the border of the camera image, at 340, 400 and 460 mm, is inside the
    // projector image: the projector lights the whole field over the working range.
    for (double depth : {340.0, 400.0, 460.0}) {
        for (int i = 0; i <= 100; ++i) {
            const double t = i / 100.0;
            const cv::Point2d border[4] = {{t * 1599, 0}, {t * 1599, 1199}, {0, t * 1199}, {1599, t * 1199}};
            for (const cv::Point2d& pixel : border) {
                const cv::Vec3d ray = opencv_ray(c, pixel.x, pixel.y);
                const cv::Vec2d uv = opencv_project_to_projector(c, ray * (depth / ray[2]));
                EXPECT_TRUE(uv[0] > 0 && uv[0] < 853 && uv[1] > 0 && uv[1] < 479)
                    << "camera pixel " << pixel << " at " << depth << " mm -> projector " << uv;
            }
        }
    }
    // ~250 mm wide camera field at 400 mm.
    const double width_mm = 400 * (opencv_ray(c, 1599, 600)[0] / opencv_ray(c, 1599, 600)[2] -
                                   opencv_ray(c, 0, 600)[0] / opencv_ray(c, 0, 600)[2]);
    EXPECT_NEAR(width_mm, 255, 10);
}

TEST(SimulateRig, DemoPartIsInViewAndWellLit) {
    const Calibration c = seed_rig_calibration();
    const Scene scene = demo_scene();
    ASSERT_EQ(scene.planes.size(), 1u);
    ASSERT_EQ(scene.meshes.size(), 1u);
    ASSERT_EQ(scene.cylinders.size(), 1u);
    ASSERT_EQ(scene.spheres.size(), 1u);
    const Simulator simulator(c, scene, noiseless());
    const SimulatedGeometry& g = simulator.geometry();
    int part = 0, part_lit = 0, all_lit = 0;
    for (int y = 0; y < g.points.rows; ++y)
        for (int x = 0; x < g.points.cols; ++x) {
            const cv::Vec3f p = g.points.at<cv::Vec3f>(y, x);
            ASSERT_TRUE(valid(p));
            const bool lit = g.lit.at<uint8_t>(y, x) != 0;
            all_lit += lit;
            if (p[2] < 455) {
                ++part;
                part_lit += lit && g.shading.at<float>(y, x) > 0.15f;
            }
        }
    std::printf("demo: %d part pixels, %d of them well lit; %d of %zu pixels lit\n", part, part_lit, all_lit,
                g.points.total());
    EXPECT_GT(part, 150000);                  // the part fills a good share of the view
    EXPECT_GT(part_lit, part * 85 / 100);     // and the projector lights most of it well
    EXPECT_GT(all_lit, int(g.points.total() * 9 / 10));

    // The sphere is where the scene says: the pixel of its centre sees its front.
    const Sphere& ball = scene.spheres[0];
    std::vector<cv::Point2d> pixel;
    cv::projectPoints(std::vector<cv::Point3d>{cv::Point3d(ball.centre)}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                      cv::Mat(c.camera_matrix), c.camera_distortion, pixel);
    const cv::Vec3f front = g.points.at<cv::Vec3f>(int(std::lround(pixel[0].y)), int(std::lround(pixel[0].x)));
    EXPECT_NEAR(cv::norm(cv::Vec3d(front) - ball.centre), ball.radius_mm, 1e-3);
}

// ---------------------------------------------------------------------------------------------
// Scene files

TEST(SimulateSceneFile, ReadsEveryShapeFromYamlAndJson) {
    const std::string folder = test_support::make_temp_dir("scene");
    Mesh triangle;
    triangle.vertices = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}};
    triangle.faces.push_back(cv::Vec3i(0, 1, 2));
    write_stl(triangle, folder + "/part.stl");

    {
        std::ofstream yaml(folder + "/scene.yml");
        yaml << "%YAML:1.0\n"
                "spheres:\n"
                "  - { centre: [1, 2, 400], radius_mm: 12.5, albedo: 0.7 }\n"
                "planes:\n"
                "  - { point: [0, 0, 470], normal: [0, 0, -2] }\n"
                "boxes:\n"
                "  - { centre: [0, 0, 420], half_size_mm: [40, 25, 12.5], rotation_deg: [0, 90, 0], albedo: 0.5 }\n"
                "  - { centre: [0, 0, 420], half_size_mm: [1, 2, 3], rotation: [[0, -1, 0], [1, 0, 0], [0, 0, 1]] }\n"
                "cylinders:\n"
                "  - { base_centre: [0, 0, 400], axis: [0, 0, -1], radius_mm: 9, height_mm: 12, albedo: 0.8 }\n"
                "meshes:\n"
                "  - { file: part.stl, albedo: 0.6, translation: [0, 0, 400] }\n";
    }
    const Scene scene = read_scene(folder + "/scene.yml");
    ASSERT_EQ(scene.spheres.size(), 1u);
    EXPECT_EQ(scene.spheres[0].centre, cv::Vec3d(1, 2, 400));
    EXPECT_DOUBLE_EQ(scene.spheres[0].radius_mm, 12.5);
    EXPECT_DOUBLE_EQ(scene.spheres[0].albedo, 0.7);
    ASSERT_EQ(scene.planes.size(), 1u);
    EXPECT_LT(cv::norm(scene.planes[0].normal - cv::Vec3d(0, 0, -1)), 1e-12);
    EXPECT_DOUBLE_EQ(scene.planes[0].albedo, 0.8);  // default
    ASSERT_EQ(scene.boxes.size(), 2u);
    // 90 degrees about y takes x to -z.
    EXPECT_LT(cv::norm(scene.boxes[0].rotation * cv::Vec3d(1, 0, 0) - cv::Vec3d(0, 0, -1)), 1e-12);
    EXPECT_LT(cv::norm(scene.boxes[1].rotation * cv::Vec3d(1, 0, 0) - cv::Vec3d(0, 1, 0)), 1e-12);
    ASSERT_EQ(scene.cylinders.size(), 1u);
    EXPECT_DOUBLE_EQ(scene.cylinders[0].height_mm, 12);
    ASSERT_EQ(scene.meshes.size(), 1u);
    ASSERT_EQ(scene.meshes[0].mesh.faces.size(), 1u);
    EXPECT_FLOAT_EQ(scene.meshes[0].mesh.vertices[1][0], 10.f);
    EXPECT_FLOAT_EQ(scene.meshes[0].mesh.vertices[1][2], 400.f);
    EXPECT_DOUBLE_EQ(scene.meshes[0].albedo, 0.6);

    {
        std::ofstream json(folder + "/scene.json");
        json << R"({"spheres": [{"centre": [0, 0, 400], "radius_mm": 20}],
                    "meshes": [{"file": "part.stl"}]})";
    }
    const Scene from_json = read_scene(folder + "/scene.json");
    ASSERT_EQ(from_json.spheres.size(), 1u);
    EXPECT_DOUBLE_EQ(from_json.spheres[0].radius_mm, 20);
    ASSERT_EQ(from_json.meshes.size(), 1u);

    // Hand-written YAML without OpenCV's "%YAML:1.0" line, block style.
    std::ofstream(folder + "/plain.yaml") << "# a comment\nspheres:\n  - centre: [0, 0, 380]\n    radius_mm: 7\n";
    const Scene plain = read_scene(folder + "/plain.yaml");
    ASSERT_EQ(plain.spheres.size(), 1u);
    EXPECT_DOUBLE_EQ(plain.spheres[0].radius_mm, 7);
}

TEST(SimulateSceneFile, ErrorsNameTheFileAndTheKey) {
    const std::string folder = test_support::make_temp_dir("scene-errors");
    auto expect_error = [&](const std::string& text, const std::string& needle) {
        const std::string path = folder + "/bad.json";
        std::ofstream(path) << text;
        try {
            read_scene(path);
            ADD_FAILURE() << "no error for " << text;
        } catch (const Error& e) {
            EXPECT_EQ(e.subject(), path);
            EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
        }
    };
    expect_error(R"({"spheres": [{"centre": [0, 0, 400]}]})", "radius_mm");
    expect_error(R"({"spheres": [{"centre": [0, 0], "radius_mm": 3}]})", "centre");
    expect_error(R"({"spheres": [{"centre": [0, 0, 400], "radius_mm": -3}]})", "radius_mm");
    expect_error(R"({"planes": [{"point": [0, 0, 400], "normal": [0, 0, 0]}]})", "normal");
    expect_error(R"({"boxes": [{"centre": [0, 0, 400], "half_size_mm": [1, 1, 1], "rotation": [1, 2, 3, 4, 5, 6, 7, 8, 9]}]})",
                 "rotation");
    expect_error(R"({"cylinders": [{"base_centre": [0, 0, 400], "axis": [0, 0, 1], "radius_mm": 3}]})", "height_mm");
    expect_error(R"({"spheres": [{"centre": [0, 0, 400], "radius_mm": 3, "albedo": 1.5}]})", "albedo");
    expect_error(R"({"meshes": [{"albedo": 0.5}]})", "file");
    expect_error(R"({"sphere": []})", "sphere");
    expect_error(R"({"spheres": {"centre": [0, 0, 400]}})", "spheres");
    expect_error(R"({"spheres": [{"centre": [0, 0, 400], "radius_mm": 3)", "parse");
    expect_error("", "empty");

    // A missing mesh file is reported by the mesh reader, naming that file.
    std::ofstream(folder + "/missing.json") << R"({"meshes": [{"file": "nowhere.stl"}]})";
    try {
        read_scene(folder + "/missing.json");
        ADD_FAILURE() << "no error for a missing mesh";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("nowhere.stl"), std::string::npos) << e.what();
    }
    EXPECT_THROW(read_scene(folder + "/does-not-exist.yml"), Error);
}

TEST(SimulateSceneFile, InvalidSceneObjectsAreRejectedBySimulator) {
    Scene scene;
    scene.spheres.push_back({cv::Vec3d(0, 0, 400), -1, 0.5});
    EXPECT_THROW(Simulator(small_rig(), scene), Error);
    scene.spheres.clear();
    Mesh mesh;
    mesh.vertices = {{0, 0, 400}, {1, 0, 400}};
    mesh.faces.push_back(cv::Vec3i(0, 1, 2));
    scene.meshes.push_back({mesh, 0.5});
    EXPECT_THROW(Simulator(small_rig(), scene), Error);
}
