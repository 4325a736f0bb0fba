// A deterministic virtual rig: ray-casts a calibrated camera-projector pair looking at a
// scene of analytic shapes and triangle meshes, and renders camera images of any pattern.
#pragma once

#include "picoscan/calibration.h"
#include "picoscan/capture_set.h"
#include "picoscan/cloud.h"
#include "picoscan/patterns.h"
#include "picoscan/progress.h"
#include "picoscan/stereo.h"

#include <opencv2/core.hpp>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace picoscan {

// All shapes in camera coordinates, mm. albedo in 0..1.
struct Sphere { cv::Vec3d centre; double radius_mm = 10; double albedo = 0.8; };
struct Plane { cv::Vec3d point; cv::Vec3d normal{0, 0, -1}; double albedo = 0.8; };
struct Box { cv::Vec3d centre; cv::Vec3d half_size_mm{10, 10, 10}; cv::Matx33d rotation = cv::Matx33d::eye(); double albedo = 0.8; };
struct Cylinder { cv::Vec3d base_centre; cv::Vec3d axis{0, 1, 0}; double radius_mm = 10; double height_mm = 20; double albedo = 0.8; };  // capped
// With vertex colours, the albedo at a vertex is albedo * its grey level (0..255 -> 0..1),
// interpolated across each face: a painted or speckled part.
struct TriangleMesh { Mesh mesh; double albedo = 0.8; };

// A planar chessboard calibration target: (inner_corners.width + 1) x (inner_corners.height + 1)
// squares of square_mm, inside a light margin of margin_mm. Board frame: origin at the first
// inner corner, x along a row of inner corners, y along a column, z = 0 on the printed face,
// +z pointing into the board (away from a camera that sees the face). Camera frame point
// X = rotation * X_board + translation. The square whose top-left corner is the board frame's
// (-square, -square) is dark, and colours alternate from there.
struct CalibrationBoard {
    cv::Matx33d rotation = cv::Matx33d::eye();
    cv::Vec3d translation{0, 0, 400};
    cv::Size inner_corners{9, 6};
    double square_mm = 10;
    double margin_mm = 10;
    double dark_albedo = 0.12;
    double light_albedo = 0.85;
};

// Board frame coordinates (z = 0) of the inner corners, row by row (OpenCV object-point order).
std::vector<cv::Point3f> chessboard_corners(const CalibrationBoard& board);

struct Scene {
    std::vector<Sphere> spheres;
    std::vector<Plane> planes;
    std::vector<Box> boxes;
    std::vector<Cylinder> cylinders;
    std::vector<TriangleMesh> meshes;
    std::vector<CalibrationBoard> boards;
};

struct SimulationOptions {
    double full_scale_dn = 220.0;   // camera level of a white-lit, albedo-1 surface facing the projector
    double ambient_dn = 12.0;       // level from ambient light on an albedo-1 surface
    double projector_black = 0.02;  // projector black level relative to white (light leakage)
    double projector_gamma = 1.0;   // projector response: light = level^gamma
    double noise_sigma_dn = 1.0;    // camera noise (Gaussian, DN)
    double blur_sigma_px = 0.0;     // defocus, Gaussian sigma in camera pixels
    int bit_depth = 8;              // 8 or 16 bit camera images
    uint64_t seed = 1;              // noise seed: the same seed renders the same images
};

// Ground truth per camera pixel, from the scene geometry alone.
struct SimulatedGeometry {
    cv::Mat points;      // CV_32FC3, camera frame, NaN where the ray hits nothing
    cv::Mat normals;     // CV_32FC3
    cv::Mat projector;   // CV_32FC2, projector (u, v) of the point (distorted pixel coords), NaN outside
    cv::Mat lit;         // CV_8U, 255 where the projector sees the point (not in shadow)
    cv::Mat shading;     // CV_32F, albedo * cos(incidence) towards the projector
    cv::Mat albedo;      // CV_32F, averaged over the pixel's footprint on calibration boards
};

class Simulator {
public:
    // Ray-casts the scene once; each render() then only samples the pattern.
    Simulator(const Calibration& calibration, const Scene& scene, const SimulationOptions& options = {});
    ~Simulator();

    const SimulatedGeometry& geometry() const;
    // Camera image (CV_8U or CV_16U) of the projector showing `pattern` (CV_8U, projector size).
    // `frame_index` selects the noise realisation.
    cv::Mat render(const cv::Mat& pattern, int frame_index) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Renders every frame of `sequence` into a capture set (in memory).
CaptureSet simulate_capture(const PatternSequence& sequence, const Calibration& calibration,
                            const Scene& scene, const SimulationOptions& options = {},
                            const ProgressCallback& progress = nullptr);

// The seed-like rig: 1600x1200 camera, 854x480 projector, ~150 mm baseline, converging
// on a working distance of 400 mm, mild lens distortion on both.
Calibration seed_rig_calibration();

// Two seed-like cameras (1600x1200, the seed rig's lens) `baseline_mm` apart along x, both
// aimed at (0, 0, 400) in the first camera's frame, with the seed projector midway between
// them aimed at the same point. Each camera's Calibration holds the shared projector.
struct SeedStereoRig {
    Calibration left, right;
    StereoCalibration stereo;  // first camera -> second
};
SeedStereoRig seed_stereo_rig(double baseline_mm = 200);

// The scene moved by a rigid transform (every shape and board): the scene as another camera
// of the rig sees it.
Scene transformed(const Scene& scene, const cv::Matx44d& transform);

// Renders `sequence` through both cameras of the rig; the scene is in the first camera's
// frame, and the second camera's noise uses options.seed + 1.
std::pair<CaptureSet, CaptureSet> simulate_stereo_capture(const PatternSequence& sequence, const SeedStereoRig& rig,
                                                          const Scene& scene, const SimulationOptions& options = {},
                                                          const ProgressCallback& progress = nullptr);

// The built-in demo part (a bracket-like block with a hole, a boss and a sphere) on a
// background plane, placed at the seed rig's working distance.
Scene demo_scene();

// The built-in mechanical test part, in its own frame: z up, origin at the centre of the
// block's bottom face. A block with one vertical edge chamfered (at +x, +y), a vertical
// through hole and a cylindrical boss on the top face; finely tessellated (edges <= 0.6 mm)
// and speckle-painted (vertex colours) so that features can be found on its white frames.
struct MechanicalPartShape {
    double length_mm = 50, width_mm = 36, height_mm = 24;  // block along x, y, z
    double chamfer_mm = 8;                                 // legs of the 45 degree chamfer
    cv::Vec2d hole_centre_mm{-11, 0};
    double hole_diameter_mm = 10;
    cv::Vec2d boss_centre_mm{12, -2};
    double boss_diameter_mm = 14, boss_height_mm = 8;
    uint64_t paint_seed = 7;
};
Mesh mechanical_part(const MechanicalPartShape& shape = {});

// How the part lies on the turntable. A second placement, the part flipped, shows the face
// it stood on in the first.
enum class PartPlacement {
    Standing,    // as modelled: part z up
    UpsideDown,  // turned half round about its x axis: the bottom face up
    OnItsSide,   // turned a quarter round about its x axis: its +y face up, its -y face down
};

// A turntable scan plan: the part turned in equal steps on a table the camera looks down on
// at `elevation_deg`, plus an optional view from nearly above; each pose may be disturbed
// by a random rotation and shift (a part knocked or re-placed by hand).
struct TurntablePlan {
    int turntable_views = 8;
    double elevation_deg = 25;
    bool top_view = true;
    double top_elevation_deg = 60;
    double max_disturbance_deg = 0, max_disturbance_mm = 0;
    cv::Vec3d part_centre_mm{0, 0, 400};  // where the part's middle sits, camera frame
    double part_middle_height_mm = 16;    // height (part z) of that middle
    uint64_t seed = 1;
    // The part is turned about its middle (x = y = 0, z = part_middle_height_mm) into this
    // placement, then by `placement_turn_deg` about the table's axis, before the first view.
    PartPlacement placement = PartPlacement::Standing;
    double placement_turn_deg = 0;
};
// Part frame -> camera frame transform of each view.
std::vector<cv::Matx44d> turntable_part_poses(const TurntablePlan& plan);


// Scene description file (YAML/JSON via OpenCV FileStorage): lists of spheres, planes,
// boxes, cylinders, meshes (file paths relative to the scene file) and calibration boards.
Scene read_scene(const std::string& path);

}  // namespace picoscan
