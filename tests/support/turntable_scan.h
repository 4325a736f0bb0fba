// The multi-view test scan shared by the registration and meshing suites: the built-in
// mechanical part on a simulated turntable, 8 views plus one from above. Scanned once and
// kept as view PLYs in the build tree, since every test runs in its own process.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/simulate.h"

#include <string>
#include <unordered_map>
#include <vector>

namespace picoscan::test_support {

struct TurntableScan {
    std::vector<ScanView> views;                   // cleaned, camera frame, pose = identity
    std::vector<std::string> names;                // view_0.ply ...
    std::vector<cv::Matx44d> part_to_camera;       // ground truth per view
    std::vector<cv::Matx44d> true_view_to_model;   // view i -> view 0 camera frame
    Mesh part;                                     // ground-truth part, part frame
    cv::Vec3d centroid(size_t view) const;         // of a view's points, its own frame
};

// Each view's pose knocked by up to 10 degrees and 20 mm.
const TurntableScan& disturbed_turntable_scan();
// Exact turntable steps of 45 degrees.
const TurntableScan& turntable_scan();

// Plain parts (uniform grey, no paint) of several shapes, some nearly symmetric, for
// registration that must be right or refuse. Each: 8 views 45 degrees apart on an exact
// turntable at 25 degrees elevation, independent camera noise per view.
enum class PlainPart { GreyMechanical, SteppedBlock, FlattedShaft, HexWithPeg, Block };
constexpr PlainPart kPlainParts[] = {PlainPart::GreyMechanical, PlainPart::SteppedBlock, PlainPart::FlattedShaft,
                                     PlainPart::HexWithPeg, PlainPart::Block};
std::string plain_part_name(PlainPart part);
const TurntableScan& plain_turntable_scan(PlainPart part);

// Two placements of one part on the turntable: views 0-7 with the part standing, views 8-15
// with it on its side (or upside down) and turned 20 degrees, so that the second placement
// sees the face the part stood on. Simulated with a half-resolution seed camera (800 x 600)
// to keep the suite fast. part_to_camera and true_view_to_model hold the truth of every view
// (model frame: view 0). Parts: the speckled mechanical part and plain ones.
enum class PlacementPart { SpeckledMechanical, GreyMechanical, SteppedBlock, HexWithPeg, Block, GreyMechanicalUpsideDown };
constexpr size_t kViewsPerPlacement = 8;
std::string placement_part_name(PlacementPart part);
const TurntableScan& two_placement_scan(PlacementPart part);
// The seed rig with its camera at half the resolution (800 x 600).
Calibration half_resolution_seed_rig();

// The point of triangle abc closest to p (Ericson, Real-Time Collision Detection, 5.1.5).
cv::Vec3d closest_on_triangle(const cv::Vec3d& p, const cv::Vec3d& a, const cv::Vec3d& b, const cv::Vec3d& c);

// Distances (mm) from points to the nearest triangle of a finely tessellated mesh; points
// farther than `reach_mm` from every triangle get reach_mm.
class MeshDistance {
public:
    MeshDistance(const Mesh& mesh, double reach_mm);
    double operator()(const cv::Vec3d& point) const;

private:
    const Mesh& mesh_;
    double reach_mm_;
    std::unordered_map<long long, std::vector<int>> cells_;
};

}  // namespace picoscan::test_support
