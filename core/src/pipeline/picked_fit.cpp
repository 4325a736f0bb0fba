// The fit-where-the-user-points recipe: select the region, then fit it.
#include "picoscan/error.h"
#include "picoscan/pipeline.h"

#include <cmath>

namespace picoscan {

namespace {

void check_finite_positive(double value, const char* field) {
    if (!(value > 0 && std::isfinite(value))) throw Error(field, "must be positive");
}

PickedFit fit_selected(const PointCloud& cloud, std::vector<int> region, const PickedFitOptions& options,
                       const ProgressCallback& progress) {
    if (progress && !progress(0.0, "region selected")) throw Error("cancelled", "region fit cancelled");
    PickedFit result;
    result.fit = fit_region(cloud, region, options.fit, progress);
    result.region = std::move(region);
    return result;
}

}  // namespace

void validate(const PickedFitOptions& options) {
    const RegionSelection& selection = options.selection;
    check_finite_positive(selection.radius_mm, "radius_mm");
    check_finite_positive(selection.max_gap_mm, "max_gap_mm");
    check_finite_positive(selection.seed_radius_mm, "seed_radius_mm");
    if (!(selection.max_normal_step_deg > 0 && selection.max_normal_step_deg < 180))
        throw Error("max_normal_step_deg", "must be in (0, 180) degrees");
    for (int i = 0; i < 3; ++i)
        if (!(selection.box_half_size_mm[i] >= 0 && std::isfinite(selection.box_half_size_mm[i])))
            throw Error("box_half_size_mm", "must not be negative");
    const RegionFitOptions& fit = options.fit;
    if (!(fit.noise_mm >= 0 && std::isfinite(fit.noise_mm))) throw Error("noise_mm", "must be 0 (from the fit) or positive");
    check_finite_positive(fit.accept_factor, "accept_factor");
    if (!(fit.margin >= 0 && std::isfinite(fit.margin))) throw Error("margin", "must not be negative");
    if (!(fit.reject_factor >= fit.accept_factor && std::isfinite(fit.reject_factor)))
        throw Error("reject_factor", "must be at least accept_factor");
    if (!(fit.min_cone_half_angle_deg >= 0 && fit.min_cone_half_angle_deg < 90))
        throw Error("min_cone_half_angle_deg", "must be in [0, 90) degrees");
    if (!(fit.snap_step_mm >= 0 && std::isfinite(fit.snap_step_mm))) throw Error("snap_step_mm", "must be 0 (no snapping) or positive");
    if (!(fit.snap_tolerance_mm >= 0 && std::isfinite(fit.snap_tolerance_mm)))
        throw Error("snap_tolerance_mm", "must not be negative");
}

PickedFit fit_at_point(const PointCloud& cloud, const cv::Vec3d& seed, const PickedFitOptions& options,
                       const ProgressCallback& progress) {
    validate(options);
    if (progress && !progress(0.0, "selecting the region")) throw Error("cancelled", "region fit cancelled");
    if (!options.selection.grow) return fit_selected(cloud, select_region(cloud, seed, options.selection, progress), options, progress);
    // The face grown as one kind is fitted as that kind (with the constraint and snapping asked for).
    const GrownFace face = grow_face(cloud, seed, options.selection, options.fit, progress);
    PickedFitOptions as_grown = options;
    as_grown.fit.automatic = false;
    as_grown.fit.kind = face.kind;
    PickedFit result = fit_selected(cloud, face.region, as_grown, progress);
    result.fit.report = face.report + "; " + result.fit.report;
    return result;
}

PickedFit fit_in_lasso(const PointCloud& cloud, const cv::Matx44d& cloud_to_screen, const std::vector<cv::Vec2d>& polygon,
                       const PickedFitOptions& options, const ProgressCallback& progress) {
    validate(options);
    if (progress && !progress(0.0, "selecting the region")) throw Error("cancelled", "region fit cancelled");
    return fit_selected(cloud, select_in_polygon(cloud, cloud_to_screen, polygon), options, progress);
}

}  // namespace picoscan
