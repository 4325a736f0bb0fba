// The recipes every front end runs (pipeline.h): stage calls in order, with progress.
#include "picoscan/pipeline.h"

#include "picoscan/error.h"
#include "picoscan/io.h"
#include "picoscan/multi_camera.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <string>

namespace picoscan {

namespace {

ReconstructResult finish_view(ScanView view, int order_corrections, const Calibration& calibration,
                              const ReconstructOptions& options, const ProgressCallback& progress,
                              const std::string& source) {
    ReconstructResult result;
    result.view = std::move(view);
    result.order_corrections = order_corrections;
    if (options.second_camera) {
        const SecondCamera& second = *options.second_camera;
        const CaptureSet captures =
            load_capture_set(second.captures_folder, options.manifest_path, progress, second.calibration.camera_size);
        check_camera_size(second.calibration, captures, second.calibration_name);
        const CorrespondenceMap map = decode(captures, options.decode, progress);
        result.unconfirmed_removed = reject_unconfirmed_points(result.view, calibration, map, second.calibration);
    }
    if (options.clean) result.cleaning = clean_view(result.view, options.cleaning);
    result.point_count = result.view.valid_count();
    if (result.point_count == 0) throw Error(source, "no pixel could be decoded and triangulated");
    return result;
}

}  // namespace

ReconstructResult reconstruct_view(const CaptureSet& captures, const Calibration& calibration,
                                   const std::string& calibration_name, const ReconstructOptions& options,
                                   const ProgressCallback& progress) {
    validate(options);
    check_camera_size(calibration, captures, calibration_name);
    const CorrespondenceMap map = decode(captures, options.decode, progress);
    ScanView view = triangulate(map, calibration, captures.white_colour, options.triangulate, progress);
    return finish_view(std::move(view), map.order_corrections, calibration, options, progress, "captures");
}

ReconstructResult reconstruct_view(const std::string& captures_folder, const Calibration& calibration,
                                   const std::string& calibration_name, const ReconstructOptions& options,
                                   const ProgressCallback& progress) {
    validate(options);
    // The manifest's projector is checked before any frame is read (a missing folder is
    // reported by load_capture_set).
    const std::string manifest = options.manifest_path.empty() ? captures_folder + "/sequence.json" : options.manifest_path;
    if (std::error_code error; std::filesystem::is_directory(captures_folder, error))
        check_projector_size(calibration, read_manifest(manifest), calibration_name, manifest);
    // The frames' headers are checked against camera_size before any frame is decoded.
    const CaptureSet captures = load_capture_set(captures_folder, options.manifest_path, progress, calibration.camera_size);
    check_camera_size(calibration, captures, calibration_name);
    const CorrespondenceMap map = decode(captures, options.decode, progress);
    ScanView view = triangulate(map, calibration, captures.white_colour, options.triangulate, progress);
    return finish_view(std::move(view), map.order_corrections, calibration, options, progress, captures_folder);
}

CleanScanResult clean_scan(ScanView& view, const std::string& view_name, const CleanScanOptions& options,
                           const ScanView* background) {
    validate(options);
    CleanScanResult result;
    if (background) result.background_removed = remove_background(view, *background, options.background_tolerance_mm);
    result.report = clean_view(view, options.cleaning);
    if (result.report.remaining == 0) throw Error(view_name, "no point survived the cleaning; loosen the options");
    return result;
}

CaptureSet simulate_captures(const Scene& scene, const Calibration& calibration, const SimulateOptions& options,
                             const ProgressCallback& progress) {
    validate(options);
    PatternOptions patterns = options.patterns;
    patterns.projector_size = calibration.projector_size;
    return simulate_capture(make_pattern_sequence(patterns), calibration, scene, options.camera, progress);
}

std::vector<cv::Matx44d> simulate_turntable_scan(const Mesh& part, const Calibration& calibration,
                                                 const TurntableScanOptions& options,
                                                 const std::function<void(const SimulatedView&)>& on_view,
                                                 const ProgressCallback& progress) {
    validate(options.patterns);
    validate(options.camera);
    validate(options.decode);
    if (!(options.part_albedo > 0 && options.part_albedo <= 1)) throw Error("part_albedo", "must be in (0, 1]");
    const std::vector<cv::Matx44d> poses = turntable_part_poses(options.plan);
    PatternOptions patterns = options.patterns;
    patterns.projector_size = calibration.projector_size;
    const PatternSequence sequence = make_pattern_sequence(patterns);
    for (size_t i = 0; i < poses.size(); ++i) {
        // Each view is one share of the whole: progress runs once from 0 to 1.
        const double share = 1.0 / static_cast<double>(poses.size());
        const ProgressCallback view_progress = [&, i](double fraction, const std::string& stage) {
            return !progress || progress((static_cast<double>(i) + fraction) * share, stage);
        };
        SimulatedView simulated;
        simulated.name = "view_" + std::to_string(i);
        simulated.part_to_camera = poses[i];
        Scene scene;
        scene.meshes.push_back({transformed(part, poses[i]), options.part_albedo});
        SimulationOptions camera = options.camera;
        camera.seed = options.camera.seed + i;  // independent camera noise in every view
        simulated.captures = simulate_capture(sequence, calibration, scene, camera, view_progress);
        simulated.view = triangulate(decode(simulated.captures, options.decode, view_progress), calibration,
                                     simulated.captures.white_colour, {}, view_progress);
        simulated.cleaning = clean_view(simulated.view);
        on_view(simulated);
    }
    return poses;
}

std::vector<std::string> foreign_preset_names() {
    return {"opencv-graycode", "slstudio-gray", "slstudio-phase-cue", "slmaster-cgc"};
}

PatternSequence foreign_preset_sequence(const ForeignPresetOptions& options) {
    const cv::Size projector = options.projector_size;
    if (options.preset == "opencv-graycode")
        return make_opencv_graycode_sequence(projector, options.file_prefix, options.file_suffix, options.first_index);
    if (options.preset == "slstudio-gray")
        return make_slstudio_gray_sequence(projector, options.gray_bits > 0 ? options.gray_bits : gray_bits_for(projector.width));
    if (options.preset == "slstudio-phase-cue")
        return make_slstudio_phase_cue_sequence(projector, options.periods > 0 ? options.periods : 16);
    if (options.preset == "slmaster-cgc")
        return make_slmaster_cgc_sequence(projector, options.shifts > 0 ? options.shifts : 12,
                                          options.periods > 0 ? options.periods : 32);
    std::string names;
    for (const std::string& name : foreign_preset_names()) names += (names.empty() ? "" : ", ") + name;
    throw Error("preset", "unknown preset '" + options.preset + "' (" + names + ")");
}

namespace {

// The placements of a stitch: each view's placement (0, 1, ...) checked, one group per placement.
std::vector<std::vector<size_t>> placement_groups(const std::vector<std::string>& names, const std::vector<int>& placement_of_view) {
    std::vector<std::vector<size_t>> groups;
    if (placement_of_view.empty()) {
        groups.emplace_back();
        for (size_t i = 0; i < names.size(); ++i) groups.back().push_back(i);
        return groups;
    }
    if (placement_of_view.size() != names.size())
        throw Error("placement_of_view", std::to_string(placement_of_view.size()) + " placements given for " +
                                             std::to_string(names.size()) + " views");
    for (size_t i = 0; i < names.size(); ++i) {
        const int placement = placement_of_view[i];
        if (placement < 0 || placement > static_cast<int>(groups.size()))
            throw Error("placement_of_view", "view " + names[i] + " has placement " + std::to_string(placement) +
                                                 "; placements are numbered 0, 1, ... in the order of the views");
        if (placement == static_cast<int>(groups.size())) groups.emplace_back();
        groups[static_cast<size_t>(placement)].push_back(i);
    }
    return groups;
}

// How one placement's views are aligned.
enum class PlacementMethod { Features, Round, GivenAxis, InitialPoses };

std::string method_name(PlacementMethod method) {
    switch (method) {
    case PlacementMethod::Features: return "features";
    case PlacementMethod::Round: return "turntable round (axis estimated)";
    case PlacementMethod::GivenAxis: return "turntable axis (given)";
    case PlacementMethod::InitialPoses: return "initial poses";
    }
    return "";
}

// One alignment of all views, each placement by its method (align_views without placements,
// else align_placements).
Alignment align_by(const std::vector<ScanView>& views, const std::vector<std::string>& names,
                   const std::vector<std::vector<size_t>>& groups, const std::vector<PlacementMethod>& methods,
                   const StitchOptions& options, const ProgressCallback& progress) {
    if (options.placement_of_view.empty()) {
        RegistrationOptions registration = options.registration;
        registration.turntable_round = methods[0] == PlacementMethod::Round;
        return align_views(views, names, registration,
                           methods[0] == PlacementMethod::GivenAxis ? options.turntable : std::nullopt, progress);
    }
    std::vector<PlacementPlan> plans(groups.size());
    for (size_t p = 0; p < groups.size(); ++p) {
        plans[p].views = groups[p];
        plans[p].turntable_round = methods[p] == PlacementMethod::Round;
        if (methods[p] == PlacementMethod::GivenAxis) plans[p].turntable = options.turntable;
    }
    return align_placements(views, names, plans, options.registration, progress);
}

// Of a placement's views, those aligned within it, and the first left out with its reason.
StitchAttempt attempt_of(const Alignment& alignment, const std::vector<size_t>& group, size_t placement,
                         PlacementMethod method) {
    StitchAttempt attempt;
    attempt.placement = static_cast<int>(placement);
    attempt.method = method_name(method);
    attempt.views = static_cast<int>(group.size());
    for (size_t v : group) {
        const ViewAlignment& view = alignment.views[v];
        if (view.aligned) ++attempt.aligned_views;
        // A view of a placement that did not join the others was aligned within it all the same.
        else if (attempt.problem.empty() && view.problem.rfind("aligned within ", 0) != 0)
            attempt.problem = view.name + ": " + view.problem;
    }
    if (!alignment.placements.empty()) attempt.aligned_views = alignment.placements[placement].aligned_views;
    return attempt;
}

}  // namespace

StitchResult stitch_views(const std::vector<ScanView>& views, const std::vector<std::string>& names,
                          const StitchOptions& options, const ProgressCallback& progress) {
    validate(options);
    if (views.size() < 2) throw Error("views", "stitching needs at least two views (got " + std::to_string(views.size()) + ")");
    if (names.size() != views.size()) throw Error("views", "one name per view is needed");
    const std::vector<std::vector<size_t>> groups = placement_groups(names, options.placement_of_view);
    const PlacementMethod chosen = options.turntable ? PlacementMethod::GivenAxis
                                   : options.registration.turntable_round ? PlacementMethod::Round
                                   : !options.registration.initial_poses.empty() ? PlacementMethod::InitialPoses
                                                                                   : PlacementMethod::Features;
    std::vector<PlacementMethod> methods(groups.size(), chosen);
    StitchResult result;
    // Automatic: features for every placement, then the turntable round for the placements they
    // left incomplete; progress is split between the two tries.
    const double first_share = options.automatic ? 0.4 : 1.0;
    const ProgressCallback first_progress = [&](double fraction, const std::string& stage) {
        return !progress || progress(first_share * fraction, options.automatic ? "features: " + stage : stage);
    };
    result.alignment = align_by(views, names, groups, methods, options, progress ? first_progress : nullptr);
    for (size_t p = 0; p < groups.size(); ++p) result.attempts.push_back(attempt_of(result.alignment, groups[p], p, methods[p]));
    if (options.automatic) {
        std::vector<StitchAttempt> by_features = result.attempts;
        bool retry = false;
        for (size_t p = 0; p < groups.size(); ++p)
            if (by_features[p].aligned_views < by_features[p].views && groups[p].size() >= 3) {
                methods[p] = PlacementMethod::Round;
                retry = true;
            }
        if (retry) {
            const ProgressCallback round_progress = [&](double fraction, const std::string& stage) {
                return !progress || progress(first_share + (1 - first_share) * fraction, "turntable round: " + stage);
            };
            Alignment by_round = align_by(views, names, groups, methods, options, progress ? round_progress : nullptr);
            // Per placement, the way that aligned more of its views; features when they tie.
            bool mixed = false;
            for (size_t p = 0; p < groups.size(); ++p) {
                if (methods[p] != PlacementMethod::Round) continue;
                result.attempts.push_back(attempt_of(by_round, groups[p], p, PlacementMethod::Round));
                if (result.attempts.back().aligned_views <= by_features[p].aligned_views) {
                    methods[p] = PlacementMethod::Features;
                    mixed = true;
                }
            }
            const bool round_kept = std::any_of(methods.begin(), methods.end(), [](PlacementMethod m) { return m == PlacementMethod::Round; });
            if (round_kept && mixed)  // some placements by features, others by their round: joined once more
                by_round = align_by(views, names, groups, methods, options, progress ? round_progress : nullptr);
            if (round_kept) result.alignment = std::move(by_round);
        }
    }
    for (StitchAttempt& attempt : result.attempts)
        attempt.kept = attempt.method == method_name(methods[static_cast<size_t>(attempt.placement)]);

    std::vector<ScanView> aligned;
    result.method_of_view.assign(views.size(), "");
    for (size_t p = 0; p < groups.size(); ++p)
        for (size_t i : groups[p])
            if (result.alignment.views[i].aligned) result.method_of_view[i] = method_name(methods[p]);
    for (size_t i = 0; i < views.size(); ++i) {
        if (!result.alignment.views[i].aligned) continue;
        aligned.push_back(views[i]);
        aligned.back().pose = result.alignment.views[i].pose;
        result.merged_views.push_back(i);
    }
    result.merged = merge_views(aligned);
    // The first view is the model's frame even when it holds no point: an empty first view
    // "merged" into an empty model, written with the other views left out against it.
    if (result.merged.points.empty())
        throw Error(names[result.merged_views.empty() ? 0 : result.merged_views.front()],
                    "holds no measured point, and no view aligned to it does: nothing to merge");
    if (result.merged_views.size() == views.size() && !options.turntable && views.size() >= 3 &&
        options.placement_of_view.empty()) {
        // Views of a turntable sequence calibrate its axis, for the next scan.
        std::vector<cv::Matx44d> poses;
        for (const ViewAlignment& view : result.alignment.views) poses.push_back(view.pose);
        try {
            result.axis = fit_turntable_axis(poses);
        } catch (const Error&) {
            // Not a turntable sequence: nothing to report.
        }
    }
    return result;
}

Mesh mesh_view(const ScanView& view, const MeshOptions& options, const ProgressCallback& progress) {
    validate(options);
    if (options.method == MeshMethod::Grid) return grid_mesh(view, options.grid);
    return mesh_cloud(to_point_cloud(view), options, progress);
}

Mesh mesh_points(const PointCloud& cloud, const MeshOptions& options, const ProgressCallback& progress) {
    validate(options);
    return mesh_cloud(cloud, options, progress);
}

FuseResult fuse_views(const std::vector<ScanView>& views, const MeshOptions& options, const ProgressCallback& progress) {
    return fuse_views(views.size(), [&](size_t index) { return views[index]; }, options, progress);
}

FuseResult fuse_views(size_t view_count, const ViewSource& view_at, const MeshOptions& options, const ProgressCallback& progress) {
    validate(options);
    if (view_count == 0) throw Error("views", "fusing needs at least one view");
    // Merging takes the first 5 % of the progress, meshing the rest.
    constexpr double kMergeShare = 0.05;
    auto report = [&](double fraction, const std::string& stage) {
        if (progress && !progress(fraction, stage)) throw Error("cancelled", "fusing cancelled");
    };
    FuseResult result;
    result.merged = merge_view_stream(view_count, [&](size_t index) {
        report(kMergeShare * double(index) / double(view_count), "merging the views");
        return view_at(index);
    });
    if (result.merged.points.empty()) throw Error("views", "the views hold no valid point");
    const ProgressCallback meshing = [&](double fraction, const std::string& stage) {
        return !progress || progress(kMergeShare + (1 - kMergeShare) * fraction, stage);
    };
    result.mesh = mesh_cloud(result.merged, options, meshing);
    if (result.mesh.faces.empty()) throw Error("views", "meshing the merged views produced no triangles");
    report(1.0, "checking the mesh");
    result.check = check_mesh(result.mesh);
    return result;
}

FuseResult fuse_view_files(const std::vector<std::string>& paths, const MeshOptions& options,
                           const ProgressCallback& progress) {
    return fuse_views(paths.size(), [&](size_t index) { return read_view_ply(paths[index]); }, options, progress);
}

// ---- Validation --------------------------------------------------------------------------

namespace {

void require(bool ok, const std::string& field, const std::string& rule) {
    if (!ok) throw Error(field, rule);
}

std::string number_text(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", value);
    return text;
}

// NaN fails every comparison, so each check below also rejects NaN.
void in_range(double value, double low, double high, const std::string& field) {
    require(value >= low && value <= high, field, "must be " + number_text(low) + ".." + number_text(high));
}

}  // namespace

void validate(const PatternOptions& options) {
    in_range(options.shifts, 3, 64, "patterns.shifts");
    in_range(options.period_bits, 1, 12, "patterns.period_bits");
}

void validate(const DecodeOptions& options) {
    in_range(options.min_contrast, 0, 255, "decode.min_contrast");
    in_range(options.min_bit_margin, 0, 255, "decode.min_bit_margin");
    in_range(options.saturation_level, 1, 256, "decode.saturation_level");
    in_range(options.min_modulation, 0, 255, "decode.min_modulation");
}

void validate(const SimulationOptions& options) {
    in_range(options.full_scale_dn, 1, 1e4, "camera.full_scale_dn");
    in_range(options.ambient_dn, 0, 1e4, "camera.ambient_dn");
    in_range(options.projector_black, 0, 1, "camera.projector_black");
    in_range(options.projector_gamma, 0.1, 10, "camera.projector_gamma");
    in_range(options.noise_sigma_dn, 0, 100, "camera.noise_sigma_dn");
    in_range(options.blur_sigma_px, 0, 20, "camera.blur_sigma_px");
    require(options.bit_depth == 8 || options.bit_depth == 16, "camera.bit_depth", "must be 8 or 16");
}

void validate(const CleanOptions& options) {
    in_range(options.min_quality, 0, 1e6, "cleaning.min_quality");
    in_range(options.max_grazing_deg, 0, 180, "cleaning.max_grazing_deg");
    in_range(options.window_px, 1, 10, "cleaning.window_px");
    in_range(options.outlier_sigma, 0.5, 1e3, "cleaning.outlier_sigma");
    in_range(options.radius_footprints, 0.1, 1e3, "cleaning.radius_footprints");
    in_range(options.min_neighbours, 0, 1000, "cleaning.min_neighbours");
    in_range(options.min_cluster_points, 0, 1e9, "cleaning.min_cluster_points");
    for (int k = 0; k < 3; ++k)
        require(!options.use_working_volume ||
                    (std::isfinite(options.volume_min[k]) && std::isfinite(options.volume_max[k]) &&
                     options.volume_min[k] < options.volume_max[k]),
                "cleaning.volume", "each minimum must be below its maximum");
}

void validate(const RegistrationOptions& options) {
    in_range(options.sample_spacing_mm, 0.1, 20, "registration.sample_spacing_mm");
    in_range(options.orb_features, 0, 100000, "registration.orb_features");
    in_range(options.ransac_inlier_mm, 0.01, 100, "registration.ransac_inlier_mm");
    in_range(options.ransac_iterations, 1, 1e7, "registration.ransac_iterations");
    in_range(options.icp_iterations, 1, 10000, "registration.icp_iterations");
    in_range(options.icp_trim_fraction, 0.1, 1, "registration.icp_trim_fraction");
    in_range(options.icp_max_distance_mm, 0.01, 1000, "registration.icp_max_distance_mm");
    in_range(options.min_overlap, 0, 1, "registration.min_overlap");
    in_range(options.global_sweeps, 0, 1000, "registration.global_sweeps");
}

void validate(const MeshOptions& options) {
    in_range(options.sample_spacing_mm, 0, 100, "mesh.sample_spacing_mm");
    in_range(options.poisson_triangle_size, 0.1, 100, "mesh.poisson_triangle_size");
    in_range(options.poisson_distance, 0.001, 10, "mesh.poisson_distance");
    in_range(options.advancing_front_max_radius, 0.5, 100, "mesh.advancing_front_max_radius");
    in_range(options.max_hole_diameter_mm, 0, 1e4, "mesh.max_hole_diameter_mm");
    in_range(options.target_faces, 0, 1e9, "mesh.target_faces");
    in_range(options.grid.pixel_step, 1, 64, "mesh.grid.pixel_step");
    in_range(options.grid.max_edge_factor, 0.01, 1e4, "mesh.grid.max_edge_factor");
    in_range(options.max_points, 1000, 1e8, "mesh.max_points");
    in_range(options.max_faces, 1000, 1e9, "mesh.max_faces");
    for (int k = 0; k < 3; ++k)
        if (!std::isfinite(options.table_axis[k])) throw Error("mesh.table_axis", "must be finite");
    if (options.fill == MeshFill::Table && options.method != MeshMethod::Poisson)
        throw Error("mesh.fill", "table closes the Poisson surface: it needs method poisson");
}

void validate(const ReconstructOptions& options) {
    validate(options.decode);
    if (options.clean) validate(options.cleaning);
    in_range(options.triangulate.min_depth_mm, 0, 1e6, "triangulate.min_depth_mm");
    require(options.triangulate.max_depth_mm > options.triangulate.min_depth_mm, "triangulate.max_depth_mm",
            "must exceed min_depth_mm");
    in_range(options.triangulate.distortion_iterations, 0, 100, "triangulate.distortion_iterations");
}

void validate(const CleanScanOptions& options) {
    validate(options.cleaning);
    require(options.background_tolerance_mm > 0 && options.background_tolerance_mm <= 1000, "background_tolerance_mm",
            "must be in (0, 1000] mm");
}

void validate(const SimulateOptions& options) {
    validate(options.patterns);
    validate(options.camera);
}

void validate(const StitchOptions& options) {
    validate(options.registration);
    if (options.turntable) {
        const TurntableAxis& axis = *options.turntable;
        for (int k = 0; k < 3; ++k) {
            require(std::isfinite(axis.point_mm[k]), "turntable.point_mm", "must be finite");
            require(std::isfinite(axis.direction[k]), "turntable.direction", "must be finite");
        }
        require(cv::norm(axis.direction) > 1e-9, "turntable.direction", "must not be zero");
        require(axis.step_deg > 0 && axis.step_deg < 360, "turntable.step_deg", "must be above 0 and below 360 degrees");
        require(!options.registration.turntable_round, "registration.turntable_round",
                "give either a known turntable axis or a turntable round (axis estimated), not both");
    }
    if (options.automatic) {
        require(!options.turntable && !options.registration.turntable_round && options.registration.initial_poses.empty(),
                "automatic", "chooses between features and the turntable round itself: give no turntable axis, "
                             "turntable round or initial poses with it");
    }
}

}  // namespace picoscan
