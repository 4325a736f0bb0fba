// What the registration refuses at its entry, whoever calls it: views made in memory (Python,
// FreeCAD) never pass read_view_ply's checks, so align_views, align_placements and
// register_pair check the views themselves, naming the view. And the grids stay defined for
// any coordinates a pose or a cloud can produce.
#include "../../core/src/register/point_grid.h"
#include "../../core/src/register/visibility.h"
#include "picoscan/error.h"
#include "picoscan/pipeline.h"
#include "picoscan/register.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>
#include <vector>

using namespace picoscan;

namespace {

// A 40 x 40 pixel patch of a plane 400 mm in front of the camera, 1 mm apart.
ScanView plane_view() {
    ScanView view;
    view.points.create(40, 40, CV_32FC3);
    view.normals = cv::Mat(40, 40, CV_32FC3, cv::Scalar(0, 0, -1));
    for (int y = 0; y < 40; ++y)
        for (int x = 0; x < 40; ++x) view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(float(x), float(y), 400.f);
    return view;
}

template <class Call>
std::string error_of(Call&& call) {
    try {
        call();
    } catch (const Error& error) {
        return error.what();
    }
    return "(no error)";
}

}  // namespace

TEST(RegisterRefusals, ViewsBeyondAKilometreAreRefusedNamingTheView) {
    const ScanView near = plane_view();
    ScanView far = plane_view();
    far.points.at<cv::Vec3f>(3, 7) = cv::Vec3f(1e15f, 0.f, 400.f);
    ScanView below = plane_view();
    below.points.at<cv::Vec3f>(0, 1) = cv::Vec3f(0.f, -2e6f, 400.f);
    const std::string far_message = "point at pixel (7, 3) lies beyond 1 km (1e6 mm) from the origin";
    EXPECT_NE(error_of([&] { align_views({near, far}, {"a.ply", "b.ply"}); }).find("b.ply: " + far_message),
              std::string::npos);
    EXPECT_NE(error_of([&] { align_views({below, near}, {"a.ply", "b.ply"}); }).find("a.ply: point at pixel (1, 0)"),
              std::string::npos);
    EXPECT_NE(error_of([&] { register_pair(near, far); }).find("moving view: " + far_message), std::string::npos);
    PlacementPlan first, second;
    first.views = {0};
    second.views = {1};
    EXPECT_NE(error_of([&] { align_placements({near, far}, {"a.ply", "b.ply"}, {first, second}); }).find("b.ply: " + far_message),
              std::string::npos);
    // Unmeasured points (NaN, inf) are skipped as every stage skips them; 999 m is within reach.
    ScanView unmeasured = plane_view();
    unmeasured.points.at<cv::Vec3f>(2, 2) = cv::Vec3f(std::numeric_limits<float>::quiet_NaN(), 0.f, 0.f);
    unmeasured.points.at<cv::Vec3f>(2, 3) = cv::Vec3f(0.f, std::numeric_limits<float>::infinity(), 0.f);
    unmeasured.points.at<cv::Vec3f>(2, 4) = cv::Vec3f(0.f, -999999.f, 400.f);
    EXPECT_EQ(error_of([&] { register_pair(near, unmeasured); }), "(no error)");
}

TEST(RegisterRefusals, ArraysOptionsAndGuessesThatCannotBeUsedAreRefused) {
    const ScanView view = plane_view();
    ScanView doubles = plane_view();
    view.points.convertTo(doubles.points, CV_64FC3);  // a NumPy float64 array: rows read as floats overrun nothing, mean nothing
    EXPECT_EQ(error_of([&] { align_views({view, doubles}, {"a", "b"}); }), "b: points must be CV_32FC3");
    ScanView short_normals = plane_view();
    short_normals.normals = cv::Mat(20, 40, CV_32FC3, cv::Scalar(0, 0, -1));  // read at rows 20..39: past the buffer
    EXPECT_EQ(error_of([&] { register_pair(short_normals, view); }), "fixed view: normals size does not match the points");
    RegistrationOptions options;
    options.sample_spacing_mm = 0;  // every cell key a division by zero
    EXPECT_NE(error_of([&] { align_views({view, view}, {"a", "b"}, options); }).find("registration.sample_spacing_mm"),
              std::string::npos);
    options = RegistrationOptions();
    options.initial_poses = {cv::Matx44d::eye(), cv::Matx44d::eye()};
    options.initial_poses[1](0, 3) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(error_of([&] { align_views({view, view}, {"a", "b"}, options); }), "initial poses: the pose of b is not finite");
    TurntableAxis axis;
    axis.point_mm = cv::Vec3d(0, 0, 400);
    axis.direction = cv::Vec3d(0, 0, 0);
    EXPECT_NE(error_of([&] { align_views({view, view}, {"a", "b"}, {}, axis); }).find("turntable: the axis needs"),
              std::string::npos);
}

TEST(RegisterGrids, PointsAndQueriesFarAwayOrNaNKeepTheGridsDefined) {
    // Before: the cell of 1e20 mm converted floor(1e20 / 3) to long long (undefined; x86 gives
    // LLONG_MIN), and NearestGrid's box from cell 0 to it overflowed (signed, then a
    // vector of 2^63 entries).
    const std::vector<cv::Vec3d> points = {{0, 0, 0}, {1e20, 0, 0}, {-1e20, 5, 0}, {std::numeric_limits<double>::quiet_NaN(), 0, 0}};
    const detail::NearestGrid nearest_grid(points, 3.0);
    detail::SearchMemory memory;
    EXPECT_EQ(nearest_grid.nearest_remembered({0.5, 0, 0}, 3.0, memory), 0);
    detail::SearchMemory far_memory;
    EXPECT_EQ(nearest_grid.nearest_remembered({1e20, 0, 0}, 3.0, far_memory), 1);
    detail::SearchMemory nan_memory;
    EXPECT_EQ(nearest_grid.nearest_remembered({std::numeric_limits<double>::quiet_NaN(), 0, 0}, 3.0, nan_memory), -1);
    const detail::PointGrid grid(points, 3.0);
    EXPECT_EQ(grid.nearest({0.5, 0, 0}, 3.0), 0);
    EXPECT_EQ(grid.nearest({1e20, 0, 0}, 3.0), 1);
    EXPECT_EQ(grid.nearest({-1e20, 5, 0}, 3.0), 2);
    EXPECT_EQ(grid.nearest({1e30, 0, 0}, 3.0), -1);  // same clamped cell as 1e20, but 1e30 mm away
    EXPECT_EQ(grid.nearest({std::numeric_limits<double>::quiet_NaN(), 0, 0}, 3.0), -1);
}

TEST(RegisterGrids, ACameraMatrixThatDoesNotFitTheViewLeavesAFreeSpaceMapOfBoundedSize) {
    // The pinhole's misfit sets the erosion radius: a principal point at 1e30 px made it
    // 2 + (int)2e30 (undefined; x86 gives INT_MIN), and OpenCV refused the negative kernel.
    ScanView view = plane_view();
    view.camera_matrix = cv::Matx33d(2500, 0, 1e30, 0, 2500, 1e30, 0, 0, 1);
    const detail::ViewCamera camera = detail::view_camera(view, detail::measured_bounds(view));
    ASSERT_TRUE(camera.valid());
    EXPECT_EQ(camera.nearest_depth.size(), cv::Size(40, 40));
    // Points projecting far outside the map (at 1e30 px, just in front of the camera, NaN) are
    // left out: lround's out-of-range result wrapped them into pixel (0, 0) before.
    const detail::FreeSpaceCheck check = detail::free_space_violations(
        camera, {{20, 20, 300}, {1, 1, 1e-30}, {std::numeric_limits<double>::quiet_NaN(), 0, 1}}, 0.5);
    EXPECT_EQ(check.checked, 0u);
}

// A first view without a measured point is the model's frame: the views left out against it
// and an empty merged cloud were written, with "1 of 2 views merged, 0 points" and exit 3. Now
// refused, naming it; an empty later view is still left out with its reason.
TEST(RegisterRefusals, AStitchWhoseFirstViewIsEmptyIsRefusedNamingIt) {
    ScanView empty = plane_view();
    empty.points.setTo(cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
    const std::string refusal = error_of([&] { stitch_views({empty, plane_view()}, {"empty.ply", "b.ply"}); });
    EXPECT_NE(refusal.find("empty.ply: holds no measured point"), std::string::npos) << refusal;
    const StitchResult later = stitch_views({plane_view(), empty}, {"a.ply", "empty.ply"});
    EXPECT_EQ(later.merged_views, std::vector<size_t>{0});
    EXPECT_FALSE(later.alignment.views[1].aligned);
    EXPECT_GT(later.merged.points.size(), 1000u);
}
