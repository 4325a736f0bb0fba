// Registering pairs of views and aligning a whole set: pairwise edges (features or turntable
// guesses, then ICP), a maximum spanning tree over the accepted edges for initial poses, and
// a simultaneous multi-view point-to-plane refinement that spreads the error over all loops.
#include "common/parallel.h"
#include "cloud/view_check.h"
#include "picoscan/error.h"
#include "picoscan/pipeline.h"
#include "picoscan/register.h"
#include "register/registration_steps.h"
#include "register/visibility.h"

#include <opencv2/calib3d.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <numeric>

namespace picoscan {

namespace detail {

std::string format(const char* pattern, double value) {
    char text[64];
    std::snprintf(text, sizeof text, pattern, value);
    return text;
}

namespace {

// Paint shows as spread in the white frame divided by its local mean; a plain part's spread
// is camera noise and shading left at edges. Median absolute deviation, so edges do not count.
bool has_texture(const std::vector<float>& grey) {
    if (grey.size() < 100) return false;
    std::vector<float> values(grey);
    const size_t middle = values.size() / 2;
    std::nth_element(values.begin(), values.begin() + static_cast<long>(middle), values.end());
    const float median = values[middle];
    for (float& v : values) v = std::abs(v - median);
    std::nth_element(values.begin(), values.begin() + static_cast<long>(middle), values.end());
    return 1.4826 * values[middle] > 0.04;
}

}  // namespace

ViewData view_data(const ScanView& view, const RegistrationOptions& options, bool with_features) {
    ViewData data;
    const cv::Rect measured_area = detail::measured_bounds(view);
    data.samples = detail::sample_view(view, measured_area, options.sample_spacing_mm);
    data.textured = has_texture(data.samples.grey);
    // ORB on the white frame only where there is paint: on a plain part it finds shading, and
    // its starts led to no decision that the shape's starts did not (the suite's 194 decisions,
    // docs/benchmarks.md) while ORB and their ICP runs took much of a pair's time.
    // texture_starts needs both views' features, so a pair with a plain view starts from the shape.
    if (with_features && data.textured) data.features = detail::view_features(view, measured_area, options.orb_features);
    data.camera = detail::view_camera(view, measured_area);
    for (const cv::Vec3d& p : data.samples.points) data.centroid += p;
    if (!data.samples.points.empty()) data.centroid *= 1.0 / static_cast<double>(data.samples.points.size());
    return data;
}

cv::Vec3d apply(const cv::Matx44d& t, const cv::Vec3d& p) {
    return t.get_minor<3, 3>(0, 0) * p + cv::Vec3d(t(0, 3), t(1, 3), t(2, 3));
}

std::vector<cv::Vec3d> moved(const std::vector<cv::Vec3d>& points, const cv::Matx44d& transform) {
    std::vector<cv::Vec3d> out;
    out.reserve(points.size());
    for (const cv::Vec3d& p : points) out.push_back(apply(transform, p));
    return out;
}

// The larger fraction, of either view's points, lying where the other view's camera saw
// through (in front of what it measured): a contradiction however well the overlap fits.
double free_space_conflict(const ViewData& fixed, const ViewData& moving, const cv::Matx44d& moving_to_fixed) {
    const double tolerance_mm = 0.5;
    const detail::FreeSpaceCheck into_fixed =
        detail::free_space_violations(fixed.camera, moved(moving.samples.points, moving_to_fixed), tolerance_mm);
    const detail::FreeSpaceCheck into_moving =
        detail::free_space_violations(moving.camera, moved(fixed.samples.points, detail::inverse_rigid(moving_to_fixed)), tolerance_mm);
    return std::max(into_fixed.fraction(), into_moving.fraction());
}

}  // namespace detail

namespace {

using detail::format;
using detail::free_space_conflict;
using detail::kMaxFreeSpaceConflict;
using detail::kMinStability;
using detail::view_data;
using detail::ViewData;

// A pair is accepted when ICP converged onto enough shared surface, tightly, without either
// view's points in the other's free space, and (only where both views are painted) with the
// paint lining up. Texture is never asked of a plain part.
void judge(PairRegistration& pair, const RegistrationOptions& options, const ViewData& fixed, const ViewData& moving,
           bool guided) {
    const double max_rms = std::max(0.25, options.sample_spacing_mm / 2);
    const double min_texture_agreement = 0.4;
    if (pair.overlap < options.min_overlap)
        pair.problem = "too little overlap (" + format("%.1f", 100 * pair.overlap) + " % of points have a partner, need " +
                       format("%.1f", 100 * options.min_overlap) + " %)";
    else if (!pair.converged && !guided)  // a guided pose is judged by how far ICP took it (align_views)
        pair.problem = "ICP did not converge in " + std::to_string(options.icp_iterations) + " iterations";
    else if (pair.rms_mm > max_rms)
        pair.problem = "residual too large after ICP (" + format("%.3f", pair.rms_mm) + " mm)";
    else if (!guided && pair.stability < kMinStability)
        pair.problem = "the overlap does not fix the pose: the surfaces could slide along each other (stability " +
                       format("%.4f", pair.stability) + ")";
    else if (fixed.textured && moving.textured && pair.texture_agreement < min_texture_agreement)
        pair.problem = "the shapes fit but their surface textures do not (correlation " +
                       format("%.2f", pair.texture_agreement) + "): a symmetric part matched the wrong way round";
    if (!pair.problem.empty()) return;
    pair.free_space_conflict = free_space_conflict(fixed, moving, pair.transform);
    if (pair.free_space_conflict > kMaxFreeSpaceConflict)
        pair.problem = "the surfaces fit where they overlap, but " + format("%.1f", 100 * pair.free_space_conflict) +
                       " % of one view's points lie where the other's camera saw through: a wrong fit";
}

// How far apart two moving -> fixed transforms put the moving view (its centroid).
PoseDifference disagreement(const cv::Matx44d& a, const cv::Matx44d& b, const ViewData& moving) {
    return pose_difference(a, b, moving.centroid);
}

bool same_pose(const cv::Matx44d& a, const cv::Matx44d& b, const ViewData& moving, double max_deg, double max_mm) {
    const PoseDifference d = disagreement(a, b, moving);
    return d.rotation_deg <= max_deg && d.translation_mm <= max_mm;
}

// ICP from `start`, judged. With earlier fits of this pair given, a run that reaches one of
// them stops there: `joined` is then its index, and the candidate is that fit's.
PairRegistration icp_candidate(const ViewData& fixed, const ViewData& moving, const detail::CoarseAlignment& start,
                               const RegistrationOptions& options, bool guided, const detail::EarlierFits& earlier = {},
                               int* joined = nullptr) {
    const detail::IcpResult icp = detail::icp_point_to_plane(fixed.samples, moving.samples, start.transform, options, earlier, !guided);
    if (joined) *joined = icp.joined;
    PairRegistration candidate;
    candidate.transform = icp.transform;
    candidate.overlap = icp.overlap;
    candidate.rms_mm = icp.rms_mm;
    candidate.converged = icp.converged;
    candidate.texture_agreement = icp.texture_agreement;
    candidate.feature_matches = start.matches;
    candidate.ransac_inliers = start.inliers;
    candidate.stability = icp.stability;
    if (icp.joined >= 0) return candidate;  // that fit was judged when first reached
    judge(candidate, options, fixed, moving, guided);
    return candidate;
}

// Coarse starting poses from features: ORB on the white frames where both are painted, then
// shape histograms (FPFH). Several of each, because a nearly symmetric part offers several
// good-looking fits.
constexpr int kFeatureHypotheses = 15;

std::vector<detail::CoarseAlignment> texture_starts(const ViewData& fixed, const ViewData& moving, const RegistrationOptions& options) {
    if (fixed.features.points.empty() || moving.features.points.empty()) return {};
    return detail::match_features(fixed.features, moving.features, options, kFeatureHypotheses);
}

std::vector<detail::CoarseAlignment> shape_starts(const ViewData& fixed, const ViewData& moving, const RegistrationOptions& options) {
    const double spacing = 2.0, radius = 6.0;
    return detail::match_features(detail::geometric_features(fixed.samples, spacing, radius),
                                  detail::geometric_features(moving.samples, spacing, radius), options, kFeatureHypotheses);
}

std::vector<detail::CoarseAlignment> feature_starts(const ViewData& fixed, const ViewData& moving, const RegistrationOptions& options) {
    std::vector<detail::CoarseAlignment> starts = texture_starts(fixed, moving, options);
    const std::vector<detail::CoarseAlignment> shape = shape_starts(fixed, moving, options);
    starts.insert(starts.end(), shape.begin(), shape.end());
    return starts;
}

// Registers a pair from a guess, or else from features. Every start is refined and judged;
// when fits that pass disagree, the pair is ambiguous and refused (unless the paint of a
// painted part tells them apart).
PairRegistration register_samples(const ViewData& fixed, const ViewData& moving, const RegistrationOptions& options,
                                  const std::optional<cv::Matx44d>& initial_guess) {
    PairRegistration pair;
    if (fixed.samples.points.size() < 100 || moving.samples.points.size() < 100) {
        pair.problem = "too few points to register (" +
                       std::to_string(std::min(fixed.samples.points.size(), moving.samples.points.size())) + " samples)";
        return pair;
    }
    std::vector<PairRegistration> accepted;
    PairRegistration best_refused;
    bool tried = false;
    const bool painted = fixed.textured && moving.textured;
    // Every fit ICP converged to, accepted or not: a later start that reaches one ends there
    // and is judged as it was (plain parts give a dozen starts, most leading to the same fit).
    detail::EarlierFits earlier{{}, moving.centroid};
    // Refines and judges each start; true once paint that lines up well settles the pair.
    auto settled_by = [&](const std::vector<detail::CoarseAlignment>& starts) {
        for (const detail::CoarseAlignment& start : starts) {
            if (start.inliers < options.min_ransac_inliers) continue;
            // A start that lands where an accepted fit already is adds nothing.
            const bool known = std::any_of(accepted.begin(), accepted.end(), [&](const PairRegistration& a) {
                return same_pose(a.transform, start.transform, moving, 2.0, 2.0);
            });
            if (known) continue;
            int joined = -1;
            const PairRegistration candidate =
                icp_candidate(fixed, moving, start, options, initial_guess.has_value(), earlier, &joined);
            tried = true;
            if (joined >= 0) continue;  // judged already, when that fit was first reached
            if (candidate.converged) earlier.transforms.push_back(candidate.transform);
            if (!candidate.problem.empty()) {
                if (best_refused.problem.empty() || candidate.overlap > best_refused.overlap) best_refused = candidate;
                continue;
            }
            if (std::none_of(accepted.begin(), accepted.end(), [&](const PairRegistration& a) {
                    return same_pose(a.transform, candidate.transform, moving, 0.5, 0.5);
                }))
                accepted.push_back(candidate);
            if (painted && candidate.texture_agreement > 0.6) return true;
        }
        return false;
    };
    if (initial_guess)
        settled_by({{*initial_guess, 0, options.min_ransac_inliers}});
    else if (!settled_by(texture_starts(fixed, moving, options)))  // shape histograms only when the paint did not settle it
        settled_by(shape_starts(fixed, moving, options));
    if (accepted.empty()) {
        if (!tried) {
            best_refused = pair;
            best_refused.problem = "no reliable feature alignment (fewer than " + std::to_string(options.min_ransac_inliers) +
                                   " RANSAC inliers, on the white frames or the shape)";
        }
        return best_refused;
    }
    std::sort(accepted.begin(), accepted.end(), [&](const PairRegistration& a, const PairRegistration& b) {
        return painted ? a.texture_agreement > b.texture_agreement : a.rms_mm < b.rms_mm;
    });
    PairRegistration chosen = accepted.front();
    chosen.alternatives = static_cast<int>(accepted.size()) - 1;
    if (accepted.size() > 1 && !(painted && chosen.texture_agreement - accepted[1].texture_agreement > 0.3)) {
        const PoseDifference apart = disagreement(accepted[0].transform, accepted[1].transform, moving);
        chosen.problem = "ambiguous: the views fit " + std::to_string(accepted.size()) + " ways " +
                         format("%.1f", apart.rotation_deg) + " degrees apart, equally well (a nearly symmetric part)";
    }
    return chosen;
}

double rotation_angle_deg(const cv::Matx44d& transform) {
    const double cosine = std::clamp((cv::trace(transform.get_minor<3, 3>(0, 0)) - 1.0) / 2.0, -1.0, 1.0);
    return std::acos(cosine) * 180.0 / CV_PI;
}

struct TurntableStep {
    std::optional<cv::Matx44d> step;  // view k+1 -> view k, the same for every k
    int supporting_pairs = 0;
    std::string problem;
};

// One full round of a turntable in n equal steps, axis unknown: the camera stays, the part
// turns, so one motion S takes every view k+1 into view k, S turns by 360/n degrees, and S^n
// is the identity (the loop closes). Hypotheses for S come from the features of every
// neighbouring pair; each is refined by ICP on every pair, and the one most pairs agree on
// wins. When two different motions are each supported as well, the part is too symmetric to
// tell and the round is refused.
TurntableStep estimate_turntable_step(const std::vector<ViewData>& data, const RegistrationOptions& options) {
    const size_t n = data.size();
    const double expected_deg = 360.0 / static_cast<double>(n);
    const double max_coarse_deg = 15.0, max_step_deg = 3.0;
    const size_t max_starts = 24;
    TurntableStep result;
    std::vector<detail::SamplePair> ring;
    for (size_t k = 0; k < n; ++k)
        if (data[k].samples.points.size() >= 100 && data[(k + 1) % n].samples.points.size() >= 100)
            ring.push_back({&data[k].samples, &data[(k + 1) % n].samples});
    // Coarse starts from every neighbouring pair's features that turn about the right angle,
    // the most inliers first; each refined on all pairs at once (the step is shared).
    std::vector<detail::CoarseAlignment> starts;
    for (size_t k = 0; k < n; ++k) {
        const ViewData& fixed = data[k];
        const ViewData& moving = data[(k + 1) % n];
        if (fixed.samples.points.size() < 100 || moving.samples.points.size() < 100) continue;
        for (const detail::CoarseAlignment& start : feature_starts(fixed, moving, options))
            if (start.inliers >= options.min_ransac_inliers &&
                std::abs(rotation_angle_deg(start.transform) - expected_deg) <= max_coarse_deg)
                starts.push_back(start);
    }
    std::stable_sort(starts.begin(), starts.end(),
                     [](const detail::CoarseAlignment& a, const detail::CoarseAlignment& b) { return a.inliers > b.inliers; });
    if (starts.size() > max_starts) starts.resize(max_starts);
    std::vector<cv::Matx44d> hypotheses;
    for (const detail::CoarseAlignment& start : starts) {
        if (std::any_of(hypotheses.begin(), hypotheses.end(),
                        [&](const cv::Matx44d& h) { return same_pose(h, start.transform, data[1], 2.0, 2.0); }))
            continue;
        const detail::IcpResult shared = detail::icp_point_to_plane(ring, start.transform, options);
        if (!shared.converged || std::abs(rotation_angle_deg(shared.transform) - expected_deg) > max_step_deg) continue;
        if (std::none_of(hypotheses.begin(), hypotheses.end(),
                         [&](const cv::Matx44d& h) { return same_pose(h, shared.transform, data[1], 0.5, 0.5); }))
            hypotheses.push_back(shared.transform);
    }
    if (hypotheses.empty()) {
        result.problem = "no fit of the neighbouring pairs turns by " + format("%.1f", expected_deg) + " degrees";
        return result;
    }
    struct Support { cv::Matx44d step; int pairs = 0; };
    std::vector<Support> supports;
    for (const cv::Matx44d& hypothesis : hypotheses) {
        Support support{hypothesis, 0};
        for (size_t k = 0; k < n; ++k) {
            const ViewData& moving = data[(k + 1) % n];
            const PairRegistration fit =
                icp_candidate(data[k], moving, {hypothesis, 0, options.min_ransac_inliers}, options, true);
            if (!fit.problem.empty() || !same_pose(fit.transform, hypothesis, moving, 0.5, 0.5)) continue;
            ++support.pairs;
        }
        supports.push_back(support);
    }
    std::sort(supports.begin(), supports.end(), [](const Support& a, const Support& b) { return a.pairs > b.pairs; });
    const Support& best = supports.front();
    result.supporting_pairs = best.pairs;
    const int needed = std::max(2, static_cast<int>((n + 1) / 2));
    if (best.pairs < needed) {
        result.problem = "only " + std::to_string(best.pairs) + " of " + std::to_string(n) +
                         " neighbouring pairs agree on one step (need " + std::to_string(needed) + ")";
        return result;
    }
    for (size_t r = 1; r < supports.size(); ++r) {
        if (same_pose(supports[r].step, best.step, data[1], 0.5, 0.5)) continue;
        if (supports[r].pairs >= best.pairs - 1) {
            result.problem = "two different steps fit (" + std::to_string(best.pairs) + " and " + std::to_string(supports[r].pairs) +
                             " of " + std::to_string(n) + " pairs): the part looks too alike from different sides";
            return result;
        }
        break;
    }
    const cv::Matx44d step = best.step;
    // Cycle: n steps must bring view 0 back onto itself.
    cv::Matx44d loop = cv::Matx44d::eye();
    for (size_t k = 0; k < n; ++k) loop = loop * step;
    const PoseDifference closure = pose_difference(cv::Matx44d::eye(), loop, data[0].centroid);
    if (closure.rotation_deg > 3.0 || closure.translation_mm > 3.0) {
        result.problem = "the step does not close the round (" + format("%.2f", closure.rotation_deg) + " degrees, " +
                         format("%.2f", closure.translation_mm) + " mm after " + std::to_string(n) + " steps)";
        return result;
    }
    result.step = step;
    return result;
}

}  // namespace

namespace detail {

std::vector<double> refine_together(const std::vector<ViewData>& data, std::vector<cv::Matx44d>& poses,
                                    const std::vector<bool>& active, int anchor, bool move_views,
                                    const RegistrationOptions& options, const ProgressCallback& progress,
                                    const std::vector<int>& groups) {
    const size_t n = data.size();
    // Column block of each view's motion: one per group (views of a group move as one), the
    // anchor's group fixed.
    std::vector<int> unknown(n, -1);
    auto group_of = [&](size_t i) { return groups.empty() ? static_cast<int>(i) : groups[i]; };
    std::map<int, int> block_of_group;
    int blocks = 0;
    for (size_t i = 0; i < n; ++i) {
        if (!active[i] || group_of(i) == group_of(static_cast<size_t>(anchor))) continue;
        const auto [found, fresh] = block_of_group.emplace(group_of(i), blocks);
        if (fresh) ++blocks;
        unknown[i] = found->second;
    }
    std::vector<double> rms(n, 0.0);
    const double min_normal_cos = std::cos(CV_PI / 4);
    double limit = std::max(3 * options.sample_spacing_mm, 1.0);
    // Each view's samples' partners in every other view at the last sweep: the search for the
    // nearest point reaches no farther than that partner does now.
    std::vector<std::vector<int>> partners(n * n);
    for (int sweep = 0; sweep < options.global_sweeps; ++sweep) {
        if (progress && !progress(0.6 + 0.4 * sweep / options.global_sweeps, "refining all views together"))
            throw Error("cancelled", "alignment cancelled");
        std::vector<detail::SurfaceSamples> model(n);
        std::vector<std::unique_ptr<detail::NearestGrid>> grids(n);
        cv::Vec3d centre(0, 0, 0);
        size_t count = 0;
        for (size_t i = 0; i < n; ++i) {
            if (!active[i]) continue;
            model[i] = detail::transformed(data[i].samples, poses[i]);
            grids[i] = std::make_unique<detail::NearestGrid>(model[i].points, limit);
            for (const cv::Vec3d& p : model[i].points) centre += p;
            count += model[i].points.size();
        }
        // Motions are taken about the model's centre, rotations scaled by its spread, so that
        // the six directions of each view are comparable.
        if (count) centre *= 1.0 / static_cast<double>(count);
        double spread = 0;
        for (size_t i = 0; i < n; ++i)
            for (const cv::Vec3d& p : model[i].points) spread += cv::norm(p - centre, cv::NORM_L2SQR);
        const double scale = count ? std::max(std::sqrt(spread / static_cast<double>(count)), 1.0) : 1.0;
        cv::Mat normal_matrix = cv::Mat::zeros(6 * blocks, 6 * blocks, CV_64F);
        cv::Mat right_side = cv::Mat::zeros(6 * blocks, 1, CV_64F);
        std::vector<double> squared(n, 0.0);
        std::vector<size_t> counted(n, 0);
        std::vector<double> all_distances;
        for (size_t i = 0; i < n; ++i) {
            if (!active[i]) continue;
            for (size_t j = 0; j < n; ++j) {
                if (i == j || !active[j]) continue;
                struct Term { double residual, distance; cv::Vec6d from_i, from_j; };
                std::vector<Term> terms;
                std::vector<int>& partner = partners[i * n + j];
                partner.resize(model[i].points.size(), -1);
                for (size_t k = 0; k < model[i].points.size(); ++k) {
                    const cv::Vec3d& p = model[i].points[k];
                    // The nearest point is no farther than the last partner (a hair beyond it, far
                    // above rounding, so that it still counts as within reach).
                    const double reach = partner[k] < 0 ? limit
                                                        : std::min(limit, cv::norm(p - model[j].points[static_cast<size_t>(partner[k])]) + 1e-9);
                    const int m = grids[j]->nearest(p, reach);
                    partner[k] = m;
                    if (m < 0) continue;
                    const cv::Vec3d& q = model[j].points[static_cast<size_t>(m)];
                    const cv::Vec3d& normal = model[j].normals[static_cast<size_t>(m)];
                    if (model[i].normals[k].dot(normal) < min_normal_cos) continue;
                    const cv::Vec3d pc = (p - centre).cross(normal) * (1.0 / scale),
                                    qc = (q - centre).cross(normal) * (1.0 / scale);
                    terms.push_back({(p - q).dot(normal), cv::norm(p - q),
                                     cv::Vec6d(pc[0], pc[1], pc[2], normal[0], normal[1], normal[2]),
                                     cv::Vec6d(-qc[0], -qc[1], -qc[2], -normal[0], -normal[1], -normal[2])});
                }
                if (terms.size() < 50) continue;
                const size_t kept = static_cast<size_t>(options.icp_trim_fraction * terms.size());
                std::nth_element(terms.begin(), terms.begin() + static_cast<long>(kept), terms.end(),
                                 [](const Term& a, const Term& b) { return a.distance < b.distance; });
                double* matrix = normal_matrix.ptr<double>();
                double* right = right_side.ptr<double>();
                const int columns = normal_matrix.cols;
                for (size_t k = 0; k < kept; ++k) {
                    const Term& term = terms[k];
                    squared[i] += term.residual * term.residual;
                    ++counted[i];
                    all_distances.push_back(term.distance);
                    const int bi = unknown[i], bj = unknown[j];
                    for (int a = 0; a < 2; ++a) {
                        const int block_a = a == 0 ? bi : bj;
                        if (block_a < 0) continue;
                        const cv::Vec6d& ra = a == 0 ? term.from_i : term.from_j;
                        for (int b = 0; b < 2; ++b) {
                            const int block_b = b == 0 ? bi : bj;
                            if (block_b < 0) continue;
                            const cv::Vec6d& rb = b == 0 ? term.from_i : term.from_j;
                            for (int r = 0; r < 6; ++r) {
                                double* row = matrix + (6 * block_a + r) * columns + 6 * block_b;
                                for (int c = 0; c < 6; ++c) row[c] += ra[r] * rb[c];
                            }
                        }
                        for (int r = 0; r < 6; ++r) right[6 * block_a + r] -= ra[r] * term.residual;
                    }
                }
            }
        }
        for (size_t i = 0; i < n; ++i) rms[i] = counted[i] ? std::sqrt(squared[i] / static_cast<double>(counted[i])) : 0.0;
        if (blocks == 0 || !move_views) break;
        // Views do not move along directions the surfaces leave unfixed (a plane or a cylinder
        // sliding along itself): those keep the poses they came with.
        cv::Mat eigenvalues, eigenvectors;
        if (!cv::eigen(normal_matrix, eigenvalues, eigenvectors)) break;
        cv::Mat step = cv::Mat::zeros(6 * blocks, 1, CV_64F);
        const double strongest = eigenvalues.at<double>(0);
        for (int e = 0; e < eigenvalues.rows; ++e) {
            const double value = eigenvalues.at<double>(e);
            if (value < 1e-3 * strongest) break;  // sorted, largest first
            const cv::Mat direction = eigenvectors.row(e).t();
            step += direction * (direction.dot(right_side) / value);
        }
        double largest = 0;
        for (size_t i = 0; i < n; ++i) {
            if (unknown[i] < 0) continue;
            const int b = 6 * unknown[i];
            const cv::Vec3d omega = cv::Vec3d(step.at<double>(b), step.at<double>(b + 1), step.at<double>(b + 2)) * (1.0 / scale);
            const cv::Vec3d delta(step.at<double>(b + 3), step.at<double>(b + 4), step.at<double>(b + 5));
            // x -> R (x - centre) + centre + delta
            const cv::Matx33d turn = detail::motion_matrix(omega, {0, 0, 0}).get_minor<3, 3>(0, 0);
            poses[i] = detail::rigid_transform(turn, centre - turn * centre + delta) * poses[i];
            largest = std::max({largest, cv::norm(omega) * 100, cv::norm(delta)});
        }
        if (!all_distances.empty()) {
            std::nth_element(all_distances.begin(), all_distances.begin() + static_cast<long>(all_distances.size() / 2),
                             all_distances.end());
            limit = std::clamp(6.0 * all_distances[all_distances.size() / 2], options.sample_spacing_mm, limit);
        }
        if (largest < 1e-5 && sweep > 0) break;
    }
    return rms;
}

}  // namespace detail

int Alignment::aligned_count() const {
    return static_cast<int>(std::count_if(views.begin(), views.end(), [](const ViewAlignment& v) { return v.aligned; }));
}

PairRegistration register_pair(const ScanView& fixed, const ScanView& moving, const RegistrationOptions& options,
                               const std::optional<cv::Matx44d>& initial_guess) {
    validate(options);
    if (initial_guess && !cv::checkRange(*initial_guess)) throw Error("initial guess", "is not finite");
    detail::check_view_reach(fixed, "fixed view");
    detail::check_view_reach(moving, "moving view");
    ViewData data[2];
    const ScanView* views[2] = {&fixed, &moving};
    detail::parallel_rows(2, [&](int begin, int end) {
        for (int i = begin; i < end; ++i) data[i] = view_data(*views[i], options, !initial_guess);
    });
    return register_samples(data[0], data[1], options, initial_guess);
}

cv::Matx44d turntable_pose(const TurntableAxis& axis, int step) {
    const cv::Vec3d direction = cv::normalize(axis.direction);
    const cv::Matx44d rotation = detail::motion_matrix(direction * (axis.step_deg * step * CV_PI / 180.0), {0, 0, 0});
    // Rotation about a line through point_mm: x -> R (x - c) + c. The part turned by +step
    // is seen in view `step`; its coordinates go back to view 0 by turning it back.
    cv::Matx44d about_axis = rotation;
    const cv::Vec3d c = axis.point_mm;
    const cv::Vec3d shift = c - rotation.get_minor<3, 3>(0, 0) * c;
    for (int r = 0; r < 3; ++r) about_axis(r, 3) = shift[r];
    return detail::inverse_rigid(about_axis);
}

TurntableAxis fit_turntable_axis(const std::vector<cv::Matx44d>& poses, double max_axis_spread_deg) {
    if (poses.size() < 3) throw Error("turntable", "needs at least 3 views to calibrate the axis");
    // Each pose turns view k back by k steps: its rotation vector lies along the axis.
    std::vector<cv::Vec3d> axes;
    std::vector<double> steps;
    for (size_t k = 1; k < poses.size(); ++k) {
        cv::Vec3d rotation_vector;
        cv::Rodrigues(cv::Matx33d(poses[k].get_minor<3, 3>(0, 0)), rotation_vector);
        const double angle = cv::norm(rotation_vector);
        if (angle < 1e-3) throw Error("turntable", "view " + std::to_string(k) + " is not turned against view 0");
        cv::Vec3d axis = rotation_vector / angle;
        if (!axes.empty() && axis.dot(axes.front()) < 0) axis = -axis;
        axes.push_back(axis);
        steps.push_back(angle * 180.0 / CV_PI);
    }
    cv::Vec3d direction(0, 0, 0);
    for (const cv::Vec3d& axis : axes) direction += axis;
    direction = cv::normalize(direction);
    for (size_t k = 0; k < axes.size(); ++k) {
        const double spread = std::acos(std::clamp(axes[k].dot(direction), -1.0, 1.0)) * 180.0 / CV_PI;
        if (spread > max_axis_spread_deg)
            throw Error("turntable", "view " + std::to_string(k + 1) + " turns about an axis " + format("%.2f", spread) +
                                         " degrees off the others: not one turntable sequence");
    }
    // A point c on the axis: every pose maps it to itself, (I - R_k) c = t_k; plus direction . c = 0.
    cv::Mat a(static_cast<int>(3 * (poses.size() - 1) + 1), 3, CV_64F), b(a.rows, 1, CV_64F);
    for (size_t k = 1; k < poses.size(); ++k) {
        const cv::Matx33d m = cv::Matx33d::eye() - poses[k].get_minor<3, 3>(0, 0);
        for (int r = 0; r < 3; ++r) {
            const int row = static_cast<int>(3 * (k - 1)) + r;
            for (int c = 0; c < 3; ++c) a.at<double>(row, c) = m(r, c);
            b.at<double>(row) = poses[k](r, 3);
        }
    }
    for (int c = 0; c < 3; ++c) a.at<double>(a.rows - 1, c) = direction[c];
    b.at<double>(a.rows - 1) = 0;
    cv::Mat point;
    cv::solve(a, b, point, cv::DECOMP_SVD);
    // Step: the first view's angle, unwrapped (views may go past 180 degrees).
    double step = steps.front();
    // Poses turn views back, so the part turns the opposite way about `direction`.
    return TurntableAxis{cv::Vec3d(point.at<double>(0), point.at<double>(1), point.at<double>(2)), -direction, step};
}

PoseDifference pose_difference(const cv::Matx44d& a, const cv::Matx44d& b, const cv::Vec3d& at) {
    const cv::Matx44d relative = detail::inverse_rigid(a) * b;
    const cv::Matx33d rotation = relative.get_minor<3, 3>(0, 0);
    const double cosine = std::clamp((cv::trace(rotation) - 1.0) / 2.0, -1.0, 1.0);
    const cv::Vec3d moved = rotation * at + cv::Vec3d(relative(0, 3), relative(1, 3), relative(2, 3));
    return {std::acos(cosine) * 180.0 / CV_PI, cv::norm(moved - at)};
}

Alignment align_views(const std::vector<ScanView>& views, const std::vector<std::string>& names,
                      const RegistrationOptions& options, const std::optional<TurntableAxis>& turntable,
                      const ProgressCallback& progress) {
    if (views.empty()) throw Error("views", "nothing to align");
    if (names.size() != views.size()) throw Error("views", "one name per view is needed");
    if (!options.initial_poses.empty() && options.initial_poses.size() != views.size())
        throw Error("initial poses", std::to_string(options.initial_poses.size()) + " given for " + std::to_string(views.size()) + " views");
    validate(options);
    for (size_t i = 0; i < views.size(); ++i) detail::check_view_reach(views[i], names[i]);
    for (size_t i = 0; i < options.initial_poses.size(); ++i)
        if (!cv::checkRange(options.initial_poses[i]))
            throw Error("initial poses", "the pose of " + names[i] + " is not finite");
    if (turntable && !(cv::checkRange(turntable->point_mm) && cv::checkRange(turntable->direction) &&
                       std::isfinite(turntable->step_deg) && cv::norm(turntable->direction) > 0))
        throw Error("turntable", "the axis needs a finite point, a non-zero direction and a finite step");
    const bool guessed = turntable || !options.initial_poses.empty();
    const size_t n = views.size();
    Alignment alignment;
    alignment.views.resize(n);
    for (size_t i = 0; i < n; ++i) alignment.views[i].name = names[i];

    auto report = [&](double fraction, const std::string& stage) {
        if (progress && !progress(fraction, stage)) throw Error("cancelled", "alignment cancelled");
    };
    std::vector<ViewData> data(n);
    report(0.0, "sampling and finding features");
    // The views are independent: prepared side by side on all cores.
    detail::parallel_rows(static_cast<int>(n), [&](int begin, int end) {
        for (int i = begin; i < end; ++i) data[static_cast<size_t>(i)] = view_data(views[static_cast<size_t>(i)], options, !guessed);
    });

    // The motion that guesses each pair, and how far ICP may move away from it.
    std::function<cv::Matx44d(size_t, size_t)> guess_of;
    double max_departure_deg = 0, max_departure_mm = 0;
    std::string motion_name;
    std::string round_problem;
    if (!options.initial_poses.empty()) {
        guess_of = [&](size_t i, size_t j) { return detail::inverse_rigid(options.initial_poses[i]) * options.initial_poses[j]; };
    } else if (turntable || (options.turntable_round && n >= 3)) {
        // A turntable: the camera stays and the part turns by the same step S between views,
        // so view k -> view 0 is S^k. S (from the axis given, or estimated from the views) is
        // refined on all neighbouring pairs at once, and every view must agree with it.
        std::optional<cv::Matx44d> start;
        if (turntable) {
            start = turntable_pose(*turntable, 1);
        } else {
            report(0.1, "estimating the turntable's step");
            const TurntableStep round = estimate_turntable_step(data, options);
            alignment.turntable_supporting_pairs = round.supporting_pairs;
            start = round.step;
            if (!start) round_problem = round.problem;
        }
        if (start) {
            const bool full_round = !turntable || std::abs(static_cast<double>(n) * turntable->step_deg - 360.0) < 1.0;
            std::vector<detail::SamplePair> ring;
            for (size_t k = 0; k < (full_round ? n : n - 1); ++k)
                if (data[k].samples.points.size() >= 100 && data[(k + 1) % n].samples.points.size() >= 100)
                    ring.push_back({&data[k].samples, &data[(k + 1) % n].samples});
            const detail::IcpResult shared = detail::icp_point_to_plane(ring, *start, options);
            const PoseDifference moved_by = disagreement(*start, shared.transform, data[n > 1 ? 1 : 0]);
            if (!shared.converged)
                round_problem = "the turntable's step could not be refined on the neighbouring views (ICP did not converge)";
            else if (moved_by.rotation_deg > 2.0 || moved_by.translation_mm > 3.0)  // a calibrated axis may be a little off
                round_problem = "the views do not follow the given turntable axis (the step fitted to them is " +
                                format("%.2f", moved_by.rotation_deg) + " degrees and " + format("%.2f", moved_by.translation_mm) +
                                " mm away from it)";
            else
                alignment.turntable_step = shared.transform;
        }
        if (alignment.turntable_step) {
            const cv::Matx44d step = *alignment.turntable_step;
            guess_of = [step](size_t i, size_t j) {
                cv::Matx44d motion = cv::Matx44d::eye();
                if (j >= i)
                    for (size_t k = i; k < j; ++k) motion = motion * step;
                else
                    for (size_t k = j; k < i; ++k) motion = motion * detail::inverse_rigid(step);
                return motion;
            };
            max_departure_deg = 0.5;
            max_departure_mm = 0.75;
            motion_name = "the turntable's step";
        }
    }

    // Grow a tree of registered views from view 0, trying the likeliest pairs first: views
    // next to each other in the given (turntable) order, then farther ones. Only pairs that
    // join a new view are registered; loops are closed by the multi-view refinement, which
    // pairs every overlapping view with every other.
    struct Edge { size_t fixed, moving; PairRegistration result; };
    std::vector<Edge> edges;
    std::vector<std::pair<size_t, size_t>> candidates;
    for (size_t step = 1; step <= n / 2; ++step)
        for (size_t i = 0; i < n; ++i) {
            const size_t j = (i + step) % n;
            if (step * 2 == n && j < i) continue;  // the opposite pair once only
            candidates.emplace_back(i, j);
        }
    std::vector<bool> reached(n, false), tried(candidates.size(), false);
    std::vector<cv::Matx44d> poses(n, cv::Matx44d::eye());
    reached[0] = true;
    size_t reached_count = 1;
    for (bool grew = round_problem.empty(); grew && reached_count < n;) {
        grew = false;
        for (size_t c = 0; c < candidates.size() && reached_count < n; ++c) {
            auto [i, j] = candidates[c];
            if (tried[c] || reached[i] == reached[j]) continue;
            if (!reached[i]) std::swap(i, j);  // i is in the tree, j joins it
            tried[c] = true;
            report(0.2 + 0.4 * reached_count / n, "registering " + names[j] + " to " + names[i]);
            std::optional<cv::Matx44d> guess;
            if (guess_of) guess = guess_of(i, j);
            PairRegistration result = register_samples(data[i], data[j], options, guess);
            if (result.problem.empty() && guess && max_departure_deg == 0 && !result.converged)
                result.problem = "ICP did not converge in " + std::to_string(options.icp_iterations) + " iterations";
            if (result.problem.empty() && guess && max_departure_deg > 0) {
                const PoseDifference departure = disagreement(*guess, result.transform, data[j]);
                if (departure.rotation_deg > max_departure_deg || departure.translation_mm > max_departure_mm)
                    result.problem = "ICP moved it " + format("%.2f", departure.rotation_deg) + " degrees and " +
                                     format("%.2f", departure.translation_mm) + " mm away from " + motion_name +
                                     ": it does not agree with the turntable's motion";
            }
            edges.push_back({i, j, result});
            if (!result.problem.empty()) continue;
            // On a turntable every view sits at its step; the pair only confirmed it.
            poses[j] = alignment.turntable_step ? guess_of(0, j) : poses[i] * result.transform;
            reached[j] = true;
            ++reached_count;
            grew = true;
        }
    }
    const bool move_views = !alignment.turntable_step;
    std::vector<double> rms = detail::refine_together(data, poses, reached, 0, move_views, options, progress);

    // The whole model checked against every view's free space: a view placed where another
    // view's camera saw through is taken out (the one in most conflicts first), and the rest
    // refined again, until no view contradicts another.
    std::vector<std::string> conflict_problem(n);
    for (bool removed = true; removed;) {
        removed = false;
        std::vector<int> conflicts(n, 0);
        std::vector<std::pair<double, size_t>> worst(n, {0.0, 0});
        for (size_t i = 0; i < n; ++i)
            for (size_t j = i + 1; j < n; ++j) {
                if (!reached[i] || !reached[j]) continue;
                const double conflict = free_space_conflict(data[i], data[j], detail::inverse_rigid(poses[i]) * poses[j]);
                if (conflict <= kMaxFreeSpaceConflict) continue;
                ++conflicts[i];
                ++conflicts[j];
                if (conflict > worst[i].first) worst[i] = {conflict, j};
                if (conflict > worst[j].first) worst[j] = {conflict, i};
            }
        size_t culprit = n;
        for (size_t i = 0; i < n; ++i)
            if (conflicts[i] > 0 && (culprit == n || conflicts[i] >= conflicts[culprit])) culprit = i;
        if (culprit == n) break;
        reached[culprit] = false;
        conflict_problem[culprit] = "placed where it contradicts " + names[worst[culprit].second] + " (" +
                                    format("%.1f", 100 * worst[culprit].first) +
                                    " % of the points lie where one camera saw through): a wrong fit, left out";
        removed = true;
        const size_t anchor = static_cast<size_t>(std::find(reached.begin(), reached.end(), true) - reached.begin());
        if (anchor == n) break;
        rms = detail::refine_together(data, poses, reached, static_cast<int>(anchor), move_views, options, progress);
    }
    report(1.0, "aligned");

    for (size_t i = 0; i < n; ++i) {
        ViewAlignment& view = alignment.views[i];
        view.aligned = reached[i];
        view.pose = poses[i];
        view.rms_mm = rms[i];
        std::string closest;
        for (const Edge& e : edges) {
            if (e.fixed != i && e.moving != i) continue;
            if (e.result.overlap >= view.overlap) {
                view.overlap = e.result.overlap;
                closest = names[e.fixed == i ? e.moving : e.fixed] + ": " +
                          (e.result.problem.empty() ? std::string("registered") : e.result.problem);
            }
        }
        if (view.aligned) continue;
        if (!conflict_problem[i].empty())
            view.problem = conflict_problem[i];
        else if (data[i].samples.points.size() < 100)
            view.problem = "too few points (" + std::to_string(data[i].samples.points.size()) + " samples)";
        else if (!round_problem.empty())
            view.problem = "no turntable step fits the views: " + round_problem;
        else
            view.problem = "could not be registered to the others (best partner " +
                           (closest.empty() ? std::string("none") : closest) + ")";
    }
    return alignment;
}

}  // namespace picoscan
