#include "stereo/board_poses.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include <unistd.h>

#include <filesystem>
#include <utility>

namespace picoscan::test_support {

namespace {

constexpr double kPi = 3.14159265358979323846;

cv::Matx33d rotation_deg(double x, double y, double z) {
    cv::Matx33d rx, ry, rz;
    cv::Rodrigues(cv::Vec3d(x * kPi / 180, 0, 0), rx);
    cv::Rodrigues(cv::Vec3d(0, y * kPi / 180, 0), ry);
    cv::Rodrigues(cv::Vec3d(0, 0, z * kPi / 180), rz);
    return rz * ry * rx;
}

}  // namespace

BoardSpec stereo_board() { return parse_board_spec(kStereoBoardSpec); }

std::vector<CalibrationBoard> board_poses() {
    struct Pose { cv::Vec3d target, tilt_deg; };
    // Spread over the common field and tilted every way, each facing roughly the midpoint
    // between the cameras (a yaw of -14 degrees), so both see it alike.
    const std::vector<Pose> poses = {
        {{0, 0, 400}, {20, -14, 0}},      {{-45, -30, 390}, {0, 11, 5}},   {{45, 30, 410}, {-20, -14, -5}},
        {{-45, 30, 420}, {0, -39, 0}},    {{45, -30, 380}, {15, 1, 10}},   {{0, 35, 400}, {-15, -34, 0}},
        {{0, -35, 430}, {25, -4, -10}},   {{-50, 0, 370}, {-10, 16, 0}},   {{50, 0, 400}, {10, -44, 5}},
        {{25, 20, 440}, {30, -14, 15}},   {{-25, -20, 360}, {-25, -4, -15}}, {{0, 0, 410}, {5, 21, 0}},
    };
    const BoardSpec spec = stereo_board();
    std::vector<CalibrationBoard> boards;
    for (const Pose& pose : poses) {
        CalibrationBoard board;
        board.inner_corners = spec.size;
        board.square_mm = spec.square_mm;
        board.rotation = rotation_deg(pose.tilt_deg[0], pose.tilt_deg[1], pose.tilt_deg[2]);
        const cv::Vec3d middle((spec.size.width - 1) * spec.square_mm / 2, (spec.size.height - 1) * spec.square_mm / 2, 0);
        board.translation = pose.target - board.rotation * middle;
        boards.push_back(board);
    }
    return boards;
}

std::vector<StereoBoardView> board_views(int count) {
    namespace fs = std::filesystem;
    // The cache key names everything that shapes the images; change it when any of that changes.
    const fs::path cache = fs::path(PICOSCAN_TEST_CACHE_DIR) / "stereo-board-v1-14x9-blur0.5";
    fs::create_directories(cache);
    const SeedStereoRig rig = seed_stereo_rig();
    cv::Matx44d left_to_right = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) left_to_right(r, c) = rig.stereo.R(r, c);
        left_to_right(r, 3) = rig.stereo.T[r];
    }
    const cv::Mat white(rig.left.projector_size, CV_8U, cv::Scalar(255));
    const std::vector<CalibrationBoard> boards = board_poses();
    std::vector<StereoBoardView> views;
    for (size_t index = 0; index < boards.size() && int(index) < count; ++index) {
        StereoBoardView view;
        view.name = "pose" + std::to_string(index);
        const fs::path left = cache / (view.name + "_left.png"), right = cache / (view.name + "_right.png");
        if (fs::exists(left) && fs::exists(right)) {
            view.left = cv::imread(left.string(), cv::IMREAD_UNCHANGED);
            view.right = cv::imread(right.string(), cv::IMREAD_UNCHANGED);
        }
        if (view.left.empty() || view.right.empty()) {
            Scene scene;
            scene.boards.push_back(boards[index]);
            SimulationOptions options;
            options.full_scale_dn = 250;
            options.blur_sigma_px = 0.5;
            options.seed = 3 + uint64_t(index);
            view.left = Simulator(rig.left, scene, options).render(white, 0);
            view.right = Simulator(rig.right, transformed(scene, left_to_right), options).render(white, 1);
            // Written under a temporary name, then renamed: tests running side by side never
            // read half a file.
            for (const auto& [image, path] : {std::pair{view.left, left}, std::pair{view.right, right}}) {
                const fs::path temporary = path.string() + "." + std::to_string(::getpid()) + ".png";
                cv::imwrite(temporary.string(), image);
                fs::rename(temporary, path);
            }
        }
        views.push_back(view);
    }
    return views;
}

}  // namespace picoscan::test_support
