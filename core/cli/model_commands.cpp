// picoscan clean, stitch, mesh and demo: from views to a printable model.
#include "cli_support.h"
#include "commands.h"

#include "picoscan/calibration.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"
#include "picoscan/preview.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>

namespace fs = std::filesystem;

namespace picoscan::cli {

namespace {

const char* kCleanHelp = R"(picoscan clean VIEW.ply --out CLEAN.ply [options]

Removes stray-light noise and unreliable points from one view written by 'picoscan
reconstruct' (its PLY keeps the camera pixel of every point and the camera, which the
filters use).
Each filter prints how many points it removed. The input is never modified.

Options:
  --background EMPTY.ply     a view of the empty scene (same rig and camera pose): points on
                             or behind it are removed
  --background-tolerance-mm  how close to the background counts as background (default 1)
  --box X0,Y0,Z0,X1,Y1,Z1    keep only points inside this camera-frame box (mm)
  --min-quality Q            drop points whose fringe modulation is below Q grey levels
                             (default 0: none)
  --max-grazing-deg A        drop points seen more obliquely than A degrees (default 80)
  --outlier-sigma S          statistical outliers: beyond S robust sigmas (default 4)
  --min-cluster N            drop disconnected clusters smaller than N points (default 100)
  --calibration rig.yml      the rig's calibration, only for views written before PicoScan
                             stored the camera in the view

Example:
  picoscan clean view.ply --out view-clean.ply --max-grazing-deg 70
)";

const char* kStitchHelp = R"(picoscan stitch VIEW.ply VIEW.ply ... [--then VIEW.ply ...] --out MERGED.ply [options]

Aligns several views of one part (each written by 'picoscan reconstruct', ideally cleaned)
into one model, in the first view's camera frame, and writes the merged cloud with normals.

Placements: when the part was set down again between views (standing, then on its side, so
that the face it stood on is seen), give the views of each further placement after --then:
  picoscan stitch stand/*.ply --then side/*.ply --out merged.ply
Each placement is aligned on its own (by --mode or the turntable options below, which apply
to every placement: the table stays where it is), then the placements are aligned to each
other by their shape alone: no guess and no paint needed. A placement is joined only when
exactly one fit passes, it fixes the pose, fits within the views' own residual, and puts no
point where a camera of the other placement saw through; otherwise it is named with the
reason and left out. Then all views are refined together.
  1. ORB features on each view's white frame, lifted to 3D, matched and fitted by RANSAC;
     where too few match (large turns, plain parts), shape histograms (FPFH) instead;
  2. point-to-plane ICP with trimmed correspondences for every overlapping pair; a pair is
     accepted only when it overlaps, converges, fits tightly, leaves no point of either view
     where the other's camera saw through, fixes the pose (nothing slides), fits only one
     way, and (where both views are painted) its paint lines up;
  3. all views refined together (multi-view ICP), so no error piles up around a full turn.
Views that cannot be aligned are named with the reason and their overlap, are left out of
the merge and are written beside it as MERGED.unmerged-NAME.ply; the exit code is then 3.
stitch prints each way it tried (per placement: the views it aligned, the first it left out
and why, kept or not) and, for every view, the way that placed it.
The poses go to MERGED.poses.txt (one 4x4 view->model matrix per view; with placements, a
'# placement N' line before each placement's views).

How each placement's views are aligned without a guess (--mode):
  automatic        (default) features first (step 1 above); a placement they leave incomplete
                   (a plain, unpainted part gives no features) is aligned again as one
                   turntable round (below), and the way that aligns more of its views is
                   kept, features when both align as many. When features align every
                   view, nothing more is tried.
  features         step 1 above only (painted or textured parts; hand-held views)
  turntable-round  the views are one full turntable round, in order, in equal steps; the
                   axis is unknown: the step is estimated from all the views together

Options:
  --mode automatic|features|turntable-round  see above (default automatic)
  --turntable-round          short for --mode turntable-round
  --turntable X,Y,Z,DX,DY,DZ  a calibrated turntable axis (point and direction, camera frame,
                             mm): the views were taken in equal steps around it, in order;
                             its steps replace the feature search as the initial guess (no
                             --mode). When all views of one turntable round are stitched,
                             stitch prints the axis they turn about, ready to paste here.
  --step-deg A               turntable step between consecutive views (default 360/views
                             of the placement)
  --initial-poses P.txt      start ICP from these view->model poses (the format stitch writes
                             to MERGED.poses.txt, views in the same order) instead of features
                             (no --mode)
  --spacing-mm S             points are thinned to about S mm for ICP, 0.1..20 (default 0.7)

Example (one turntable round of cleaned views, in order):
  picoscan stitch views/view_*.ply --out merged.ply
)";

const char* kMeshHelp = R"(picoscan mesh CLOUD.ply --out PART.stl|PART.3mf|PART.ply [--method poisson|advancing-front|grid]
                    [--fill open|table|poisson] [options]

Turns a cloud with normals (from 'picoscan stitch' or 'reconstruct') into a triangle mesh:
  poisson          watertight surface (Poisson reconstruction); default
  advancing-front  interpolates the points and leaves unmeasured areas open; holes smaller
                   than --max-hole-mm are filled (triangulated, refined and faired)
  grid             joins neighbouring camera pixels of ONE view written by 'reconstruct'
What closes the side the scan never saw (poisson only; the face the part stood on):
  --fill poisson   Poisson's own smooth guess (default); the check below says how much of
                   the surface was filled in, not measured, and warns when it is much
  --fill table     a flat cap on the turntable's plane, for a part standing on the table;
                   walls seen only in part (a deep hole) are continued down to it. The plane
                   is across --turntable's axis when given, else fitted to the unseen side's rim
  --fill open      nothing invented: the unseen side stays open (not printable as it is);
                   the points are contoured where they are, no Poisson (one view: seconds)
The mesh is checked before it is written (watertight, manifold, self-intersections, volume,
share of filled-in surface) and the result is printed. Output by extension: .stl, .3mf
(units millimetres), .ply (vertex colours from the white frames; quality 1 = measured,
0 = filled in) or .obj.

Options:
  --spacing-mm S       thin the cloud to about S mm first (default 0.4; 0 keeps every point)
  --max-points N       thin further until at most N points remain (default 200000): the budget
                       that bounds meshing time
  --max-faces N        Poisson's triangles grow until the surface has about N at most (default 400000)
  --turntable X,Y,Z,DX,DY,DZ  the turntable axis (as 'picoscan stitch' prints it), for --fill table
  --target-faces N     simplify to about N triangles (default: no simplification)
  --max-hole-mm D      advancing front: fill holes up to D mm across (default 10)
  --mesh-step N        grid: join every N-th pixel only (default 1)
  --preview P.png      a contact sheet: the mesh from top, bottom and four sides, filled-in
                       surface in orange

Examples:
  picoscan mesh merged.ply --out part.stl --preview part.png     # watertight, for printing
  picoscan mesh view.ply --method grid --mesh-step 2 --out view.stl
)";

const char* kDemo360Help = R"(picoscan demo [--out DIR] [--single-view]

A complete scan of the built-in mechanical part (a block with a through hole, a boss and a
chamfer, speckle-painted) on a simulated turntable, in two placements: standing, then laid on
its side so that the face it stood on is seen; one round of 8 views each. Each view is
simulated, reconstructed and cleaned; the views of both placements are stitched into one
model as 'stitch --turntable-round' does (each round's step estimated from its views, then
the placements joined by shape) and meshed into a watertight STL.
Writes DIR/captures/{standing,side}_view_K/ (capture sets), DIR/calibration.yml,
DIR/views/{standing,side}_view_K.ply, DIR/merged.ply (+ merged.poses.txt), the model as
DIR/part.stl, DIR/part.3mf (millimetres) and DIR/part.ply (with the white frames' colours and
a measured/filled flag per vertex), DIR/part.png (a contact sheet: top, bottom and four sides,
filled-in surface in orange), and the simulation's true poses in DIR/true_poses.txt.
Default DIR: demo-output.
--single-view: the older one-view demo of a bracket (DIR/cloud.ply, part.stl, preview.png).

An interrupted demo is restarted by running the same command again: the demo marks
DIR/captures/ (.picoscan-demo) before writing into it and replaces only a folder so marked
(or an empty one), never one it did not make. The other outputs are replaced whole.

Example (about 2 minutes of CPU time; then open demo/part.stl or demo/part.png):
  picoscan demo --out demo/
)";

int run_clean(const Arguments& arguments) {
    const std::string input = single_input(arguments);
    const std::string out = arguments.required("--out");
    const std::string calibration_path = arguments.text("--calibration");
    const std::string background_path = arguments.text("--background");
    check_extension(out, {".ply"}, "cleaned view (PLY)");
    refuse_overwriting(out, {input, background_path, calibration_path});
    CleanOptions options;
    options.min_quality = arguments.number("--min-quality", options.min_quality);
    options.max_grazing_deg = arguments.number("--max-grazing-deg", options.max_grazing_deg);
    options.outlier_sigma = arguments.number("--outlier-sigma", options.outlier_sigma);
    options.min_cluster_points = arguments.integer("--min-cluster", options.min_cluster_points);
    if (arguments.has("--box")) {
        const std::vector<double> box = arguments.numbers("--box", 6);
        options.use_working_volume = true;
        options.volume_min = {box[0], box[1], box[2]};
        options.volume_max = {box[3], box[4], box[5]};
    }
    CleanScanOptions clean;
    clean.cleaning = options;
    clean.background_tolerance_mm = arguments.number("--background-tolerance-mm", clean.background_tolerance_mm);
    arguments.reject_unknown();
    validate(clean);
    ScanView view = read_view_ply(input);
    if (!(view.camera_matrix(0, 0) > 0)) {
        if (calibration_path.empty())
            throw Error(input, "does not store its camera (an older view): give --calibration, or reconstruct it again");
        const Calibration calibration = read_calibration(calibration_path);
        view.camera_matrix = calibration.camera_matrix;
        view.camera_distortion = calibration.camera_distortion;
    }
    const int before = view.valid_count();
    std::optional<ScanView> background;
    if (!background_path.empty()) background = read_view_ply(background_path);
    const CleanScanResult result = clean_scan(view, input, clean, background ? &*background : nullptr);
    const CleanReport& report = result.report;
    if (background) std::printf("background: %d points removed\n", result.background_removed);
    std::printf("quality: %d, grazing: %d, working volume: %d, statistical outliers: %d, too few neighbours: %d, "
                "small clusters: %d removed\n",
                report.by_quality, report.by_grazing, report.by_working_volume, report.by_statistics, report.by_radius,
                report.by_cluster);
    write_view_ply(view, out);
    std::printf("%d of %d points kept -> %s\n", report.remaining, before, out.c_str());
    return 0;
}

std::vector<ViewPose> view_poses(const Alignment& alignment) {
    std::vector<ViewPose> poses;
    for (const ViewAlignment& view : alignment.views) poses.push_back({view.name, view.pose, view.aligned, view.placement});
    return poses;
}

// The outputs stitch derives from --out: the poses, and each view it could not align.
std::string poses_path(const std::string& out) { return fs::path(out).replace_extension(".poses.txt").string(); }
std::string unmerged_view_path(const std::string& out, const std::string& view_name) {
    return fs::path(out).replace_extension("").string() + ".unmerged-" + view_name;
}

// Views are named by their file names, or, when two share one (placements in folders of
// their own), by folder_file.
std::vector<std::string> view_names(const std::vector<std::string>& paths) {
    std::vector<std::string> names;
    for (const std::string& path : paths) names.push_back(fs::path(path).filename().string());
    std::vector<std::string> sorted = names;
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end()) return names;
    for (size_t i = 0; i < paths.size(); ++i)
        names[i] = absolute_path(paths[i]).parent_path().filename().string() + "_" + names[i];
    return names;
}

// Aligns the views and writes the merged cloud and its poses; returns how many views were left out.
int stitch_and_write(const std::vector<std::string>& paths, const std::string& out, const StitchOptions& options) {
    std::vector<ScanView> views;
    for (const std::string& path : paths) views.push_back(read_view_ply(path));
    const std::vector<std::string> names = view_names(paths);
    const auto start = std::chrono::steady_clock::now();
    const StitchResult result = stitch_views(views, names, options, terminal_progress());
    OutputBatch outputs;  // the cloud, its poses and the unmerged views appear together
    int left_out = 0;
    // Each way tried, per placement: what it aligned, the first view it left out and why, kept or not.
    const bool several = result.alignment.placements.size() > 1;
    for (const StitchAttempt& attempt : result.attempts)
        std::printf("%s%s: %d of %d views aligned%s%s; %s\n",
                    several ? ("placement " + std::to_string(attempt.placement + 1) + " by ").c_str() : "by ",
                    attempt.method.c_str(), attempt.aligned_views, attempt.views,
                    attempt.problem.empty() ? "" : ", first left out: ", attempt.problem.c_str(),
                    attempt.kept ? "kept" : "not kept");
    for (size_t i = 0; i < views.size(); ++i) {
        const ViewAlignment& view = result.alignment.views[i];
        if (view.aligned) {
            std::printf("%-24s aligned by %s: residual %.4f mm, overlap %.0f %%\n", names[i].c_str(),
                        result.method_of_view[i].c_str(), view.rms_mm, 100 * std::min(1.0, view.overlap));
            continue;
        }
        ++left_out;
        std::fprintf(stderr, "%-24s NOT aligned: %s; best overlap %.0f %%\n", names[i].c_str(), view.problem.c_str(),
                     100 * std::min(1.0, view.overlap));
        const std::string unmerged = unmerged_view_path(out, names[i]);
        write_view_ply(views[i], unmerged);
        std::fprintf(stderr, "%-24s written unmerged -> %s\n", "", unmerged.c_str());
    }
    for (const PlacementAlignment& placement : result.alignment.placements) {
        if (&placement == &result.alignment.placements.front())
            std::printf("%-24s %s\n", placement.name.c_str(), placement.aligned ? "the model frame" : "NOT aligned: no view of it aligned");
        else if (placement.aligned)
            std::printf("%-24s aligned to the others: residual %.4f mm (its views' own %.4f mm), overlap %.0f %%\n",
                        placement.name.c_str(), placement.rms_mm, placement.noise_mm, 100 * std::min(1.0, placement.overlap));
        else
            std::fprintf(stderr, "%-24s NOT aligned: %s\n", placement.name.c_str(), placement.problem.c_str());
    }
    write_ply(result.merged, out);
    write_poses(view_poses(result.alignment), poses_path(out));
    outputs.commit();
    std::printf("%d of %zu views merged, %zu points -> %s (%.1f s)\n", result.alignment.aligned_count(), views.size(),
                result.merged.points.size(), out.c_str(), seconds_since(start));
    if (result.axis)
        std::printf("these views turn about one axis; next time: --turntable %.4f,%.4f,%.4f,%.6f,%.6f,%.6f --step-deg %.3f\n",
                    result.axis->point_mm[0], result.axis->point_mm[1], result.axis->point_mm[2],
                    result.axis->direction[0], result.axis->direction[1], result.axis->direction[2],
                    result.axis->step_deg);
    return left_out;
}

// The same view given twice (the same file, or two files with the same bytes) would be
// merged onto itself: worth a warning, not an error (a copy may be intended). Only files of
// one size can hold the same bytes: the others are not read for this.
void warn_about_duplicate_views(const std::vector<std::string>& inputs) {
    auto size_of = [](const std::string& path) {
        std::error_code unknown;  // all files of unknown size are compared with each other
        return fs::file_size(path, unknown);
    };
    std::map<std::uintmax_t, int> files_of_size;
    for (const std::string& input : inputs) ++files_of_size[size_of(input)];
    std::map<std::string, std::string> first_with_content;
    for (const std::string& input : inputs) {
        if (files_of_size[size_of(input)] < 2) continue;
        std::ifstream file(input, std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
        const auto [found, fresh] = first_with_content.emplace(std::move(bytes), input);
        if (!fresh)
            std::fprintf(stderr, "picoscan stitch: warning: %s is the same view as %s\n", input.c_str(),
                         found->second.c_str());
    }
}

int run_stitch(const Arguments& arguments) {
    // The views in order, placement after placement.
    std::vector<std::string> inputs = arguments.inputs();
    std::vector<int> placement_of_view(inputs.size(), 0);
    std::vector<size_t> placement_sizes{inputs.size()};
    for (const std::vector<std::string>& placement : arguments.occurrences("--then")) {
        for (const std::string& input : placement) {
            inputs.push_back(input);
            placement_of_view.push_back(static_cast<int>(placement_sizes.size()));
        }
        placement_sizes.push_back(placement.size());
    }
    if (placement_sizes.front() == 0) throw Error("--then", "give the first placement's views before --then");
    for (const std::string& input : inputs)
        if (!fs::is_regular_file(input)) throw Error(input, "no such file");
    const std::string out = arguments.required("--out");
    check_extension(out, {".ply"}, "merged cloud (PLY)");
    // Every output, derived ones included, is checked before any work: none may be an input.
    const std::string initial_poses = arguments.text("--initial-poses");
    std::vector<std::string> every_input = inputs;
    every_input.push_back(initial_poses);
    refuse_overwriting(out, every_input);
    refuse_overwriting(poses_path(out), every_input);
    for (const std::string& name : view_names(inputs)) refuse_overwriting(unmerged_view_path(out, name), every_input);
    if (inputs.size() < 2) throw Error("stitch", "needs at least two views (got " + std::to_string(inputs.size()) + ")");
    warn_about_duplicate_views(inputs);
    StitchOptions options;
    options.registration.sample_spacing_mm = arguments.number("--spacing-mm", options.registration.sample_spacing_mm);
    if (arguments.has("--step-deg") && !arguments.has("--turntable"))
        throw Error("--step-deg", "goes with --turntable (without an axis, --mode turntable-round estimates the step)");
    if (arguments.has("--turntable")) {
        const std::vector<double> axis = arguments.numbers("--turntable", 6);
        options.turntable = TurntableAxis{{axis[0], axis[1], axis[2]}, {axis[3], axis[4], axis[5]}, 360.0 / placement_sizes.front()};
        if (cv::norm(options.turntable->direction) < 1e-9) throw Error("--turntable", "the axis direction must not be zero");
        if (!arguments.has("--step-deg") &&
            std::any_of(placement_sizes.begin(), placement_sizes.end(), [&](size_t size) { return size != placement_sizes.front(); }))
            throw Error("--step-deg", "is needed when the placements have different numbers of views");
        options.turntable->step_deg = arguments.number("--step-deg", options.turntable->step_deg);
    }
    // How each placement's views are aligned: --mode (automatic unless a guess is given), or
    // the guess itself (a known axis, initial poses).
    std::string mode = arguments.text("--mode");
    if (arguments.flag("--turntable-round")) {
        if (!mode.empty()) throw Error("--turntable-round", "is short for --mode turntable-round: give one of them");
        mode = "turntable-round";
    }
    const std::string mode_option = arguments.flag("--turntable-round") ? "--turntable-round" : "--mode";
    if (!mode.empty() && options.turntable)
        throw Error(mode_option, "give either --turntable (axis known) or " + mode_option + " (no guess)");
    if (!mode.empty() && arguments.has("--initial-poses"))
        throw Error("--initial-poses", "give either --turntable, " + mode_option + " or --initial-poses");
    if (mode.empty() && !options.turntable && !arguments.has("--initial-poses")) mode = "automatic";
    if (mode == "automatic") options.automatic = true;
    else if (mode == "turntable-round") options.registration.turntable_round = true;
    else if (!mode.empty() && mode != "features")
        throw Error("--mode", "must be automatic, features or turntable-round, got '" + mode + "'");
    if (placement_sizes.size() > 1) options.placement_of_view = placement_of_view;
    if (arguments.has("--initial-poses")) {
        if (placement_sizes.size() > 1) throw Error("--initial-poses", "cannot be used with --then (placements)");
        const std::string path = arguments.text("--initial-poses");
        const std::vector<ViewPose> poses = read_poses(path);
        if (poses.size() != inputs.size())
            throw Error(path, "has " + std::to_string(poses.size()) + " poses for " + std::to_string(inputs.size()) + " views");
        for (const ViewPose& pose : poses) options.registration.initial_poses.push_back(pose.pose);
    }
    arguments.reject_unknown();
    validate(options);
    return stitch_and_write(inputs, out, options) > 0 ? 3 : 0;
}

void report_mesh(const Mesh& mesh, const std::string& path) {
    const MeshCheck check = check_mesh(mesh);
    std::printf("%s\n", check.summary().c_str());
    if (!check.watertight() || !check.closed_volume)
        std::printf("warning: %s is not a closed volume; a slicer may refuse it or guess\n", path.c_str());
}

int run_mesh(const Arguments& arguments) {
    const std::string input = single_input(arguments);
    const std::string out = arguments.required("--out");
    const std::string method = arguments.text("--method", "poisson");
    const std::string preview = arguments.text("--preview");
    check_extension(out, {".stl", ".ply", ".obj", ".3mf"}, "mesh file");
    check_extension(preview, {".png"}, "preview file");
    refuse_overwriting(out, {input});
    refuse_overwriting(preview, {input, out});
    MeshOptions options;
    if (method == "poisson") options.method = MeshMethod::Poisson;
    else if (method == "advancing-front") options.method = MeshMethod::AdvancingFront;
    else if (method == "grid") options.method = MeshMethod::Grid;
    else throw Error("--method", "must be poisson, advancing-front or grid, got '" + method + "'");
    if (arguments.has("--fill")) options.fill = mesh_fill_from_name(arguments.text("--fill"), "--fill");
    if (arguments.has("--turntable")) {
        if (options.fill != MeshFill::Table) throw Error("--turntable", "is used by --fill table only");
        const std::vector<double> axis = arguments.numbers("--turntable", 6);
        options.table_axis = cv::Vec3d(axis[3], axis[4], axis[5]);
        if (cv::norm(options.table_axis) < 1e-9) throw Error("--turntable", "the axis direction must not be zero");
    }
    options.sample_spacing_mm = arguments.number("--spacing-mm", options.sample_spacing_mm);
    options.max_points = arguments.integer("--max-points", options.max_points);
    options.max_faces = arguments.integer("--max-faces", options.max_faces);
    options.target_faces = arguments.integer("--target-faces", options.target_faces);
    options.max_hole_diameter_mm = arguments.number("--max-hole-mm", options.max_hole_diameter_mm);
    options.grid.pixel_step = arguments.integer("--mesh-step", options.grid.pixel_step);
    arguments.reject_unknown();
    validate(options);
    const auto start = std::chrono::steady_clock::now();
    Mesh mesh;
    if (options.method == MeshMethod::Grid) {
        mesh = mesh_view(read_view_ply(input), options);
    } else {
        const Mesh points = read_ply(input);
        PointCloud cloud;
        cloud.points = points.vertices;
        cloud.normals = points.normals;
        cloud.colours = points.colours;
        try {
            mesh = mesh_points(cloud, options, terminal_progress());
        } catch (const Error& error) {
            // The core names the cloud "point cloud"; here it is a file. A stage's refusal of the
            // cloud ("Poisson reconstruction: ...") is said of the file too.
            if (error.subject() == "Poisson reconstruction") throw Error(input, error.what());
            if (error.subject() != "point cloud") throw;
            throw Error(input, std::string(error.what()).substr(error.subject().size() + 2));
        }
    }
    if (mesh.faces.empty()) throw Error(input, "meshing produced no triangles: nothing to write");
    report_mesh(mesh, out);
    OutputBatch outputs;  // the mesh and its preview appear together
    write_mesh(mesh, out);
    if (!preview.empty()) write_contact_sheet_png(mesh, preview);
    outputs.commit();
    std::printf("%zu triangles -> %s (%.1f s)\n", mesh.faces.size(), out.c_str(), seconds_since(start));
    if (!preview.empty()) std::printf("contact sheet -> %s\n", preview.c_str());
    return 0;
}

// Replaces the demo's own previous capture folder, finished or interrupted (it carries a
// marker, written before anything else), or an empty one; never anything else. Leaves the
// folder empty but for a new marker, so that a run interrupted from here on is restarted by
// the same command.
void start_demo_captures(const fs::path& captures) {
    std::error_code error;
    if (fs::exists(captures, error) && !fs::is_empty(captures, error) &&
        !fs::is_regular_file(captures / ".picoscan-demo", error))
        throw Error(captures.string(), "exists and was not made by 'picoscan demo'; choose another --out");
    fs::remove_all(captures, error);
    if (error) throw Error(captures.string(), "cannot be replaced: " + error.message());
    fs::create_directories(captures, error);
    if (error) throw Error(captures.string(), "cannot be created: " + error.message());
    write_file_atomically((captures / ".picoscan-demo").string(),
                          "made by picoscan demo; the next demo run replaces this folder\n");
}

// The older demo: one view of a bracket, reconstructed as 'picoscan reconstruct' does.
int run_demo_single_view(const fs::path& directory) {
    const fs::path captures = directory / "captures";
    start_demo_captures(captures);
    const Calibration calibration = seed_rig_calibration();
    std::printf("simulating a scan of the built-in part (1600x1200 camera, 854x480 projector)...\n");
    write_capture_set(simulate_captures(demo_scene(), calibration, SimulateOptions{}, terminal_progress()),
                      captures.string());
    write_calibration(calibration, (directory / "calibration.yml").string());
    ReconstructRequest request;
    request.calibration = (directory / "calibration.yml").string();
    request.captures = captures.string();
    request.cloud = (directory / "cloud.ply").string();
    request.mesh = (directory / "part.stl").string();
    request.preview = (directory / "preview.png").string();
    request.mesh_step = 2;  // a 1-million-triangle STL rather than 4 million
    return reconstruct_and_write(request);
}

// The 360-degree demo: the part scanned in two placements (standing, then on its side so
// that its bottom is seen), cleaned, stitched into one model, meshed.
int run_demo_360(const fs::path& directory) {
    const fs::path captures = directory / "captures";
    start_demo_captures(captures);
    fs::create_directories(directory / "views");
    const Calibration calibration = seed_rig_calibration();
    write_calibration(calibration, (directory / "calibration.yml").string());
    struct Placement { std::string name; TurntableScanOptions scan; };
    std::vector<Placement> placements(2);
    placements[0].name = "standing";
    placements[1].name = "side";
    placements[1].scan.plan.placement = PartPlacement::OnItsSide;  // the face it stood on turned to the camera
    placements[1].scan.plan.placement_turn_deg = 20;
    placements[1].scan.camera.seed = 101;  // independent camera noise
    std::vector<std::string> view_files;
    std::vector<int> placement_of_view;
    std::vector<ViewPose> truth;
    std::vector<cv::Matx44d> part_to_camera;
    for (size_t p = 0; p < placements.size(); ++p) {
        Placement& placement = placements[p];
        placement.scan.plan.top_view = false;  // each placement one turntable round
        std::printf("placement %zu (%s):\n", p + 1, placement.name.c_str());
        const std::vector<cv::Matx44d> poses = simulate_turntable_scan(
            mechanical_part(), calibration, placement.scan,
            [&](const SimulatedView& simulated) {
                const std::string name = placement.name + "_" + simulated.name;
                write_capture_set(simulated.captures, (captures / name).string());
                view_files.push_back((directory / "views" / (name + ".ply")).string());
                placement_of_view.push_back(static_cast<int>(p));
                write_view_ply(simulated.view, view_files.back());
                truth.push_back({name + ".ply", cv::Matx44d::eye(), true, static_cast<int>(p)});
                std::printf("view %zu: %d points after cleaning (%d removed) -> %s\n", view_files.size(),
                            simulated.cleaning.remaining, simulated.cleaning.removed(), view_files.back().c_str());
            },
            terminal_progress());
        part_to_camera.insert(part_to_camera.end(), poses.begin(), poses.end());
    }
    // The simulation's ground truth, in the format stitch writes, to judge the stitching by.
    for (size_t i = 0; i < part_to_camera.size(); ++i) truth[i].pose = part_to_camera[0] * part_to_camera[i].inv();
    write_poses(truth, (directory / "true_poses.txt").string());
    const std::string merged = (directory / "merged.ply").string();
    StitchOptions stitch;
    stitch.placement_of_view = placement_of_view;
    stitch.registration.turntable_round = true;  // each placement: one round, its step estimated
    if (stitch_and_write(view_files, merged, stitch) > 0)
        throw Error(merged, "not every view could be aligned (see above)");
    const Mesh points = read_ply(merged);
    PointCloud cloud;
    cloud.points = points.vertices;
    cloud.normals = points.normals;
    cloud.colours = points.colours;  // the white frames' shade, carried to the mesh's vertices
    const Mesh mesh = mesh_points(cloud, MeshOptions{}, terminal_progress());
    const std::string stl = (directory / "part.stl").string();
    report_mesh(mesh, stl);
    OutputBatch outputs;  // the model in every format and its contact sheet appear together
    for (const char* extension : {".stl", ".3mf", ".ply"})
        write_mesh(mesh, (directory / (std::string("part") + extension)).string());
    write_contact_sheet_png(mesh, (directory / "part.png").string());
    outputs.commit();
    std::printf("%zu triangles -> %s (also part.3mf, part.ply with colours), contact sheet -> %s\n",
                mesh.faces.size(), stl.c_str(), (directory / "part.png").c_str());
    return 0;
}

int run_demo(const Arguments& arguments) {
    const fs::path directory = arguments.text("--out", "demo-output");
    const bool single_view = arguments.flag("--single-view");
    arguments.reject_unknown();
    return single_view ? run_demo_single_view(directory) : run_demo_360(directory);
}

}  // namespace

std::vector<Command> model_commands() {
    return {
        {"clean", "remove stray-light noise, background and outliers from a view", kCleanHelp, run_clean,
         {{}, {}, true}},
        {"stitch", "align several views of a part, in one or more placements, into one model", kStitchHelp, run_stitch,
         {{"--turntable-round"}, {"--then"}, true}},
        {"mesh", "mesh a cloud: Poisson (open, table cap or closed), advancing front or pixel grid -> STL/3MF/PLY", kMeshHelp, run_mesh,
         {{}, {}, true}},
        {"demo", "simulated scan of the built-in part in two placements -> watertight STL", kDemo360Help, run_demo,
         {{"--single-view"}, {}, false}},
    };
}

}  // namespace picoscan::cli
