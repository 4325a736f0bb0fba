// ScanView -> PointCloud and grid_mesh.
#include "picoscan/cloud.h"
#include "picoscan/error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <set>

namespace picoscan {
namespace {

const float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr double kFocal = 1000.0;

// An organised view of a surface z = depth(x, y) seen by a pinhole camera (focal kFocal,
// principal point at the image centre), with colours and normals per pixel.
ScanView pinhole_view(int width, int height, const std::function<double(int, int)>& depth) {
    ScanView view;
    view.points.create(height, width, CV_32FC3);
    view.normals.create(height, width, CV_32FC3);
    view.colours.create(height, width, CV_8UC3);
    view.quality.create(height, width, CV_32F);
    const double cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
    view.camera_matrix = cv::Matx33d(kFocal, 0, cx, 0, kFocal, cy, 0, 0, 1);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const double z = depth(x, y);
            view.points.at<cv::Vec3f>(y, x) = cv::Vec3f(static_cast<float>((x - cx) / kFocal * z),
                                                        static_cast<float>((y - cy) / kFocal * z),
                                                        static_cast<float>(z));
            view.normals.at<cv::Vec3f>(y, x) = cv::Vec3f(0, 0, -1);
            view.colours.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uchar>(x), static_cast<uchar>(y), 200);
            view.quality.at<float>(y, x) = static_cast<float>(x + 100 * y);
        }
    return view;
}

cv::Vec3f winding_normal(const Mesh& mesh, const cv::Vec3i& face) {
    const cv::Vec3f a = mesh.vertices[face[0]], b = mesh.vertices[face[1]], c = mesh.vertices[face[2]];
    return (b - a).cross(c - a);
}

void expect_faces_towards_camera(const Mesh& mesh) {
    for (const cv::Vec3i& face : mesh.faces) {
        const cv::Vec3f n = winding_normal(mesh, face);
        const cv::Vec3f centre = (mesh.vertices[face[0]] + mesh.vertices[face[1]] + mesh.vertices[face[2]]) / 3.0f;
        ASSERT_LT(n.dot(centre), 0) << "face " << face << " points away from the camera";
    }
}

TEST(ScanView, ValidCountSkipsNonFinite) {
    ScanView view = pinhole_view(4, 3, [](int, int) { return 100.0; });
    EXPECT_EQ(view.valid_count(), 12);
    view.points.at<cv::Vec3f>(0, 0)[2] = kNaN;
    view.points.at<cv::Vec3f>(1, 2)[0] = std::numeric_limits<float>::infinity();
    view.points.at<cv::Vec3f>(2, 3) = cv::Vec3f(kNaN, kNaN, kNaN);
    EXPECT_EQ(view.valid_count(), 9);
    EXPECT_EQ(ScanView{}.valid_count(), 0);
}

TEST(ScanView, PointCloudTransformsByPoseAndConvertsColours) {
    ScanView view = pinhole_view(5, 4, [](int x, int y) { return 300.0 + x + 2 * y; });
    view.points.at<cv::Vec3f>(1, 1) = cv::Vec3f(kNaN, kNaN, kNaN);
    view.normals.at<cv::Vec3f>(2, 3) = cv::Vec3f(1, 0, 0);
    // 90 degrees about z, then a shift.
    view.pose = cv::Matx44d(0, -1, 0, 10,
                            1, 0, 0, 20,
                            0, 0, 1, 30,
                            0, 0, 0, 1);
    const PointCloud cloud = to_point_cloud(view);
    ASSERT_EQ(cloud.points.size(), 19u);
    ASSERT_EQ(cloud.normals.size(), 19u);
    ASSERT_EQ(cloud.colours.size(), 19u);
    ASSERT_EQ(cloud.quality.size(), 19u);
    // Row-major order: pixel (x=3, y=2) is index 2*5+3 minus the one invalid pixel before it.
    const size_t i = 2 * 5 + 3 - 1;
    const cv::Vec3f p = view.points.at<cv::Vec3f>(2, 3);
    EXPECT_NEAR(cloud.points[i][0], -p[1] + 10, 1e-4);
    EXPECT_NEAR(cloud.points[i][1], p[0] + 20, 1e-4);
    EXPECT_NEAR(cloud.points[i][2], p[2] + 30, 1e-4);
    EXPECT_NEAR(cloud.normals[i][0], 0, 1e-6);
    EXPECT_NEAR(cloud.normals[i][1], 1, 1e-6);
    EXPECT_EQ(cloud.colours[i], cv::Vec3b(200, 2, 3));  // BGR (3, 2, 200) -> RGB
    EXPECT_EQ(cloud.quality[i], 203.0f);
}

TEST(ScanView, OptionalLayersMayBeAbsentButNotMismatched) {
    ScanView view = pinhole_view(3, 3, [](int, int) { return 50.0; });
    view.normals.release();
    view.quality.release();
    const PointCloud cloud = to_point_cloud(view);
    EXPECT_EQ(cloud.points.size(), 9u);
    EXPECT_TRUE(cloud.normals.empty());
    EXPECT_TRUE(cloud.quality.empty());
    EXPECT_EQ(cloud.colours.size(), 9u);

    view.colours = cv::Mat(2, 3, CV_8UC3, cv::Scalar::all(0));
    EXPECT_THROW(to_point_cloud(view), Error);
    EXPECT_THROW(grid_mesh(view), Error);
    view.colours.release();
    view.quality = cv::Mat(3, 3, CV_64F, cv::Scalar::all(0));
    EXPECT_THROW(to_point_cloud(view), Error);
    EXPECT_TRUE(to_point_cloud(ScanView{}).points.empty());
}

TEST(GridMesh, SmoothPlaneIsJoinedFully) {
    const int width = 40, height = 30;
    // A plane tilted in x and y, well within the default edge factor.
    const ScanView view = pinhole_view(width, height, [](int x, int y) { return 400.0 + 0.3 * x - 0.2 * y; });
    const Mesh mesh = grid_mesh(view);
    EXPECT_EQ(mesh.faces.size(), static_cast<size_t>((width - 1) * (height - 1) * 2));
    EXPECT_EQ(mesh.vertices.size(), static_cast<size_t>(width * height));
    EXPECT_EQ(mesh.normals.size(), mesh.vertices.size());
    EXPECT_EQ(mesh.colours.size(), mesh.vertices.size());
    expect_faces_towards_camera(mesh);
    // Every face normal agrees with the stored vertex normal (towards the camera).
    for (const cv::Vec3i& face : mesh.faces) EXPECT_GT(winding_normal(mesh, face).dot(mesh.normals[face[0]]), 0);
    // Vertices are the pixels in row-major order, colours BGR -> RGB.
    EXPECT_EQ(mesh.vertices[width + 2], view.points.at<cv::Vec3f>(1, 2));
    EXPECT_EQ(mesh.colours[width + 2], cv::Vec3b(200, 1, 2));
}

TEST(GridMesh, WindingFacesTheCameraWhateverTheTilt) {
    for (const auto& slope : {cv::Vec2d(3, 0), cv::Vec2d(-3, 0), cv::Vec2d(0, 3), cv::Vec2d(0, -3), cv::Vec2d(1, 1)}) {
        const ScanView view = pinhole_view(12, 10, [&](int x, int y) { return 200.0 + slope[0] * x * 0.1 + slope[1] * y * 0.1; });
        const Mesh mesh = grid_mesh(view);
        EXPECT_EQ(mesh.faces.size(), 11u * 9u * 2u);
        expect_faces_towards_camera(mesh);
    }
}

TEST(GridMesh, DepthStepIsNotBridged) {
    const int width = 20, height = 12;
    const ScanView view = pinhole_view(width, height, [](int x, int) { return x < 10 ? 400.0 : 450.0; });
    const Mesh mesh = grid_mesh(view);
    // The column of quads across the step is dropped, everything else is joined.
    EXPECT_EQ(mesh.faces.size(), static_cast<size_t>((width - 2) * (height - 1) * 2));
    for (const cv::Vec3i& face : mesh.faces) {
        const bool near0 = mesh.vertices[face[0]][2] < 425, near1 = mesh.vertices[face[1]][2] < 425,
                   near2 = mesh.vertices[face[2]][2] < 425;
        EXPECT_TRUE(near0 == near1 && near1 == near2) << "face " << face << " spans the step";
    }
    expect_faces_towards_camera(mesh);
}

TEST(GridMesh, HolesAndIsolatedPixels) {
    const int width = 9, height = 7;
    ScanView view = pinhole_view(width, height, [](int, int) { return 300.0; });
    const size_t full = (width - 1) * (height - 1) * 2;
    // One interior hole: its four quads keep one triangle each.
    view.points.at<cv::Vec3f>(3, 4) = cv::Vec3f(kNaN, kNaN, kNaN);
    Mesh mesh = grid_mesh(view);
    EXPECT_EQ(mesh.faces.size(), full - 4);
    EXPECT_EQ(mesh.vertices.size(), static_cast<size_t>(width * height - 1));
    expect_faces_towards_camera(mesh);

    // An isolated valid pixel joins nothing and is not a vertex.
    ScanView sparse = pinhole_view(width, height, [](int, int) { return 300.0; });
    sparse.points.setTo(cv::Scalar::all(kNaN));
    sparse.points.at<cv::Vec3f>(3, 3) = cv::Vec3f(0, 0, 300);
    mesh = grid_mesh(sparse);
    EXPECT_TRUE(mesh.faces.empty());
    EXPECT_TRUE(mesh.vertices.empty());

    // Three valid corners of one quad make one triangle, with any corner missing.
    for (int missing = 0; missing < 4; ++missing) {
        ScanView quad = pinhole_view(2, 2, [](int, int) { return 300.0; });
        quad.points.at<cv::Vec3f>(missing / 2, missing % 2) = cv::Vec3f(kNaN, kNaN, kNaN);
        mesh = grid_mesh(quad);
        ASSERT_EQ(mesh.faces.size(), 1u) << "missing corner " << missing;
        EXPECT_EQ(mesh.vertices.size(), 3u);
        expect_faces_towards_camera(mesh);
    }
}

TEST(GridMesh, ChoosesTheShorterDiagonal) {
    for (int variant = 0; variant < 2; ++variant) {
        // Pull corner a (variant 0) or b (variant 1) towards the quad centre so the
        // diagonal through it is the shorter one.
        ScanView view = pinhole_view(2, 2, [](int, int) { return 1000.0; });
        cv::Vec3f& moved = view.points.at<cv::Vec3f>(0, variant);
        moved[0] *= 0.5f;
        moved[1] *= 0.5f;
        const Mesh mesh = grid_mesh(view);
        ASSERT_EQ(mesh.faces.size(), 2u);
        // a=0 b=1 c=2 d=3: the diagonal is the pair present in both triangles.
        std::set<int> first(mesh.faces[0].val, mesh.faces[0].val + 3), shared;
        for (int k = 0; k < 3; ++k)
            if (first.count(mesh.faces[1][k])) shared.insert(mesh.faces[1][k]);
        const std::set<int> expected = variant == 0 ? std::set<int>{0, 3} : std::set<int>{1, 2};
        EXPECT_EQ(shared, expected);
        expect_faces_towards_camera(mesh);
    }
}

TEST(GridMesh, EdgeFactorControlsJoining) {
    // Neighbours 1 pixel footprint apart; a 30% depth ramp per pixel makes edges ~3 footprints long.
    const ScanView view = pinhole_view(6, 6, [](int x, int) { return 100.0 + 0.3 * x * (100.0 / kFocal) * 10; });
    GridMeshOptions loose, tight;
    loose.max_edge_factor = 8.0;
    tight.max_edge_factor = 1.5;
    EXPECT_EQ(grid_mesh(view, loose).faces.size(), 50u);
    EXPECT_TRUE(grid_mesh(view, tight).faces.empty());
    GridMeshOptions bad;
    bad.max_edge_factor = 0;
    EXPECT_THROW(grid_mesh(view, bad), Error);
    ScanView without_camera = view;
    without_camera.camera_matrix(0, 0) = 0;
    EXPECT_THROW(grid_mesh(without_camera), Error);
    without_camera.camera_matrix(0, 0) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(grid_mesh(without_camera), Error);
}

TEST(GridMesh, PoseMatchesThePointCloud) {
    ScanView view = pinhole_view(7, 5, [](int x, int y) { return 250.0 + x - y; });
    view.pose = cv::Matx44d(1, 0, 0, 5,
                            0, 0, -1, 6,
                            0, 1, 0, 7,
                            0, 0, 0, 1);
    const Mesh mesh = grid_mesh(view);
    const PointCloud cloud = to_point_cloud(view);
    ASSERT_EQ(mesh.vertices.size(), cloud.points.size());
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        EXPECT_EQ(mesh.vertices[i], cloud.points[i]);
        EXPECT_EQ(mesh.normals[i], cloud.normals[i]);
        EXPECT_EQ(mesh.colours[i], cloud.colours[i]);
    }
    // A proper rotation keeps the faces turned towards the (moved) camera centre.
    const cv::Vec3f camera(5, 6, 7);
    for (const cv::Vec3i& face : mesh.faces)
        EXPECT_LT(winding_normal(mesh, face).dot(mesh.vertices[face[0]] - camera), 0);
}

TEST(GridMesh, TinyAndEmptyViews) {
    EXPECT_TRUE(grid_mesh(ScanView{}).faces.empty());
    const ScanView row = pinhole_view(5, 1, [](int, int) { return 10.0; });
    EXPECT_TRUE(grid_mesh(row).faces.empty());
}

TEST(GridMesh, PixelStepMeshesEveryNthPixel) {
    const int width = 41, height = 31;
    const ScanView view = pinhole_view(width, height, [](int x, int y) { return 400.0 + 0.3 * x - 0.2 * y; });
    GridMeshOptions options;
    options.pixel_step = 2;
    const Mesh mesh = grid_mesh(view, options);
    // 21 x 16 pixels kept, all joined.
    EXPECT_EQ(mesh.vertices.size(), size_t(21 * 16));
    EXPECT_EQ(mesh.faces.size(), size_t(20 * 15 * 2));
    EXPECT_EQ(mesh.vertices[1], view.points.at<cv::Vec3f>(0, 2));
    expect_faces_towards_camera(mesh);
    options.pixel_step = 0;
    EXPECT_THROW(grid_mesh(view, options), Error);
}

}  // namespace
}  // namespace picoscan
