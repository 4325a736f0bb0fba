// Several placements of one part: each placement aligned on its own (align_views), then the
// placements to each other by shape alone, under the same right-or-refuse gate as a pair of
// views, and finally every view refined together.
#include "cloud/view_check.h"
#include "picoscan/error.h"
#include "picoscan/pipeline.h"
#include "picoscan/register.h"
#include "register/registration_steps.h"
#include "register/visibility.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace picoscan {

namespace {

using detail::format;
using detail::ViewData;

cv::Vec3d apply(const cv::Matx44d& t, const cv::Vec3d& p) {
    return t.get_minor<3, 3>(0, 0) * p + cv::Vec3d(t(0, 3), t(1, 3), t(2, 3));
}

// A placement as one body: its aligned views, their poses in the placement's frame (its
// first view's camera), and their samples merged into one cloud thinned to one per cube.
struct PlacementBody {
    std::vector<size_t> views;         // aligned views (indices into all views)
    std::vector<cv::Matx44d> poses;    // view -> placement frame, one per entry of `views`
    detail::SurfaceSamples cloud;      // placement frame
    bool textured = false;             // every view painted
    double noise_mm = 0;               // median residual of its views against each other
    bool rigid = false;                // a turntable round: its views move as one body
    cv::Vec3d centroid{0, 0, 0};
};

detail::SurfaceSamples merged_cloud(const std::vector<ViewData>& data, const PlacementBody& body, double spacing_mm) {
    detail::SurfaceSamples cloud;
    std::unordered_set<detail::GridCell, detail::GridCellHash> taken;
    for (size_t k = 0; k < body.views.size(); ++k) {
        const detail::SurfaceSamples moved = detail::transformed(data[body.views[k]].samples, body.poses[k]);
        for (size_t i = 0; i < moved.points.size(); ++i) {
            const cv::Vec3d& p = moved.points[i];
            if (!taken.insert(detail::grid_cell(p, spacing_mm)).second) continue;
            cloud.points.push_back(p);
            cloud.normals.push_back(moved.normals[i]);
            if (!moved.grey.empty()) cloud.grey.push_back(moved.grey[i]);
        }
    }
    if (cloud.grey.size() != cloud.points.size()) cloud.grey.clear();
    return cloud;
}

// The largest fraction, over every camera of either placement, of the other placement's
// points lying where that camera saw through. Cameras that see too few of them (no overlap)
// are not asked.
double placement_conflict(const std::vector<ViewData>& data, const PlacementBody& fixed, const PlacementBody& moving,
                          const cv::Matx44d& moving_to_fixed) {
    const double tolerance_mm = 0.5;
    const size_t min_checked = 200;
    double worst = 0;
    auto check = [&](const PlacementBody& seeing, const PlacementBody& seen, const cv::Matx44d& seen_to_seeing) {
        for (size_t k = 0; k < seeing.views.size(); ++k) {
            const cv::Matx44d to_camera = detail::inverse_rigid(seeing.poses[k]) * seen_to_seeing;
            std::vector<cv::Vec3d> points;
            points.reserve(seen.cloud.points.size());
            for (const cv::Vec3d& p : seen.cloud.points) points.push_back(apply(to_camera, p));
            const detail::FreeSpaceCheck result =
                detail::free_space_violations(data[seeing.views[k]].camera, points, tolerance_mm);
            if (result.checked >= min_checked) worst = std::max(worst, result.fraction());
        }
    };
    check(fixed, moving, moving_to_fixed);
    check(moving, fixed, detail::inverse_rigid(moving_to_fixed));
    return worst;
}

// A cloud's centroid and principal axes (the columns of `axes`).
struct PrincipalAxes { cv::Vec3d centroid{0, 0, 0}; cv::Matx33d axes = cv::Matx33d::eye(); };
PrincipalAxes principal_axes(const detail::SurfaceSamples& cloud) {
    PrincipalAxes result;
    for (const cv::Vec3d& p : cloud.points) result.centroid += p;
    result.centroid *= 1.0 / static_cast<double>(std::max<size_t>(1, cloud.points.size()));
    cv::Matx33d covariance = cv::Matx33d::zeros();
    for (const cv::Vec3d& p : cloud.points) covariance += (p - result.centroid) * (p - result.centroid).t();
    cv::Mat eigenvalues, eigenvectors;
    cv::eigen(cv::Mat(covariance), eigenvalues, eigenvectors);
    result.axes = cv::Matx33d(cv::Mat(eigenvectors.t()));
    return result;
}

// The 24 proper rotations of a cube (signed permutations with determinant 1).
std::vector<cv::Matx33d> cube_turns() {
    std::vector<cv::Matx33d> turns;
    const int permutations[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (const auto& order : permutations)
        for (int signs = 0; signs < 8; ++signs) {
            cv::Matx33d turn = cv::Matx33d::zeros();
            for (int r = 0; r < 3; ++r) turn(r, order[r]) = (signs >> r) & 1 ? -1 : 1;
            if (cv::determinant(turn) > 0) turns.push_back(turn);
        }
    return turns;
}

// The 23 quarter and half turns (besides the identity) about the cloud's principal axes
// through its centroid, as transforms of the cloud's frame.
std::vector<cv::Matx44d> symmetric_twins(const detail::SurfaceSamples& cloud) {
    const PrincipalAxes principal = principal_axes(cloud);
    std::vector<cv::Matx44d> twins;
    for (const cv::Matx33d& turn : cube_turns()) {
        if (turn == cv::Matx33d::eye()) continue;
        const cv::Matx33d rotation = principal.axes * turn * principal.axes.t();
        twins.push_back(detail::rigid_transform(rotation, principal.centroid - rotation * principal.centroid));
    }
    return twins;
}

// Starts that put the moving cloud's principal axes on the fixed cloud's, every way round
// (24), centroid on centroid: for when the shape features found nothing that overlaps.
std::vector<cv::Matx44d> principal_axis_starts(const detail::SurfaceSamples& fixed, const detail::SurfaceSamples& moving) {
    const PrincipalAxes to = principal_axes(fixed), from = principal_axes(moving);
    std::vector<cv::Matx44d> starts;
    for (const cv::Matx33d& turn : cube_turns()) {
        const cv::Matx33d rotation = to.axes * turn * from.axes.t();
        starts.push_back(detail::rigid_transform(rotation, to.centroid - rotation * from.centroid));
    }
    return starts;
}

// Registers placement `moving` to `fixed` by shape alone. Every FPFH hypothesis is refined by
// ICP and judged; when fits that pass disagree, the placements are ambiguous and refused.
PlacementAlignment register_placement(const std::vector<ViewData>& data, const PlacementBody& fixed,
                                      const PlacementBody& moving, const RegistrationOptions& options) {
    PlacementAlignment best_refused, chosen;
    if (fixed.cloud.points.size() < 100 || moving.cloud.points.size() < 100) {
        best_refused.problem = "too few points to register (" +
                               std::to_string(std::min(fixed.cloud.points.size(), moving.cloud.points.size())) + " samples)";
        return best_refused;
    }
    const int hypotheses = 30;
    const double spacing = 2.0, radius = 6.0;
    const std::vector<detail::CoarseAlignment> starts =
        detail::match_features(detail::geometric_features(fixed.cloud, spacing, radius),
                               detail::geometric_features(moving.cloud, spacing, radius), options, hypotheses);
    // The residual a right fit leaves: the views' own residual against each other (the scan's
    // noise), with a margin for the larger, thinner overlap; never above the pairwise limit.
    const double noise = std::max(fixed.noise_mm, moving.noise_mm);
    const double max_rms = std::min(std::max(0.25, options.sample_spacing_mm / 2), std::max(0.05, 3 * noise));
    const bool painted = fixed.textured && moving.textured;
    struct Candidate { PlacementAlignment fit; double texture; };
    std::vector<Candidate> accepted;
    auto same = [&](const cv::Matx44d& a, const cv::Matx44d& b, double deg, double mm) {
        const PoseDifference d = pose_difference(a, b, moving.centroid);
        return d.rotation_deg <= deg && d.translation_mm <= mm;
    };
    // Starts: the shape features' hypotheses, then, around the fit that overlaps most, the 23
    // other quarter and half turns about the moving cloud's principal axes: a nearly symmetric
    // part (a block flipped over) fits its near-symmetric twin best by features, and the
    // gate below must see every twin to pick the right one or refuse.
    std::vector<cv::Matx44d> queue;
    for (const detail::CoarseAlignment& start : starts)
        if (start.inliers >= options.min_ransac_inliers) queue.push_back(start.transform);
    const size_t feature_starts = queue.size();
    RegistrationOptions coarse = options;
    coarse.icp_max_distance_mm = std::max(options.icp_max_distance_mm, 10.0);
    coarse.icp_iterations = std::min(options.icp_iterations, 30);
    std::vector<cv::Matx44d> results;  // every ICP result, to skip starts that lead nowhere new
    cv::Matx44d widest = cv::Matx44d::eye();
    double widest_overlap = -1;
    for (size_t next = 0;; ++next) {
        if (next == feature_starts) {
            if (widest_overlap >= options.min_overlap)
                for (const cv::Matx44d& twin : symmetric_twins(moving.cloud)) queue.push_back(widest * twin);
            else
                for (const cv::Matx44d& start : principal_axis_starts(fixed.cloud, moving.cloud)) queue.push_back(start);
        }
        if (next >= queue.size()) break;
        const cv::Matx44d start = queue[next];
        if (std::any_of(results.begin(), results.end(), [&](const cv::Matx44d& r) { return same(r, start, 2.0, 2.0); }))
            continue;
        const detail::IcpResult rough = detail::icp_point_to_plane(fixed.cloud, moving.cloud, start, coarse);
        const detail::IcpResult icp = detail::icp_point_to_plane(fixed.cloud, moving.cloud, rough.transform, options);
        results.push_back(icp.transform);
        if (icp.converged && icp.overlap > widest_overlap) {
            widest_overlap = icp.overlap;
            widest = icp.transform;
        }
        PlacementAlignment fit;
        fit.pose = icp.transform;
        fit.overlap = icp.overlap;
        fit.rms_mm = icp.rms_mm;
        fit.stability = icp.stability;
        if (icp.overlap < options.min_overlap)
            fit.problem = "too little overlap (" + format("%.1f", 100 * icp.overlap) + " % of points have a partner)";
        else if (!icp.converged)
            fit.problem = "ICP did not converge in " + std::to_string(options.icp_iterations) + " iterations";
        else if (icp.rms_mm > max_rms)
            fit.problem = "residual " + format("%.3f", icp.rms_mm) + " mm after ICP, above " + format("%.3f", max_rms) +
                          " mm (three times the views' own residual)";
        else if (icp.stability < detail::kMinStability)
            fit.problem = "the overlap does not fix the pose: the surfaces could slide along each other (stability " +
                          format("%.4f", icp.stability) + ")";
        else if (painted && icp.texture_agreement < 0.4)
            fit.problem = "the shapes fit but their surface textures do not (correlation " +
                          format("%.2f", icp.texture_agreement) + ")";
        if (fit.problem.empty()) {
            fit.free_space_conflict = placement_conflict(data, fixed, moving, icp.transform);
            if (fit.free_space_conflict > detail::kMaxFreeSpaceConflict)
                fit.problem = "the surfaces fit where they overlap, but " + format("%.1f", 100 * fit.free_space_conflict) +
                              " % of one placement's points lie where a camera of the other saw through: a wrong fit";
        }
        if (!fit.problem.empty()) {
            if (best_refused.problem.empty() || fit.overlap > best_refused.overlap) best_refused = fit;
            continue;
        }
        if (std::none_of(accepted.begin(), accepted.end(), [&](const Candidate& a) { return same(a.fit.pose, fit.pose, 1.0, 1.0); }))
            accepted.push_back({fit, icp.texture_agreement});
    }
    if (accepted.empty()) {
        if (best_refused.problem.empty()) best_refused.problem = "no fit of the shapes found";
        return best_refused;
    }
    // Paint, where both placements carry it, tells fits apart; otherwise the tightest first.
    std::sort(accepted.begin(), accepted.end(), [&](const Candidate& a, const Candidate& b) {
        return painted ? a.texture > b.texture : a.fit.rms_mm < b.fit.rms_mm;
    });
    chosen = accepted.front().fit;
    const bool paint_decides = painted && accepted.size() > 1 && accepted[0].texture - accepted[1].texture > 0.3;
    chosen.alternatives = static_cast<int>(accepted.size()) - 1;
    if (accepted.size() > 1 && !paint_decides) {
        const PoseDifference apart = pose_difference(accepted[0].fit.pose, accepted[1].fit.pose, moving.centroid);
        chosen.problem = "ambiguous: the placements fit " + std::to_string(accepted.size()) + " ways " +
                         format("%.1f", apart.rotation_deg) + " degrees apart, equally well (the part looks alike turned over)";
    }
    return chosen;
}

}  // namespace

Alignment align_placements(const std::vector<ScanView>& views, const std::vector<std::string>& names,
                           const std::vector<PlacementPlan>& placements, const RegistrationOptions& options,
                           const ProgressCallback& progress) {
    const size_t n = views.size();
    if (names.size() != n) throw Error("views", "one name per view is needed");
    if (placements.empty()) throw Error("placements", "no placement given");
    if (!options.initial_poses.empty()) throw Error("initial poses", "are not supported with several placements");
    std::vector<int> placement_of(n, -1);
    for (size_t p = 0; p < placements.size(); ++p) {
        if (placements[p].views.empty()) throw Error("placement " + std::to_string(p + 1), "has no views");
        for (size_t v : placements[p].views) {
            if (v >= n) throw Error("placement " + std::to_string(p + 1), "names view " + std::to_string(v) + " of " + std::to_string(n));
            if (placement_of[v] >= 0) throw Error(names[v], "is in more than one placement");
            placement_of[v] = static_cast<int>(p);
        }
    }
    for (size_t v = 0; v < n; ++v)
        if (placement_of[v] < 0) throw Error(names[v], "is in no placement");
    validate(options);
    for (size_t v = 0; v < n; ++v) detail::check_view_reach(views[v], names[v]);
    auto report = [&](double fraction, const std::string& stage) {
        if (progress && !progress(fraction, stage)) throw Error("cancelled", "alignment cancelled");
    };

    // 1. Each placement on its own, in its own frame.
    const size_t count = placements.size();
    Alignment alignment;
    alignment.views.resize(n);
    alignment.placements.resize(count);
    std::vector<cv::Matx44d> poses(n, cv::Matx44d::eye());
    std::vector<PlacementBody> bodies(count);
    for (size_t p = 0; p < count; ++p) {
        const PlacementPlan& plan = placements[p];
        std::vector<ScanView> members;
        std::vector<std::string> member_names;
        for (size_t v : plan.views) {
            members.push_back(views[v]);
            member_names.push_back(names[v]);
        }
        RegistrationOptions own = options;
        own.turntable_round = plan.turntable_round;
        const double share = 0.6 / static_cast<double>(count);
        const ProgressCallback own_progress = [&](double fraction, const std::string& stage) {
            return !progress || progress(share * (static_cast<double>(p) + fraction), "placement " + std::to_string(p + 1) + ": " + stage);
        };
        const Alignment own_alignment = align_views(members, member_names, own, plan.turntable, own_progress);
        PlacementAlignment& placement = alignment.placements[p];
        placement.name = "placement " + std::to_string(p + 1);
        std::vector<double> residuals;
        for (size_t k = 0; k < plan.views.size(); ++k) {
            const size_t v = plan.views[k];
            alignment.views[v] = own_alignment.views[k];
            alignment.views[v].placement = static_cast<int>(p);
            if (!own_alignment.views[k].aligned) continue;
            bodies[p].views.push_back(v);
            bodies[p].poses.push_back(own_alignment.views[k].pose);
            residuals.push_back(own_alignment.views[k].rms_mm);
        }
        placement.aligned_views = static_cast<int>(bodies[p].views.size());
        if (!residuals.empty()) {
            std::nth_element(residuals.begin(), residuals.begin() + static_cast<long>(residuals.size() / 2), residuals.end());
            bodies[p].noise_mm = residuals[residuals.size() / 2];
        }
        placement.noise_mm = bodies[p].noise_mm;
        bodies[p].rigid = own_alignment.turntable_step.has_value();
        if (p == 0) alignment.turntable_step = own_alignment.turntable_step;
        if (p == 0) alignment.turntable_supporting_pairs = own_alignment.turntable_supporting_pairs;
    }
    if (count == 1) {
        alignment.placements[0].aligned = bodies[0].views.size() > 0;
        if (!alignment.placements[0].aligned) alignment.placements[0].problem = "none of its views aligned";
        return alignment;
    }

    // 2. Each placement as one cloud.
    report(0.6, "merging each placement");
    std::vector<ViewData> data(n);
    for (size_t v = 0; v < n; ++v)
        if (alignment.views[v].aligned) data[v] = detail::view_data(views[v], options, false);
    // Coarser than a view's samples: a placement is 8 views' worth, and the final refinement
    // runs on the views themselves.
    const double cloud_spacing = std::max(options.sample_spacing_mm, 1.0);
    for (PlacementBody& body : bodies) {
        body.cloud = merged_cloud(data, body, cloud_spacing);
        body.textured = !body.views.empty() && std::all_of(body.views.begin(), body.views.end(), [&](size_t v) { return data[v].textured; });
        for (const cv::Vec3d& p : body.cloud.points) body.centroid += p;
        if (!body.cloud.points.empty()) body.centroid *= 1.0 / static_cast<double>(body.cloud.points.size());
    }

    // 3. Placements join a tree grown from the first, each to one already joined.
    std::vector<bool> joined(count, false);
    std::vector<cv::Matx44d> placement_pose(count, cv::Matx44d::eye());
    joined[0] = !bodies[0].views.empty();
    if (!joined[0]) alignment.placements[0].problem = "none of its views aligned, so it cannot anchor the model";
    std::vector<PlacementAlignment> best_failure(count);
    std::vector<std::vector<bool>> tried(count, std::vector<bool>(count, false));
    for (bool grew = joined[0]; grew;) {
        grew = false;
        for (size_t q = 0; q < count; ++q) {
            if (joined[q]) continue;
            if (bodies[q].views.empty()) {
                alignment.placements[q].problem = "none of its views aligned";
                continue;
            }
            for (size_t p = 0; p < count && !joined[q]; ++p) {
                if (!joined[p] || tried[p][q]) continue;
                tried[p][q] = true;
                report(0.6 + 0.2 * static_cast<double>(q) / static_cast<double>(count),
                       "registering placement " + std::to_string(q + 1) + " to placement " + std::to_string(p + 1));
                const PlacementAlignment fit = register_placement(data, bodies[p], bodies[q], options);
                if (!fit.problem.empty()) {
                    if (best_failure[q].problem.empty() || fit.overlap > best_failure[q].overlap) {
                        best_failure[q] = fit;
                        best_failure[q].problem = "to placement " + std::to_string(p + 1) + ": " + fit.problem;
                    }
                    continue;
                }
                const PlacementAlignment kept = alignment.placements[q];
                alignment.placements[q] = fit;
                alignment.placements[q].name = kept.name;
                alignment.placements[q].aligned_views = kept.aligned_views;
                alignment.placements[q].noise_mm = kept.noise_mm;
                placement_pose[q] = placement_pose[p] * fit.pose;
                joined[q] = true;
                grew = true;
            }
        }
    }
    for (size_t q = 1; q < count; ++q)
        if (!joined[q] && !bodies[q].views.empty()) {
            const PlacementAlignment kept = alignment.placements[q];
            alignment.placements[q] = best_failure[q];
            alignment.placements[q].name = kept.name;
            alignment.placements[q].aligned_views = kept.aligned_views;
            alignment.placements[q].noise_mm = kept.noise_mm;
            if (alignment.placements[q].problem.empty()) alignment.placements[q].problem = "could not be registered to the others";
        }

    // 4. Every view refined together; a turntable round keeps its shape.
    std::vector<bool> active(n, false);
    std::vector<int> groups(n, 0);
    int next_group = static_cast<int>(count);
    for (size_t p = 0; p < count; ++p)
        for (size_t k = 0; k < bodies[p].views.size(); ++k) {
            const size_t v = bodies[p].views[k];
            active[v] = joined[p];
            poses[v] = placement_pose[p] * bodies[p].poses[k];
            groups[v] = bodies[p].rigid ? static_cast<int>(p) : next_group++;
        }
    const int anchor = joined[0] ? static_cast<int>(bodies[0].views.front()) : -1;
    std::vector<double> rms(n, 0.0);
    if (anchor >= 0) {
        report(0.8, "refining all views together");
        rms = detail::refine_together(data, poses, active, anchor, true, options, nullptr, groups);
        // The whole model checked once more: a placement whose points lie where a camera of
        // another saw through is taken out (the anchor's never), and the rest refined again.
        for (bool removed = true; removed;) {
            removed = false;
            for (size_t q = 1; q < count && !removed; ++q) {
                if (!joined[q]) continue;
                for (size_t p = 0; p < count && !removed; ++p) {
                    if (p == q || !joined[p]) continue;
                    PlacementBody fixed = bodies[p], moving = bodies[q];
                    for (size_t k = 0; k < fixed.views.size(); ++k) fixed.poses[k] = poses[fixed.views[k]];
                    for (size_t k = 0; k < moving.views.size(); ++k) moving.poses[k] = poses[moving.views[k]];
                    moving.cloud = merged_cloud(data, moving, cloud_spacing);
                    fixed.cloud = merged_cloud(data, fixed, cloud_spacing);
                    // Both now in the model frame.
                    const double conflict = placement_conflict(data, fixed, moving, cv::Matx44d::eye());
                    if (conflict <= detail::kMaxFreeSpaceConflict) continue;
                    joined[q] = false;
                    alignment.placements[q].problem = "after refining all views, " + format("%.1f", 100 * conflict) +
                                                      " % of its points lie where a camera of placement " +
                                                      std::to_string(p + 1) + " saw through: a wrong fit, left out";
                    for (size_t v : bodies[q].views) active[v] = false;
                    removed = true;
                }
            }
            if (removed) rms = detail::refine_together(data, poses, active, anchor, true, options, nullptr, groups);
        }
    }
    report(1.0, "aligned");

    for (size_t p = 0; p < count; ++p) {
        PlacementAlignment& placement = alignment.placements[p];
        placement.aligned = joined[p];
        if (joined[p]) {
            placement.problem.clear();
            // Where the refinement put the placement's frame (its first view's camera).
            placement.pose = poses[bodies[p].views.front()] * detail::inverse_rigid(bodies[p].poses.front());
        }
        for (size_t v : placements[p].views) {
            ViewAlignment& view = alignment.views[v];
            if (!view.aligned) continue;
            if (!joined[p]) {
                view.aligned = false;
                view.problem = "aligned within " + placement.name + ", but that placement did not align to the others: " +
                               placement.problem;
                continue;
            }
            view.pose = poses[v];
            view.rms_mm = rms[v];
        }
    }
    return alignment;
}

}  // namespace picoscan
