// Point-to-plane ICP (Chen & Medioni 1992) with trimmed correspondences (Chetverikov et al.
// 2002): each iteration linearises the rotation and solves a 6x6 least-squares system.
#include "register/registration_steps.h"

#include <opencv2/calib3d.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace picoscan::detail {

cv::Matx44d rigid_transform(const cv::Matx33d& rotation, const cv::Vec3d& translation) {
    cv::Matx44d transform = cv::Matx44d::eye();
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) transform(r, c) = rotation(r, c);
        transform(r, 3) = translation[r];
    }
    return transform;
}

cv::Matx44d inverse_rigid(const cv::Matx44d& transform) {
    const cv::Matx33d rotation = transform.get_minor<3, 3>(0, 0).t();
    return rigid_transform(rotation, -(rotation * cv::Vec3d(transform(0, 3), transform(1, 3), transform(2, 3))));
}

cv::Matx44d motion_matrix(const cv::Vec3d& rotation_vector, const cv::Vec3d& translation) {
    cv::Matx33d rotation;
    cv::Rodrigues(rotation_vector, rotation);
    return rigid_transform(rotation, translation);
}

namespace {

// Directions of motion whose eigenvalue is below this share of the largest are left alone.
constexpr double kWeakDirection = 1e-3;

struct Pairing {
    double residual;  // signed point-to-plane distance
    double distance;  // point-to-point distance, for trimming
    cv::Vec3d point, normal;
    int moving, fixed;  // sample indices
    int pair;           // which pair of views
};

// Pearson correlation of the grey levels of the paired samples (NaN when either is flat).
double texture_correlation(const std::vector<Pairing>& pairings, size_t count, const std::vector<SamplePair>& pairs) {
    for (const SamplePair& pair : pairs)
        if (pair.fixed->grey.empty() || pair.moving->grey.empty()) return std::numeric_limits<double>::quiet_NaN();
    if (count < 10) return std::numeric_limits<double>::quiet_NaN();
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    for (size_t k = 0; k < count; ++k) {
        const SamplePair& pair = pairs[static_cast<size_t>(pairings[k].pair)];
        const double a = pair.moving->grey[static_cast<size_t>(pairings[k].moving)],
                     b = pair.fixed->grey[static_cast<size_t>(pairings[k].fixed)];
        sa += a; sb += b; saa += a * a; sbb += b * b; sab += a * b;
    }
    const double n = static_cast<double>(count);
    const double va = saa / n - (sa / n) * (sa / n), vb = sbb / n - (sb / n) * (sb / n);
    if (va < 1e-3 || vb < 1e-3) return std::numeric_limits<double>::quiet_NaN();  // no paint to compare
    return (sab / n - (sa / n) * (sb / n)) / std::sqrt(va * vb);
}

// Coarse to fine, for a start from features (often far off, or never settling): the first
// iterations pair only every kCoarseStride-th moving sample, about an eighth of the work, until
// they settle or kCoarseIterations have run; then every sample, from where they got to, with
// the whole budget of full-density iterations (options.icp_iterations) still to spend: a start
// that needs them all converges as it did without the coarse stage. Every start still runs,
// and ends and is judged at full density.
constexpr size_t kCoarseStride = 8;
constexpr int kCoarseIterations = 30;

}  // namespace

IcpResult icp_point_to_plane(const SurfaceSamples& fixed, const SurfaceSamples& moving, const cv::Matx44d& initial,
                             const RegistrationOptions& options, const EarlierFits& earlier, bool coarse_first) {
    return icp_point_to_plane({{&fixed, &moving}}, initial, options, earlier, coarse_first);
}

IcpResult icp_point_to_plane(const std::vector<SamplePair>& pairs, const cv::Matx44d& initial, const RegistrationOptions& options,
                             const EarlierFits& earlier, bool coarse_first) {
    IcpResult result;
    result.transform = initial;
    std::vector<std::unique_ptr<NearestGrid>> grids;
    size_t smaller_total = 0;
    for (const SamplePair& pair : pairs) {
        if (pair.fixed->points.empty() || pair.moving->points.empty()) return result;
        grids.push_back(std::make_unique<NearestGrid>(pair.fixed->points, options.icp_max_distance_mm));
        smaller_total += std::min(pair.fixed->points.size(), pair.moving->points.size());
    }
    if (pairs.empty()) return result;
    const double min_normal_cos = std::cos(CV_PI / 4);  // partners must face the same way
    double limit = options.icp_max_distance_mm;
    // The kept pairings of the last finished iteration are set aside: the texture agreement is
    // that iteration's, and only needed once the run ends.
    std::vector<Pairing> pairings, finished;
    size_t finished_kept = 0;
    std::vector<double> distances;
    std::vector<std::vector<SearchMemory>> memories(pairs.size());
    for (size_t k = 0; k < pairs.size(); ++k) memories[k].resize(pairs[k].moving->points.size());
    int coarse_left = coarse_first ? kCoarseIterations : 0, fine_left = options.icp_iterations;
    for (int iteration = 0; fine_left > 0; ++iteration) {
        const bool coarse = coarse_left > 0;
        if (coarse) --coarse_left;
        else --fine_left;
        const size_t stride = coarse ? kCoarseStride : 1;
        const cv::Matx33d rotation = result.transform.get_minor<3, 3>(0, 0);
        const cv::Vec3d translation(result.transform(0, 3), result.transform(1, 3), result.transform(2, 3));
        pairings.clear();
        for (size_t k = 0; k < pairs.size(); ++k) {
            const SurfaceSamples& fixed = *pairs[k].fixed;
            const SurfaceSamples& moving = *pairs[k].moving;
            for (size_t i = 0; i < moving.points.size(); i += stride) {
                const cv::Vec3d p = rotation * moving.points[i] + translation;
                const int j = grids[k]->nearest_remembered(p, limit, memories[k][i]);
                if (j < 0) continue;
                const cv::Vec3d& n = fixed.normals[static_cast<size_t>(j)];
                if ((rotation * moving.normals[i]).dot(n) < min_normal_cos) continue;
                const cv::Vec3d q = fixed.points[static_cast<size_t>(j)];
                pairings.push_back({(p - q).dot(n), cv::norm(p - q), p, n, static_cast<int>(i), j, static_cast<int>(k)});
            }
        }
        if (pairings.size() < 6) break;
        // Trimmed: only the best fraction of pairs (overlap is never complete).
        const size_t kept = std::max<size_t>(6, static_cast<size_t>(options.icp_trim_fraction * pairings.size()));
        std::nth_element(pairings.begin(), pairings.begin() + static_cast<long>(kept - 1), pairings.end(),
                         [](const Pairing& a, const Pairing& b) { return a.distance < b.distance; });
        // Linearised about the centroid of the paired points, rotation scaled by their spread, so
        // the six directions are comparable: a direction the surfaces do not fix (a plane or a
        // cylinder sliding along itself) shows as a tiny eigenvalue, and ICP does not move
        // along it (Gelfand et al. 2003 measure the same stability).
        cv::Vec3d centre(0, 0, 0);
        for (size_t k = 0; k < kept; ++k) centre += pairings[k].point;
        centre *= 1.0 / static_cast<double>(kept);
        double spread = 0;
        for (size_t k = 0; k < kept; ++k) spread += cv::norm(pairings[k].point - centre, cv::NORM_L2SQR);
        const double scale = std::max(std::sqrt(spread / static_cast<double>(kept)), 1.0);
        cv::Matx66d normal_matrix = cv::Matx66d::zeros();
        cv::Vec6d right_side(0, 0, 0, 0, 0, 0);
        double squared = 0;
        for (size_t k = 0; k < kept; ++k) {
            const Pairing& pair = pairings[k];
            const cv::Vec3d c = (pair.point - centre).cross(pair.normal) * (1.0 / scale);
            const cv::Vec6d row(c[0], c[1], c[2], pair.normal[0], pair.normal[1], pair.normal[2]);
            // The upper triangle only (the products are those of row * row.t(), added in the same order).
            for (int a = 0; a < 6; ++a) {
                for (int b = a; b < 6; ++b) normal_matrix(a, b) += row[a] * row[b];
                right_side[a] -= row[a] * pair.residual;
            }
            squared += pair.residual * pair.residual;
        }
        for (int a = 1; a < 6; ++a)
            for (int b = 0; b < a; ++b) normal_matrix(a, b) = normal_matrix(b, a);
        result.rms_mm = std::sqrt(squared / static_cast<double>(kept));
        cv::Matx61d eigenvalues;
        cv::Matx66d eigenvectors;  // rows
        if (!cv::eigen(normal_matrix, eigenvalues, eigenvectors)) break;
        result.stability = eigenvalues(0) > 0 ? std::max(eigenvalues(5), 0.0) / eigenvalues(0) : 0.0;
        cv::Vec6d step(0, 0, 0, 0, 0, 0);
        for (int e = 0; e < 6; ++e) {
            if (eigenvalues(e) < kWeakDirection * eigenvalues(0)) continue;  // not fixed by the surfaces: stay
            cv::Vec6d direction;
            for (int c = 0; c < 6; ++c) direction[c] = eigenvectors(e, c);
            step += direction * (direction.dot(right_side) / eigenvalues(e));
        }
        const cv::Vec3d omega = cv::Vec3d(step[0], step[1], step[2]) * (1.0 / scale), delta(step[3], step[4], step[5]);
        // x -> R (x - centre) + centre + delta
        const cv::Matx44d turn = motion_matrix(omega, {0, 0, 0});
        const cv::Vec3d shift = centre - turn.get_minor<3, 3>(0, 0) * centre + delta;
        result.transform = rigid_transform(turn.get_minor<3, 3>(0, 0), shift) * result.transform;
        // Tighten the correspondence distance as the alignment improves (outliers drop out).
        distances.clear();
        for (size_t k = 0; k < kept; ++k) distances.push_back(pairings[k].distance);
        std::nth_element(distances.begin(), distances.begin() + static_cast<long>(kept / 2), distances.end());
        limit = std::clamp(6.0 * distances[kept / 2], options.sample_spacing_mm, options.icp_max_distance_mm);
        result.overlap = static_cast<double>(pairings.size() * stride) / static_cast<double>(smaller_total);
        std::swap(pairings, finished);
        finished_kept = kept;
        // A start that shares almost nothing with the fixed view will not get better.
        if (iteration == 10 && result.overlap < options.min_overlap / 2) break;
        if (cv::norm(omega) < 1e-5 && cv::norm(delta) < 1e-3) {  // 0.0006 degrees, 1 um: far below what is measured
            if (coarse) {  // settled on the few: on to all samples
                coarse_left = 0;
                continue;
            }
            result.converged = true;
            break;
        }
        for (size_t f = 0; f < earlier.transforms.size() && result.joined < 0; ++f) {
            const PoseDifference apart = pose_difference(earlier.transforms[f], result.transform, earlier.centroid);
            if (apart.rotation_deg <= kJoinDeg && apart.translation_mm <= kJoinMm) result.joined = static_cast<int>(f);
        }
        if (result.joined >= 0) break;
    }
    result.texture_agreement = texture_correlation(finished, finished_kept, pairs);
    return result;
}

}  // namespace picoscan::detail
