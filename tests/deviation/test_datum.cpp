// 3-2-1 datum alignment: planes fitted to noisy points of a box's faces, seen in a scan frame that
// is turned and shifted, must give back the box's own frame; datums that do not fix a frame
// (parallel planes, a third plane along the line) are refused with the reason.
#include "picoscan/error.h"
#include "picoscan/fit.h"
#include "picoscan/pipeline.h"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include <cmath>
#include <random>

using namespace picoscan;

namespace {

// Points on the rectangle of the plane `axis` = `level` of the part frame, spanning [0, 40] on the
// other axes, with Gaussian noise along the normal, then moved into the scan frame by (R, t).
std::vector<cv::Vec3f> face_points(int axis, double level, double noise_mm, const cv::Matx33d& rotation, const cv::Vec3d& shift,
                                   std::mt19937& random) {
    std::uniform_real_distribution<double> along(2.0, 38.0);
    std::normal_distribution<double> unit_noise;  // scaled: its deviation must be positive, and noise_mm may be 0
    const auto noise = [&](auto& engine) { return noise_mm * unit_noise(engine); };
    std::vector<cv::Vec3f> points;
    for (int i = 0; i < 4000; ++i) {
        cv::Vec3d part(along(random), along(random), along(random));
        part[axis] = level + noise(random);
        points.emplace_back(rotation * part + shift);
    }
    return points;
}

double angle_deg(const cv::Vec3d& a, const cv::Vec3d& b) {
    return std::acos(std::clamp(a.dot(b) / (cv::norm(a) * cv::norm(b)), -1.0, 1.0)) * 180 / CV_PI;
}

PlaneFit turned_towards(PlaneFit plane, const cv::Vec3d& direction) {
    if (plane.normal.dot(direction) < 0) {
        plane.normal = -plane.normal;
        plane.offset_mm = -plane.offset_mm;
    }
    return plane;
}

struct Pose {
    cv::Matx33d rotation;
    cv::Vec3d shift;
};

Pose scan_pose(double angle_deg_, const cv::Vec3d& axis, const cv::Vec3d& shift) {
    cv::Matx33d rotation;
    cv::Rodrigues(cv::Vec3d(axis / cv::norm(axis) * angle_deg_ * CV_PI / 180), rotation);
    return {rotation, shift};
}

}  // namespace

TEST(Datum, PlanesOfANoisyTurnedBoxGiveItsOwnFrame) {
    // The box's bottom (z = 0), back (y = 0) and left (x = 0) faces are the datums A, B, C.
    for (const double noise : {0.0, 0.02, 0.05}) {
        for (const Pose& pose : {scan_pose(35, {1, -2, 0.5}, {12, -30, 410}), scan_pose(170, {0.2, 1, 0.1}, {-80, 5, 350})}) {
            std::mt19937 random(7);
            const auto fit = [&](int axis, const cv::Vec3d& outward_in_part) {
                return turned_towards(fit_plane(face_points(axis, 0.0, noise, pose.rotation, pose.shift, random)),
                                      pose.rotation * outward_in_part);
            };
            // Normals pointing into the part (its material side): the frame's axes then point into it.
            const PlaneFit bottom = fit(2, {0, 0, 1}), back = fit(1, {0, 1, 0}), left = fit(0, {1, 0, 0});
            const DatumFrame frame = datum_frame(bottom, back, left);
            const double tilt = angle_deg(frame.z_axis, pose.rotation * cv::Vec3d(0, 0, 1));
            const double turn = angle_deg(frame.x_axis, pose.rotation * cv::Vec3d(1, 0, 0));
            const double shift = cv::norm(frame.origin - pose.shift);
            std::printf("noise %.2f mm: Z off %.4f deg, X off %.4f deg, origin off %.4f mm, angles %.3f %.3f %.3f\n", noise,
                        tilt, turn, shift, frame.primary_secondary_deg, frame.primary_tertiary_deg, frame.secondary_tertiary_deg);
            // 4000 points over 36 mm: the tilt is known to about noise / (36 mm sqrt(4000 / 12)) rad.
            const double bound_deg = 0.001 + 6 * noise / (36 * std::sqrt(4000.0 / 12)) * 180 / CV_PI;
            EXPECT_LT(tilt, bound_deg);
            EXPECT_LT(turn, 2 * bound_deg);
            EXPECT_LT(shift, 0.001 + 0.3 * noise);
            EXPECT_NEAR(frame.primary_secondary_deg, 90, 0.1);
            // The scan's corner goes to the part's origin, and a point 10 mm up its Z edge to (0, 0, 10).
            const cv::Vec4d corner = frame.part_from_scan * cv::Vec4d(pose.shift[0], pose.shift[1], pose.shift[2], 1);
            EXPECT_LT(cv::norm(cv::Vec3d(corner[0], corner[1], corner[2])), 0.001 + 0.3 * noise);
            const cv::Vec3d up = pose.rotation * cv::Vec3d(5, 7, 10) + pose.shift;
            const cv::Vec4d mapped = frame.part_from_scan * cv::Vec4d(up[0], up[1], up[2], 1);
            EXPECT_NEAR(mapped[0], 5, 0.001 + 0.5 * noise);
            EXPECT_NEAR(mapped[1], 7, 0.001 + 0.5 * noise);
            EXPECT_NEAR(mapped[2], 10, 0.001 + 0.5 * noise);
            // A point for the origin instead of the third plane: the line's point nearest to it.
            const cv::Vec3d near_corner = pose.rotation * cv::Vec3d(0.0, 3.0, -2.0) + pose.shift;
            const DatumFrame by_point = datum_frame(bottom, back, near_corner);
            EXPECT_LT(cv::norm(by_point.origin - pose.shift), 0.001 + 0.5 * noise);
        }
    }
}

TEST(Datum, ARightHandedFrameEvenWhenANormalIsTurned) {
    const PlaneFit bottom = PlaneFit{{0, 0, -1}, -5, 0, 0};  // z = 5, normal down
    const PlaneFit back = PlaneFit{{0, 1, 0}, 2, 0, 0};
    const PlaneFit left = PlaneFit{{1, 0, 0}, -3, 0, 0};
    const DatumFrame frame = datum_frame(bottom, back, left);
    EXPECT_NEAR(frame.z_axis.dot(cv::Vec3d(0, 0, -1)), 1, 1e-12);
    EXPECT_NEAR(frame.x_axis.cross(frame.y_axis).dot(frame.z_axis), 1, 1e-12);
    EXPECT_NEAR(cv::norm(frame.origin - cv::Vec3d(-3, 2, 5)), 0, 1e-12);
    EXPECT_NEAR(cv::determinant(cv::Matx33d(frame.part_from_scan.get_minor<3, 3>(0, 0))), 1, 1e-12);
}

TEST(Datum, ParallelOrUselessDatumsAreRefusedWithTheReason) {
    const PlaneFit bottom{{0, 0, 1}, 0, 0, 0};
    const PlaneFit top{{0, 0.05, -1}, -20, 0, 0};  // 2.9 degrees from parallel to the bottom
    const PlaneFit back{{0, 1, 0}, 0, 0, 0};
    const PlaneFit left{{1, 0, 0}, 0, 0, 0};
    try {
        datum_frame(bottom, top, left);
        FAIL() << "parallel primary and secondary accepted";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("secondary"), std::string::npos) << error.what();
        EXPECT_NE(std::string(error.what()).find("2.86 degrees from parallel"), std::string::npos) << error.what();
    }
    // A third plane containing the X line (the side y = 0 again, slightly turned) fixes no origin.
    try {
        datum_frame(bottom, back, PlaneFit{{0.02, 1, 0.1}, 4, 0, 0});
        FAIL() << "a third plane along the line accepted";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("tertiary"), std::string::npos) << error.what();
    }
    EXPECT_THROW(datum_frame(bottom, back, left, DatumOptions{0.0}), Error);
    EXPECT_THROW(datum_frame(PlaneFit{{0, 0, 0}, 0, 0, 0}, back, left), Error);
    EXPECT_THROW(frame_from_axis({0, 0, 0}, {0, 0, 1}, {0, 0, 3}), Error);
    // Near-parallel but above the threshold: accepted, with the angle reported.
    const DatumFrame skew = datum_frame(bottom, PlaneFit{{0, 1, 0.5}, 0, 0, 0}, left);
    EXPECT_NEAR(skew.primary_secondary_deg, std::acos(0.5 / std::sqrt(1.25)) * 180 / CV_PI, 1e-9);
}

TEST(Datum, FrameFromAnAxis) {
    const DatumFrame frame = frame_from_axis({1, 2, 3}, {0, -2, 0}, {1, 0, 1});
    EXPECT_NEAR(cv::norm(frame.z_axis - cv::Vec3d(0, -1, 0)), 0, 1e-12);
    EXPECT_NEAR(cv::norm(frame.x_axis - cv::Vec3d(1, 0, 1) / std::sqrt(2.0)), 0, 1e-12);
    const cv::Vec4d origin = frame.part_from_scan * cv::Vec4d(1, 2, 3, 1);
    EXPECT_NEAR(cv::norm(cv::Vec3d(origin[0], origin[1], origin[2])), 0, 1e-12);
}

namespace {

// A camera's cloud of a 30 mm cube standing on a 200 x 200 mm table, the table turned 40 degrees
// about x towards a camera 400 mm away (normals towards the camera), with 20 um noise.
PointCloud cube_on_table(const cv::Matx33d& table_to_camera, const cv::Vec3d& table_origin, bool with_table) {
    std::mt19937 random(5);
    std::uniform_real_distribution<double> across(-100.0, 100.0), side(0.0, 30.0);
    std::normal_distribution<double> noise(0.0, 0.02);
    PointCloud cloud;
    const auto add = [&](const cv::Vec3d& local, const cv::Vec3d& normal) {
        const cv::Vec3d point = table_to_camera * (local + noise(random) * normal) + table_origin;
        cloud.points.emplace_back(point);
        cloud.normals.emplace_back(table_to_camera * normal);
    };
    for (int i = 0; with_table && i < 20000; ++i) {
        const cv::Vec3d local(across(random), across(random), 0.0);
        if (std::abs(local[0] - 5) < 15 && std::abs(local[1] - 10) < 15) continue;  // under the cube
        add(local, {0, 0, 1});
    }
    for (int i = 0; i < 6000; ++i) {  // the cube's top and the two sides the camera sees
        const double u = side(random), v = side(random);
        add({-10 + u, -5 + v, 30}, {0, 0, 1});
        add({-10 + u, -5, v}, {0, -1, 0});
    }
    return cloud;
}

}  // namespace

TEST(PartFrame, TheBasePlaneIsZUpAndItsOriginIsUnderThePart) {
    cv::Matx33d tilt;
    cv::Rodrigues(cv::Vec3d(-40 * CV_PI / 180, 0, 0), tilt);  // the table's normal turns towards the camera (-z)
    const cv::Matx33d table_to_camera = tilt * cv::Matx33d(1, 0, 0, 0, -1, 0, 0, 0, -1);
    const cv::Vec3d table_origin(10, 20, 420);
    const PartFrame result = part_frame(cube_on_table(table_to_camera, table_origin, true));
    std::printf("part frame: %s, Z off %.4f deg\n", result.basis.c_str(),
                angle_deg(result.frame.z_axis, table_to_camera * cv::Vec3d(0, 0, 1)));
    EXPECT_NE(result.basis.find("base plane"), std::string::npos);
    EXPECT_LT(angle_deg(result.frame.z_axis, table_to_camera * cv::Vec3d(0, 0, 1)), 0.02);
    // The origin is on the table, under the middle of the cube's visible points (x 5, y about 5).
    const cv::Vec4d origin = result.frame.part_from_scan * cv::Vec4d(table_origin[0], table_origin[1], table_origin[2], 1);
    EXPECT_NEAR(origin[2], 0.0, 0.01);  // the table's origin is on the frame's z = 0
    const cv::Vec3d middle = table_to_camera.t() * (result.frame.origin - table_origin);
    EXPECT_NEAR(middle[0], 5.0, 1.0);
    EXPECT_NEAR(middle[2], 0.0, 0.01);
}

TEST(PartFrame, TheTurntableAxisIsZUpWhicheverWayItTurns) {
    const cv::Matx33d table_to_camera(1, 0, 0, 0, 0, -1, 0, 1, 0);  // the table's up is the camera's -y
    const PointCloud cloud = cube_on_table(table_to_camera, {0, 30, 400}, false);
    for (const double sign : {1.0, -1.0}) {
        TurntableAxis axis;
        axis.point_mm = cv::Vec3d(5, 0, 400);
        axis.direction = sign * cv::Vec3d(0, -1, 0);
        const PartFrame result = part_frame(cloud, axis);
        EXPECT_NE(result.basis.find("turntable axis"), std::string::npos);
        EXPECT_NEAR(result.frame.z_axis.dot(cv::Vec3d(0, -1, 0)), 1.0, 1e-12);
        // The cube's lowest visible points (its side's foot, y = 30 in the camera) are z = 0.
        EXPECT_NEAR(result.frame.origin[1], 30.0, 0.2);
        EXPECT_NEAR(result.frame.origin[0], 5.0, 1e-9);
    }
}

TEST(PartFrame, NoPlaneToStandOnOrNoNormalsIsRefused) {
    // A ball alone: nothing to stand on.
    std::mt19937 random(9);
    std::normal_distribution<double> gauss(0.0, 1.0);
    PointCloud ball;
    for (int i = 0; i < 20000; ++i) {
        cv::Vec3d direction(gauss(random), gauss(random), gauss(random));
        direction /= cv::norm(direction);
        ball.points.emplace_back(cv::Vec3d(0, 0, 400) + 20 * direction);
        ball.normals.emplace_back(direction);
    }
    try {
        part_frame(ball);
        FAIL() << "a ball got a base plane";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("no plane holding 5 % of its points"), std::string::npos) << error.what();
    }
    PointCloud bare = ball;
    bare.normals.clear();
    EXPECT_THROW(part_frame(bare), Error);
    PartFrameOptions options;
    options.min_plane_share = 1.5;
    EXPECT_THROW(part_frame(ball, std::nullopt, options), Error);
    EXPECT_THROW(part_frame(PointCloud{}), Error);
}
