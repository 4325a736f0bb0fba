// The recipes: the ordered uses of the stages that every front end runs. The CLI, the Python
// module (FreeCAD) and the MeshLab plugin translate their parameters into these options and
// present the results; none of them calls decode, triangulate, clean, register or mesh itself.
// Defaults live in the options structs below, ranges are checked once by validate(), and the
// errors name the option field (hosts map field names to their own parameter names).
#pragma once

#include "picoscan/calibration.h"
#include "picoscan/capture_set.h"
#include "picoscan/clean.h"
#include "picoscan/cloud.h"
#include "picoscan/decode.h"
#include "picoscan/fit.h"
#include "picoscan/mesh.h"
#include "picoscan/patterns.h"
#include "picoscan/progress.h"
#include "picoscan/region_fit.h"
#include "picoscan/register.h"
#include "picoscan/simulate.h"
#include "picoscan/stereo.h"
#include "picoscan/triangulate.h"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace picoscan {

// ---- Reconstruct one view from a capture folder ----------------------------------------

// A second camera on the same projector, calibrated with it: it confirms the first camera's
// points, and points it does not confirm (stray light, interreflections) are removed.
struct SecondCamera {
    Calibration calibration;
    std::string calibration_name;  // the file it came from, for messages
    std::string captures_folder;
};

struct ReconstructOptions {
    std::string manifest_path;  // sequence.json to read instead of the capture folder's own
    DecodeOptions decode;
    TriangulateOptions triangulate;
    std::optional<SecondCamera> second_camera;
    bool clean = false;  // run clean_view on the result
    CleanOptions cleaning;
};

struct ReconstructResult {
    ScanView view;                        // organised, knows its camera
    int order_corrections = 0;            // fringe orders the Gray code corrected
    int unconfirmed_removed = 0;          // by the second camera
    std::optional<CleanReport> cleaning;  // when options.clean
    int point_count = 0;                  // valid points in the view
};

// Inputs: a capture folder (frames + sequence.json, or options.manifest_path) and the rig's
// calibration (calibration_name names it in errors). Checks the frames' size against the
// calibration, decodes, triangulates, confirms with a second camera and cleans.
// Throws Error naming the folder when no pixel could be reconstructed.
ReconstructResult reconstruct_view(const std::string& captures_folder, const Calibration& calibration,
                                   const std::string& calibration_name, const ReconstructOptions& options = {},
                                   const ProgressCallback& progress = nullptr);
// The same from captures already in memory (a simulated or captured set).
ReconstructResult reconstruct_view(const CaptureSet& captures, const Calibration& calibration,
                                   const std::string& calibration_name, const ReconstructOptions& options = {},
                                   const ProgressCallback& progress = nullptr);

// ---- Reconstruct one view with two cameras (binocular) -----------------------------------

// Two cameras with a stereo calibration, the projector only labelling pixels (stereo.h).
struct StereoReconstructOptions {
    std::string manifest_path;         // sequence.json for both cameras' folders instead of their own
    std::string second_manifest_path;  // the second camera's, when it differs (both cameras' frames in one folder)
    DecodeOptions decode;
    StereoOptions stereo;
    bool refine_pose = false;   // re-estimate R, T from the codes both cameras decoded first
    // The first camera's camera-projector calibration with the same projector: each point is
    // then triangulated from three views (StereoMatcher's second constructor).
    std::optional<Calibration> projector;
    bool clean = false;         // run clean_view on the result
    CleanOptions cleaning;
};

struct StereoReconstructResult {
    ScanView view;                                  // on the first camera's grid, knows its camera
    StereoStatistics statistics;
    std::optional<ExtrinsicsRefinement> refinement;  // when options.refine_pose
    std::optional<CleanReport> cleaning;             // when options.clean
    int point_count = 0;
};

// Loads and decodes both folders, checks their sizes against the calibration (named by
// calibration_name), matches and triangulates, cleans. Throws Error naming the first folder
// when no point could be reconstructed.
StereoReconstructResult reconstruct_stereo_view(const std::string& first_folder, const std::string& second_folder,
                                                const StereoCalibration& calibration, const std::string& calibration_name,
                                                const StereoReconstructOptions& options = {},
                                                const ProgressCallback& progress = nullptr);

// ---- Clean one view -----------------------------------------------------------------------

struct CleanScanOptions {
    CleanOptions cleaning;
    double background_tolerance_mm = 1.0;  // how close to the background counts as background
};

struct CleanScanResult {
    int background_removed = 0;
    CleanReport report;  // the filters of clean_view, in order
};

// Removes the background (when `background`, a view of the empty scene with the same rig and
// pose, is given), then stray-light noise and unreliable points, in place. Throws Error naming
// `view_name` when no point survives.
CleanScanResult clean_scan(ScanView& view, const std::string& view_name, const CleanScanOptions& options = {},
                           const ScanView* background = nullptr);

// ---- Simulate -----------------------------------------------------------------------------

// A capture set of a virtual scene, as 'picoscan simulate' and the hosts' Simulate commands
// render it: the default patterns and a camera slightly out of focus, like a real webcam.
struct SimulateOptions {
    PatternOptions patterns;  // projector_size is taken from the calibration
    SimulationOptions camera = realistic_camera();
    static SimulationOptions realistic_camera() {
        SimulationOptions camera;
        camera.blur_sigma_px = 0.7;
        return camera;
    }
};
CaptureSet simulate_captures(const Scene& scene, const Calibration& calibration, const SimulateOptions& options = {},
                             const ProgressCallback& progress = nullptr);

// The turntable session of the demo, the multi-view tests and the hosts: the part, light grey,
// turned on a table in front of the rig; each view simulated, reconstructed and cleaned.
struct TurntableScanOptions {
    TurntablePlan plan;
    PatternOptions patterns = fewer_shifts();
    SimulationOptions camera = bright_camera();
    DecodeOptions decode = modulated_only();
    double part_albedo = 0.85;
    static PatternOptions fewer_shifts() {
        PatternOptions patterns;
        patterns.shifts = 16;
        return patterns;
    }
    static SimulationOptions bright_camera() {
        SimulationOptions camera;
        camera.full_scale_dn = 250;
        camera.blur_sigma_px = 0.5;
        return camera;
    }
    static DecodeOptions modulated_only() {
        DecodeOptions decode;
        decode.min_modulation = 15;
        return decode;
    }
};

// One simulated view: its captures (for writing), the cleaned view and the truth.
struct SimulatedView {
    std::string name;             // view_K
    CaptureSet captures;
    ScanView view;                // cleaned, camera frame, pose identity
    CleanReport cleaning;
    cv::Matx44d part_to_camera;   // ground truth
};

// Simulates every view of options.plan in turn (camera noise seeded per view, so views are
// independent) and hands each to on_view as soon as it is made, so the caller can write it
// without holding every capture set in memory. Returns the part->camera pose of every view.
std::vector<cv::Matx44d> simulate_turntable_scan(const Mesh& part, const Calibration& calibration,
                                                 const TurntableScanOptions& options,
                                                 const std::function<void(const SimulatedView&)>& on_view,
                                                 const ProgressCallback& progress = nullptr);

// ---- Sequences of other systems ------------------------------------------------------------

struct ForeignPresetOptions {
    std::string preset;             // one of foreign_preset_names()
    cv::Size projector_size;
    std::string file_prefix;        // opencv-graycode: files PREFIX<K>SUFFIX
    std::string file_suffix = ".png";
    int first_index = 1;
    int gray_bits = 0;              // slstudio-gray: projected bits (0: all)
    int periods = 0;                // slstudio-phase-cue (0: 16), slmaster-cgc (0: 32)
    int shifts = 0;                 // slmaster-cgc (0: 12)
};
std::vector<std::string> foreign_preset_names();
PatternSequence foreign_preset_sequence(const ForeignPresetOptions& options);

// ---- Align and fuse views -----------------------------------------------------------------

struct StitchOptions {
    RegistrationOptions registration;
    std::optional<TurntableAxis> turntable;  // known turntable motion (views in order)
    // Several placements (the part set down again between them, e.g. on its side to show the
    // face it stood on): each view's placement, 0, 1, ... in order, a placement's views in
    // turntable order. Empty: all views are one placement. `turntable` (the table stays
    // where it is) and registration.turntable_round then apply to each placement on its own;
    // the placements are aligned to each other by shape (align_placements).
    std::vector<int> placement_of_view;
    // What a user expects of a turntable scan, painted or plain: features first; a placement
    // they leave incomplete (a plain part gives no features) is aligned again as one turntable
    // round (axis estimated), and the way that aligns more of its views is kept. Not with
    // `turntable`, registration.turntable_round or registration.initial_poses.
    bool automatic = false;
};

// One way of aligning one placement's views that stitch_views tried.
struct StitchAttempt {
    int placement = 0;       // from 0
    std::string method;      // "features", "turntable round (axis estimated)", "turntable axis (given)", "initial poses"
    int aligned_views = 0;   // of the placement's views, aligned within it
    int views = 0;
    std::string problem;     // the first view it left out, with the reason; empty when it aligned all
    bool kept = false;       // its poses are the result
};

struct StitchResult {
    Alignment alignment;                   // every view: aligned or not, with the reason
    PointCloud merged;                     // the aligned views in the model frame
    std::vector<size_t> merged_views;      // indices of the views in `merged`
    std::optional<TurntableAxis> axis;     // the turntable the aligned views turn about, if any
    std::vector<StitchAttempt> attempts;   // in the order tried, placement by placement
    std::vector<std::string> method_of_view;  // the method that placed each view; empty when it was left out
};

// Aligns the views (features -> RANSAC -> ICP -> multi-view refinement; with placements,
// each placement, then the placements by shape, then every view) and merges those that
// aligned. Views that did not are left out, never forced in; their reason is in alignment
// (and a placement's in alignment.placements). Throws Error naming the field for bad options
// (validate).
StitchResult stitch_views(const std::vector<ScanView>& views, const std::vector<std::string>& names,
                          const StitchOptions& options = {}, const ProgressCallback& progress = nullptr);

// ---- Mesh ---------------------------------------------------------------------------------

// A view into a mesh: MeshMethod::Grid joins the pixels of the view (with its camera); the
// others mesh its points as mesh_points does.
Mesh mesh_view(const ScanView& view, const MeshOptions& options = {}, const ProgressCallback& progress = nullptr);
// A cloud with normals (a merged model) into a mesh: Poisson or advancing front (mesh_cloud).
Mesh mesh_points(const PointCloud& cloud, const MeshOptions& options = {}, const ProgressCallback& progress = nullptr);

// ---- Part frame ---------------------------------------------------------------------------

// Where a scan's own part coordinate system lies, Z up, so that a scan does not sit in the
// camera's frame: about the turntable's axis when the views turned on one (origin where the
// axis meets the lowest points), else on the cloud's largest plane (the table or base the part
// stands on: Z along its normal towards the camera, origin under the middle of the points above
// it). X is the camera's x made square to Z. Datum alignment (fit.h) then gives the exact frame.
struct PartFrameOptions {
    int max_points = 60000;          // evenly chosen subset searched for the base plane
    double plane_epsilon_mm = 0.25;  // base plane inliers are nearer than this
    double min_plane_share = 0.05;   // the base plane holds at least this share of the points
};
struct PartFrame {
    DatumFrame frame;                // part_from_scan takes the cloud's coordinates into the part frame
    std::string basis;               // what fixed it: "turntable axis ..." or "base plane ..."
};
// Throws Error("cloud", ...) when the cloud has no normals (without a turntable) or no plane with
// min_plane_share of the points, Error(<field>, ...) for bad options.
PartFrame part_frame(const PointCloud& cloud, const std::optional<TurntableAxis>& turntable = std::nullopt,
                     const PartFrameOptions& options = {}, const ProgressCallback& progress = nullptr);

// ---- Fit where the user points ------------------------------------------------------------

// A region picked on a scan, fitted: the region around a picked point (grown over the smooth
// surface up to the face's edges by default, or a ball, or a box around it) or under a lasso drawn
// on the screen, then a plane, cylinder, sphere or cone fitted to it (region_fit.h), with the
// constraint and snapping the options ask for.
// The workbench's default region: the face under the point, up to its edges, within 30 mm.
inline RegionSelection grown_face_selection() {
    RegionSelection selection;
    selection.radius_mm = 30;
    selection.grow = true;
    return selection;
}
struct PickedFitOptions {
    RegionSelection selection = grown_face_selection();  // ignored by fit_in_lasso
    RegionFitOptions fit;
};
struct PickedFit {
    std::vector<int> region;  // the cloud's points fitted
    RegionFit fit;
};
// Throws Error(<field>, ...) for bad options, Error("region", ...) when the region is too small or
// no kind fits it (see fit_region), Error("cancelled", ...) when progress answers false.
PickedFit fit_at_point(const PointCloud& cloud, const cv::Vec3d& seed, const PickedFitOptions& options = {},
                       const ProgressCallback& progress = nullptr);
PickedFit fit_in_lasso(const PointCloud& cloud, const cv::Matx44d& cloud_to_screen, const std::vector<cv::Vec2d>& polygon,
                       const PickedFitOptions& options = {}, const ProgressCallback& progress = nullptr);

// ---- Fuse views that are already posed ------------------------------------------------------

// Views already aligned (each through its pose, e.g. MeshLab layers with their transforms)
// merged into one cloud and meshed (mesh_points), with the mesh's check.
struct FuseResult {
    PointCloud merged;
    Mesh mesh;
    MeshCheck check;
};
// Throws Error when no view is given, the merged cloud is empty, or meshing gives no triangle.
FuseResult fuse_views(const std::vector<ScanView>& views, const MeshOptions& options = {},
                      const ProgressCallback& progress = nullptr);
// The same, the views asked for one at a time (merge_view_stream): for 16-32 full views,
// which a host reads or makes one by one rather than holding every pixel grid at once.
// The result is the same as from the views held whole.
FuseResult fuse_views(size_t view_count, const ViewSource& view_at, const MeshOptions& options = {},
                      const ProgressCallback& progress = nullptr);
// The same over view PLY files (write_view_ply, each with its pose), read one at a time: the
// hosts' way to fuse views kept on disk. Throws Error naming a file that is missing or is not
// a view PLY.
FuseResult fuse_view_files(const std::vector<std::string>& paths, const MeshOptions& options = {},
                           const ProgressCallback& progress = nullptr);

// ---- Validation ---------------------------------------------------------------------------
// Each throws Error naming the offending field (e.g. "decode.min_modulation") when a value is
// out of range or NaN.
void validate(const PatternOptions& options);
void validate(const DecodeOptions& options);
void validate(const SimulationOptions& options);
void validate(const CleanOptions& options);
void validate(const RegistrationOptions& options);
void validate(const MeshOptions& options);
void validate(const ReconstructOptions& options);
void validate(const SimulateOptions& options);
void validate(const CleanScanOptions& options);
void validate(const PartFrameOptions& options);
void validate(const PickedFitOptions& options);
void validate(const StitchOptions& options);

}  // namespace picoscan
