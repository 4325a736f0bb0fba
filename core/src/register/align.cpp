// Registering pairs of views and aligning a whole set: pairwise edges (features or turntable
// guesses, then ICP), a maximum spanning tree over the accepted edges for initial poses, and
// a simultaneous multi-view point-to-plane refinement that spreads the error over all loops.
#include "picoscan/error.h"
#include "picoscan/register.h"
#include "register/registration_steps.h"

#include <opencv2/calib3d.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numeric>

namespace picoscan {

namespace {

std::string format(const char* pattern, double value) {
    char text[64];
    std::snprintf(text, sizeof text, pattern, value);
    return text;
}

cv::Matx44d inverse_rigid(const cv::Matx44d& t) {
    const cv::Matx33d rotation = t.get_minor<3, 3>(0, 0).t();
    const cv::Vec3d translation = -(rotation * cv::Vec3d(t(0, 3), t(1, 3), t(2, 3)));
    cv::Matx44d inverse = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) inverse(r, c) = rotation(r, c);
        inverse(r, 3) = translation[r];
    }
    return inverse;
}

// A pair is accepted when ICP converged onto enough shared surface, tightly.
void judge(PairRegistration& pair, const RegistrationOptions& options, double sample_spacing_mm, double texture_agreement) {
    const double max_rms = std::max(0.25, sample_spacing_mm / 2);
    const double min_texture_agreement = 0.4;
    if (pair.overlap < options.min_overlap)
        pair.problem = "too little overlap (" + format("%.1f", 100 * pair.overlap) + " % of points have a partner, need " +
                       format("%.1f", 100 * options.min_overlap) + " %)";
    else if (!pair.converged)
        pair.problem = "ICP did not converge in " + std::to_string(options.icp_iterations) + " iterations";
    else if (pair.rms_mm > max_rms)
        pair.problem = "residual too large after ICP (" + format("%.3f", pair.rms_mm) + " mm)";
    else if (texture_agreement < min_texture_agreement)  // false for NaN: no texture to judge by
        pair.problem = "the shapes fit but their surface textures do not (correlation " + format("%.2f", texture_agreement) +
                       "): a symmetric part matched the wrong way round";
}

PairRegistration register_samples(const detail::SurfaceSamples& fixed, const detail::SurfaceSamples& moving,
                                  const detail::ViewFeatures* fixed_features, const detail::ViewFeatures* moving_features,
                                  const RegistrationOptions& options, const std::optional<cv::Matx44d>& initial_guess) {
    PairRegistration pair;
    if (fixed.points.size() < 100 || moving.points.size() < 100) {
        pair.problem = "too few points to register (" + std::to_string(std::min(fixed.points.size(), moving.points.size())) +
                       " samples)";
        return pair;
    }
    // Candidate starting poses, in the order they are tried: the guess; else ORB hypotheses
    // on the white frames, then shape (FPFH) hypotheses. Several of each, because a nearly
    // symmetric part offers several good-looking fits and only ICP with the texture check can
    // tell which is right.
    const int hypotheses = 15;
    PairRegistration first;
    bool tried = false;
    for (int round = 0; round < (initial_guess ? 1 : 2); ++round) {
        std::vector<detail::CoarseAlignment> starts;
        if (initial_guess) {
            starts = {{*initial_guess, 0, options.min_ransac_inliers}};
        } else if (round == 0) {
            starts = detail::match_features(*fixed_features, *moving_features, options, hypotheses);
        } else {
            const double spacing = 2.0, radius = 6.0;
            starts = detail::match_features(detail::geometric_features(fixed, spacing, radius),
                                            detail::geometric_features(moving, spacing, radius), options, hypotheses);
        }
        for (const detail::CoarseAlignment& start : starts) {
            if (start.inliers < options.min_ransac_inliers) continue;
            const detail::IcpResult icp = detail::icp_point_to_plane(fixed, moving, start.transform, options);
            PairRegistration candidate = pair;
            candidate.transform = icp.transform;
            candidate.overlap = icp.overlap;
            candidate.rms_mm = icp.rms_mm;
            candidate.converged = icp.converged;
            candidate.texture_agreement = icp.texture_agreement;
            candidate.feature_matches = start.matches;
            candidate.ransac_inliers = start.inliers;
            judge(candidate, options, options.sample_spacing_mm, icp.texture_agreement);
            if (candidate.problem.empty()) return candidate;
            if (!tried || candidate.overlap > first.overlap) first = candidate;
            tried = true;
        }
    }
    if (!tried) {
        first = pair;
        first.problem = "no reliable feature alignment (fewer than " + std::to_string(options.min_ransac_inliers) +
                        " RANSAC inliers, on the white frames or the shape)";
    }
    return first;
}

// Multi-view refinement: every accepted view against every other, all poses solved together
// (view `anchor` fixed). Returns each view's point-to-plane RMS against the others.
std::vector<double> refine_together(const std::vector<detail::SurfaceSamples>& samples, std::vector<cv::Matx44d>& poses,
                                    const std::vector<bool>& active, int anchor, const RegistrationOptions& options,
                                    const ProgressCallback& progress) {
    const size_t n = samples.size();
    std::vector<int> unknown(n, -1);  // column block of each view's motion
    int blocks = 0;
    for (size_t i = 0; i < n; ++i)
        if (active[i] && static_cast<int>(i) != anchor) unknown[i] = blocks++;
    std::vector<double> rms(n, 0.0);
    const double min_normal_cos = std::cos(CV_PI / 4);
    double limit = std::max(3 * options.sample_spacing_mm, 1.0);
    for (int sweep = 0; sweep < options.global_sweeps; ++sweep) {
        if (progress && !progress(0.6 + 0.4 * sweep / options.global_sweeps, "refining all views together"))
            throw Error("cancelled", "alignment cancelled");
        std::vector<detail::SurfaceSamples> model(n);
        std::vector<std::unique_ptr<detail::PointGrid>> grids(n);
        for (size_t i = 0; i < n; ++i) {
            if (!active[i]) continue;
            model[i] = detail::transformed(samples[i], poses[i]);
            grids[i] = std::make_unique<detail::PointGrid>(model[i].points, limit);
        }
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
                for (size_t k = 0; k < model[i].points.size(); ++k) {
                    const cv::Vec3d& p = model[i].points[k];
                    const int m = grids[j]->nearest(p, limit);
                    if (m < 0) continue;
                    const cv::Vec3d& q = model[j].points[static_cast<size_t>(m)];
                    const cv::Vec3d& normal = model[j].normals[static_cast<size_t>(m)];
                    if (model[i].normals[k].dot(normal) < min_normal_cos) continue;
                    const cv::Vec3d pc = p.cross(normal), qc = q.cross(normal);
                    terms.push_back({(p - q).dot(normal), cv::norm(p - q),
                                     cv::Vec6d(pc[0], pc[1], pc[2], normal[0], normal[1], normal[2]),
                                     cv::Vec6d(-qc[0], -qc[1], -qc[2], -normal[0], -normal[1], -normal[2])});
                }
                if (terms.size() < 50) continue;
                const size_t kept = static_cast<size_t>(options.icp_trim_fraction * terms.size());
                std::nth_element(terms.begin(), terms.begin() + static_cast<long>(kept), terms.end(),
                                 [](const Term& a, const Term& b) { return a.distance < b.distance; });
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
                            for (int r = 0; r < 6; ++r)
                                for (int c = 0; c < 6; ++c)
                                    normal_matrix.at<double>(6 * block_a + r, 6 * block_b + c) += ra[r] * rb[c];
                        }
                        for (int r = 0; r < 6; ++r) right_side.at<double>(6 * block_a + r) -= ra[r] * term.residual;
                    }
                }
            }
        }
        for (size_t i = 0; i < n; ++i) rms[i] = counted[i] ? std::sqrt(squared[i] / static_cast<double>(counted[i])) : 0.0;
        if (blocks == 0) break;
        // A tiny damping keeps a view with a one-sided constraint (a sliding plane) in place.
        normal_matrix += cv::Mat::eye(6 * blocks, 6 * blocks, CV_64F) * 1e-6;
        cv::Mat step;
        if (!cv::solve(normal_matrix, right_side, step, cv::DECOMP_CHOLESKY)) break;
        double largest = 0;
        for (size_t i = 0; i < n; ++i) {
            if (unknown[i] < 0) continue;
            const int b = 6 * unknown[i];
            const cv::Vec3d omega(step.at<double>(b), step.at<double>(b + 1), step.at<double>(b + 2));
            const cv::Vec3d delta(step.at<double>(b + 3), step.at<double>(b + 4), step.at<double>(b + 5));
            poses[i] = detail::motion_matrix(omega, delta) * poses[i];
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

}  // namespace

int Alignment::aligned_count() const {
    return static_cast<int>(std::count_if(views.begin(), views.end(), [](const ViewAlignment& v) { return v.aligned; }));
}

PairRegistration register_pair(const ScanView& fixed, const ScanView& moving, const RegistrationOptions& options,
                               const std::optional<cv::Matx44d>& initial_guess) {
    const detail::SurfaceSamples fixed_samples = detail::sample_view(fixed, options.sample_spacing_mm);
    const detail::SurfaceSamples moving_samples = detail::sample_view(moving, options.sample_spacing_mm);
    detail::ViewFeatures fixed_features, moving_features;
    if (!initial_guess) {
        fixed_features = detail::view_features(fixed, options.orb_features);
        moving_features = detail::view_features(moving, options.orb_features);
    }
    return register_samples(fixed_samples, moving_samples, &fixed_features, &moving_features, options, initial_guess);
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
    return inverse_rigid(about_axis);
}

PoseDifference pose_difference(const cv::Matx44d& a, const cv::Matx44d& b, const cv::Vec3d& at) {
    const cv::Matx44d relative = inverse_rigid(a) * b;
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
    const bool guessed = turntable || !options.initial_poses.empty();
    const size_t n = views.size();
    Alignment alignment;
    alignment.views.resize(n);
    for (size_t i = 0; i < n; ++i) alignment.views[i].name = names[i];

    auto report = [&](double fraction, const std::string& stage) {
        if (progress && !progress(fraction, stage)) throw Error("cancelled", "alignment cancelled");
    };
    std::vector<detail::SurfaceSamples> samples(n);
    std::vector<detail::ViewFeatures> features(n);
    for (size_t i = 0; i < n; ++i) {
        report(0.1 * i / n, "sampling and finding features");
        samples[i] = detail::sample_view(views[i], options.sample_spacing_mm);
        if (!guessed) features[i] = detail::view_features(views[i], options.orb_features);
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
    for (bool grew = true; grew && reached_count < n;) {
        grew = false;
        for (size_t c = 0; c < candidates.size() && reached_count < n; ++c) {
            auto [i, j] = candidates[c];
            if (tried[c] || reached[i] == reached[j]) continue;
            if (!reached[i]) std::swap(i, j);  // i is in the tree, j joins it
            tried[c] = true;
            report(0.1 + 0.5 * reached_count / n, "registering " + names[j] + " to " + names[i]);
            std::optional<cv::Matx44d> guess;
            if (!options.initial_poses.empty())
                guess = inverse_rigid(options.initial_poses[i]) * options.initial_poses[j];
            else if (turntable)
                guess = inverse_rigid(turntable_pose(*turntable, static_cast<int>(i))) * turntable_pose(*turntable, static_cast<int>(j));
            edges.push_back({i, j, register_samples(samples[i], samples[j], &features[i], &features[j], options, guess)});
            if (!edges.back().result.problem.empty()) continue;
            poses[j] = poses[i] * edges.back().result.transform;
            reached[j] = true;
            ++reached_count;
            grew = true;
        }
    }
    const std::vector<double> rms = refine_together(samples, poses, reached, 0, options, progress);
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
        if (!view.aligned)
            view.problem = samples[i].points.size() < 100
                               ? "too few points (" + std::to_string(samples[i].points.size()) + " samples)"
                               : "could not be registered to the others (best partner " +
                                     (closest.empty() ? std::string("none") : closest) + ")";
    }
    return alignment;
}

}  // namespace picoscan
