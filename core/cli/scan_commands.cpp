// picoscan simulate and reconstruct: a capture set, and a capture set into a view.
#include "cli_support.h"
#include "commands.h"

#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"
#include "picoscan/preview.h"

#include <cmath>
#include <cstdio>
#include <filesystem>

namespace fs = std::filesystem;

namespace picoscan::cli {

namespace {

const char* kSimulateHelp = R"(picoscan simulate --out DIR [options]

Renders the capture set a real rig would record, with the seed-like rig (1600x1200 camera,
854x480 projector, 150 mm baseline, 400 mm working distance) unless --calibration is given.
Writes the images, DIR/sequence.json and the exact rig as DIR/calibration.yml.

  --out DIR            output folder (must be empty or not exist)
  --scene FILE         scene description (YAML/JSON, see docs/formats.md); default: built-in part
  --calibration FILE   rig to simulate (default: the seed-like rig)
  --shifts K, --period-bits N, --rows | --no-rows    pattern options as for 'patterns'
  --noise SIGMA        camera noise in grey levels, 0..100 (default 1)
  --gamma G            projector response exponent, 0.1..10 (default 1)
  --blur SIGMA         defocus blur in camera pixels, 0..20 (default 0.7)
  --seed N             noise seed (default 1)

Example (then reconstruct it as 'picoscan reconstruct --help' shows):
  picoscan simulate --out scan/ --noise 2
)";

const char* kReconstructHelp = R"(picoscan reconstruct --calibration FILE --captures DIR --out CLOUD.ply [options]

Decodes the Gray code and phase-shift frames of a capture set (hybrid unwrapping) and
triangulates every camera pixel. Writes an organised point cloud with colour, normals and
quality, and optionally a grid mesh that does not bridge depth jumps.

  --calibration FILE   camera-projector calibration (PicoScan YAML, SLMaster caliInfo.yml or
                       SLStudio calibration.xml)
  --captures DIR       capture set folder
  --manifest FILE      sequence.json to use instead of DIR/sequence.json (for foreign sets)
  --out FILE           point cloud (.ply, binary unless --ascii)
  --mesh FILE          grid mesh too (.stl, .ply or .obj)
  --mesh-step N        join every N-th pixel only: N*N times fewer triangles (default 1)
  --preview FILE       shaded PNG preview of the scan
  --binary-only        Gray code only, ignore the phase frames (for comparison)
  --ascii              write ASCII PLY/STL instead of binary
  --min-contrast DN    white-black contrast below this is shadow, 0..255 grey levels (default 15)
  --min-modulation DN  fringe amplitude below this is rejected, 0..255 grey levels (default 4)
  --clean              remove unreliable points before writing: stray-light outliers, points seen
                       at grazing angles (> 80 deg), small disconnected clusters; prints what
                       each filter removed
  --second-calibration FILE, --second-captures DIR
                       a second camera's calibration (with the same projector) and its captures
                       of the same scan: points the second camera does not confirm (stray light,
                       interreflections, points only the first camera sees) are removed

Two cameras, any projector: when --calibration is a stereo calibration of two cameras (PicoScan's
'calibrate --stereo', OpenCV's stereo calibration keys M1 D1 M2 D2 R T, OpenCV's structured-light
tutorial keys, see docs/formats.md), the projector needs no calibration. Give the second
camera's captures with --second-captures (no --second-calibration): each camera decodes its
projector codes, and every first-camera pixel is matched along its rectified row, checked
left-right and triangulated. The cloud is in the first camera's frame.
  --second-manifest FILE  the second camera's sequence.json, when it differs from --manifest
                       (both cameras' frames in one folder)
  --refine-stereo-pose re-estimate the cameras' relative pose from the codes both decoded first
                       (for a rig whose cameras moved, or a file whose R, T do not fit)
  --projector-calibration FILE
                       the first camera's camera-projector calibration with the same projector:
                       each point is then triangulated from three views (both cameras and the
                       projector) instead of two; refused when the projector's columns do not
                       fit the points

Example (a capture set from 'picoscan simulate --out scan/' or 'picoscan capture'):
  picoscan reconstruct --calibration scan/calibration.yml --captures scan/ --out view.ply \
                       --mesh view.stl --preview view.png
)";

// Writes the view and what was asked of it: the cloud, a grid mesh, a preview.
void write_view_products(const ScanView& view, const ReconstructRequest& request, const MeshOptions& mesh_options) {
    OutputBatch outputs;  // the cloud, mesh and preview appear together, or none of them
    write_view_ply(view, request.cloud, request.encoding);  // keeps the pixel grid for clean and stitch
    if (!request.mesh.empty()) {
        const Mesh mesh = mesh_view(view, mesh_options);
        if (mesh.faces.empty()) throw Error(request.captures, "the grid mesh has no triangles: nothing to write");
        write_mesh(mesh, request.mesh, request.encoding);
        std::printf("%zu triangles -> %s\n", mesh.faces.size(), request.mesh.c_str());
    }
    if (!request.preview.empty()) {
        write_preview_png(view, request.preview);
        std::printf("preview -> %s\n", request.preview.c_str());
    }
    outputs.commit();
}

void print_cleaning(const std::optional<CleanReport>& cleaning) {
    if (!cleaning) return;
    std::printf("cleaning removed %d points: %d grazing, %d outliers, %d with too few neighbours, %d in small clusters\n",
                cleaning->removed(), cleaning->by_grazing, cleaning->by_statistics, cleaning->by_radius,
                cleaning->by_cluster);
}

// The binocular path: a stereo calibration and both cameras' captures.
int reconstruct_stereo_and_write(const ReconstructRequest& request) {
    const auto start = std::chrono::steady_clock::now();
    if (!request.second_calibration.empty())
        throw Error("--second-calibration", request.calibration +
                                                " is a stereo calibration of both cameras; give only --second-captures");
    if (request.second_captures.empty())
        throw Error("--second-captures", request.calibration +
                                             " is a stereo calibration: the second camera's captures are required");
    check_extension(request.cloud, {".ply"}, "point cloud file");
    check_extension(request.mesh, {".stl", ".ply", ".obj"}, "mesh file");
    check_extension(request.preview, {".png"}, "preview file");
    for (const std::string& output : {request.cloud, request.mesh, request.preview})
        refuse_overwriting(output, {request.calibration, request.options.manifest_path, request.second_manifest,
                                    request.projector_calibration},
                           {request.captures, request.second_captures});
    MeshOptions mesh_options;
    mesh_options.method = MeshMethod::Grid;
    mesh_options.grid.pixel_step = request.mesh_step;
    validate(mesh_options);

    StereoReconstructOptions options;
    options.manifest_path = request.options.manifest_path;
    options.second_manifest_path = request.second_manifest;
    options.decode = request.options.decode;
    options.clean = request.options.clean;
    options.cleaning = request.options.cleaning;
    options.refine_pose = request.refine_stereo_pose;
    if (!request.projector_calibration.empty()) {
        if (calibration_kind(request.projector_calibration) != CalibrationKind::CameraProjector)
            throw Error("--projector-calibration", request.projector_calibration +
                                                       " is a stereo calibration; give the first camera's camera-projector calibration");
        options.projector = read_calibration(request.projector_calibration);
    }
    const StereoCalibration calibration = read_stereo_calibration(request.calibration);
    const StereoReconstructResult result = reconstruct_stereo_view(request.captures, request.second_captures, calibration,
                                                                   request.calibration, options, terminal_progress());
    if (result.refinement)
        std::printf("cameras' pose refined from %d shared codes (%d agree): median epipolar error %.2f px -> %.2f px, "
                    "rotation changed by %.3f deg\n",
                    result.refinement->pairs, result.refinement->inliers, result.refinement->median_epipolar_before_px,
                    result.refinement->median_epipolar_after_px, result.refinement->rotation_change_deg);
    const StereoStatistics& s = result.statistics;
    std::printf("binocular: %d first-camera pixels decoded, %d matched on the second camera's row (%d ambiguous), "
                "left-right consistency %.2f %%",
                s.left_decoded, s.matched, s.ambiguous, 100 * s.left_right_consistency());
    if (std::isfinite(s.median_epipolar_error_px))
        std::printf(", median epipolar error %.3f px (%d points beyond %.1f px dropped)\n", s.median_epipolar_error_px,
                    s.epipolar_rejected, options.stereo.max_epipolar_error_px);
    else
        std::printf("\nwarning: no projector rows in both cameras' captures, so whether the calibration fits them "
                    "(the cameras not swapped or moved) is not checked; project rows to check it\n");
    if (s.three_view > 0)
        std::printf("three views: %d points refined with the projector, median projector column residual %.3f px\n",
                    s.three_view, s.median_projector_residual_px);
    print_cleaning(result.cleaning);
    write_view_products(result.view, request, mesh_options);
    std::printf("%d points (%.1f %% of the first camera's pixels) -> %s\n", result.point_count,
                100.0 * result.point_count / static_cast<double>(result.view.points.total()), request.cloud.c_str());
    std::printf("done in %.2f s\n", seconds_since(start));
    return 0;
}

int run_reconstruct(const Arguments& arguments) {
    ReconstructRequest request;
    request.calibration = arguments.required("--calibration");
    request.captures = arguments.required("--captures");
    request.options.manifest_path = arguments.text("--manifest");
    request.cloud = arguments.required("--out");
    request.mesh = arguments.text("--mesh");
    request.preview = arguments.text("--preview");
    request.mesh_step = arguments.integer("--mesh-step", request.mesh_step);
    request.options.clean = arguments.flag("--clean");
    request.second_calibration = arguments.text("--second-calibration");
    request.second_captures = arguments.text("--second-captures");
    DecodeOptions& decode = request.options.decode;
    decode.binary_only = arguments.flag("--binary-only");
    decode.min_contrast = arguments.number("--min-contrast", decode.min_contrast);
    decode.min_modulation = arguments.number("--min-modulation", decode.min_modulation);
    request.encoding = arguments.flag("--ascii") ? Encoding::Ascii : Encoding::Binary;
    request.refine_stereo_pose = arguments.flag("--refine-stereo-pose");
    request.second_manifest = arguments.text("--second-manifest");
    request.projector_calibration = arguments.text("--projector-calibration");
    arguments.reject_unknown();
    return reconstruct_and_write(request);
}

constexpr const char* kSimulationMarker = ".picoscan-simulate";

// simulate writes into a new or empty folder, or restarts in one that an interrupted simulate
// run left (its marker, written first, without calibration.yml, written last); a finished
// set and anything else are left alone.
void restart_simulation_folder(const std::string& directory) {
    std::error_code error;
    if (fs::is_regular_file(fs::path(directory) / kSimulationMarker, error) &&
        !fs::exists(fs::path(directory) / "calibration.yml", error)) {
        fs::remove_all(directory, error);
        if (error) throw Error(directory, "cannot clear the earlier simulation: " + error.message());
        return;
    }
    require_empty_directory(directory);
}

int run_simulate(const Arguments& arguments) {
    const std::string directory = arguments.required("--out");
    const Calibration calibration =
        arguments.has("--calibration") ? read_calibration(arguments.text("--calibration")) : seed_rig_calibration();
    const Scene scene = arguments.has("--scene") ? read_scene(arguments.text("--scene")) : demo_scene();
    SimulateOptions options;
    options.patterns = pattern_options(arguments, calibration.projector_size);
    options.camera = camera_options(arguments);
    arguments.reject_unknown();
    restart_simulation_folder(directory);
    const CaptureSet captures = simulate_captures(scene, calibration, options, terminal_progress());
    std::error_code ignored;
    fs::create_directories(directory, ignored);
    // Marked first: an interrupted run leaves a folder the next run may restart in.
    write_file_atomically((fs::path(directory) / kSimulationMarker).string(),
                          "made by picoscan simulate; if interrupted, the next simulate run restarts here\n");
    write_capture_set(captures, directory);
    write_calibration(calibration, (fs::path(directory) / "calibration.yml").string());
    std::printf("wrote %zu simulated frames, sequence.json and calibration.yml to %s\n", captures.images.size(),
                directory.c_str());
    return 0;
}

}  // namespace

SimulationOptions camera_options(const Arguments& arguments) {
    SimulationOptions options = SimulateOptions{}.camera;
    options.noise_sigma_dn = arguments.number("--noise", options.noise_sigma_dn);
    options.projector_gamma = arguments.number("--gamma", options.projector_gamma);
    options.blur_sigma_px = arguments.number("--blur", options.blur_sigma_px);
    options.seed = static_cast<uint64_t>(arguments.integer("--seed", static_cast<int>(options.seed)));
    validate(options);
    return options;
}

void check_reconstruct_outputs(const ReconstructRequest& request) {
    check_extension(request.cloud, {".ply"}, "point cloud file");
    check_extension(request.mesh, {".stl", ".ply", ".obj"}, "mesh file");
    check_extension(request.preview, {".png"}, "preview file");
    const std::vector<std::string> inputs{request.calibration, request.options.manifest_path, request.second_calibration};
    for (const std::string& output : {request.cloud, request.mesh, request.preview})
        refuse_overwriting(output, inputs, {request.captures, request.second_captures});
    refuse_overwriting(request.mesh, {request.cloud});  // outputs must differ from each other too
    refuse_overwriting(request.preview, {request.cloud, request.mesh});
}

int reconstruct_and_write(const ReconstructRequest& request) {
    // The calibration's kind decides the method.
    if (calibration_kind(request.calibration) == CalibrationKind::Stereo) return reconstruct_stereo_and_write(request);
    if (request.refine_stereo_pose) throw Error("--refine-stereo-pose", "needs a stereo calibration of two cameras");
    if (!request.second_manifest.empty()) throw Error("--second-manifest", "needs a stereo calibration of two cameras");
    if (!request.projector_calibration.empty())
        throw Error("--projector-calibration", "goes with a stereo calibration of two cameras as --calibration");
    if (request.second_calibration.empty() != request.second_captures.empty())
        throw Error("--second-captures", "--second-calibration and --second-captures go together");
    // The same frames twice would "confirm" every point: the check would pass without checking.
    if (!request.second_captures.empty() && absolute_path(request.second_captures) == absolute_path(request.captures))
        throw Error("--second-captures", "is the --captures folder again: give the second camera's own captures");
    const auto start = std::chrono::steady_clock::now();
    // Refuse bad output names before any work, so nothing is half done.
    check_reconstruct_outputs(request);
    MeshOptions mesh_options;
    mesh_options.method = MeshMethod::Grid;
    mesh_options.grid.pixel_step = request.mesh_step;
    validate(mesh_options);
    validate(request.options);

    const Calibration calibration = read_calibration(request.calibration);
    ReconstructOptions options = request.options;
    if (!request.second_calibration.empty())
        options.second_camera = SecondCamera{read_calibration(request.second_calibration), request.second_calibration,
                                             request.second_captures};
    const ReconstructResult result =
        reconstruct_view(request.captures, calibration, request.calibration, options, terminal_progress());
    if (options.second_camera)
        std::printf("%d points not confirmed by the second camera removed\n", result.unconfirmed_removed);
    print_cleaning(result.cleaning);
    write_view_products(result.view, request, mesh_options);
    std::printf("%d points (%.1f %% of the camera pixels), %d fringe orders corrected -> %s\n", result.point_count,
                100.0 * result.point_count / static_cast<double>(result.view.points.total()), result.order_corrections,
                request.cloud.c_str());
    std::printf("done in %.2f s\n", seconds_since(start));
    return 0;
}

std::vector<Command> scan_commands() {
    return {
        {"simulate", "render a capture set of a virtual scene with the simulated rig", kSimulateHelp, run_simulate,
         {{"--rows", "--no-rows"}, {}, false}},
        {"reconstruct", "decode a capture set and triangulate it into a point cloud (and mesh)", kReconstructHelp,
         run_reconstruct, {{"--binary-only", "--ascii", "--clean", "--refine-stereo-pose"}, {}, false}},
    };
}

}  // namespace picoscan::cli
