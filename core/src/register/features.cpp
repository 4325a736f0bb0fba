// Coarse alignment: ORB on the white frames, lifted to 3D through the organised grid,
// matched with a ratio test, and a rigid fit by RANSAC (the seed's plan).
#include "register/registration_steps.h"

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include "common/parallel.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <unordered_set>

namespace picoscan::detail {

ViewFeatures view_features(const ScanView& view, const cv::Rect& measured_area, int max_features) {
    ViewFeatures features;
    if (view.points.empty() || view.colours.empty()) return features;
    // Only the measured area and a margin are searched (the part is small in the frame).
    if (measured_area.empty()) return features;
    const int margin = 32;
    const cv::Rect area = (measured_area + cv::Point(-margin, -margin) + cv::Size(2 * margin, 2 * margin)) &
                          cv::Rect(0, 0, view.points.cols, view.points.rows);
    cv::Mat grey;
    cv::cvtColor(view.colours(area), grey, cv::COLOR_BGR2GRAY);
    cv::Mat measured(area.size(), CV_8U);
    for (int y = 0; y < measured.rows; ++y) {
        const cv::Vec3f* row = view.points.ptr<cv::Vec3f>(y + area.y) + area.x;
        uchar* out = measured.ptr<uchar>(y);
        for (int x = 0; x < measured.cols; ++x) out[x] = is_finite_point(row[x]) ? 255 : 0;
    }
    // Keypoints near the edge of the measured area sit on depth jumps or on unmeasured
    // background texture: keep away from it.
    cv::erode(measured, measured, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(17, 17)));
    // ORB is not affine invariant, and neighbouring turntable views see each face foreshortened
    // differently. As in ASIFT (Morel & Yu 2009), features are also taken on squeezed copies
    // of the image (simulated tilts), at twice the resolution since parts are small in frame.
    const double upscale = 2.0;
    const cv::Vec2d squeezes[] = {{1.0, 1.0}, {0.7, 1.0}, {1.0, 0.6}};
    const cv::Ptr<cv::ORB> orb = cv::ORB::create(max_features, 1.2f, 8, 19, 0, 2, cv::ORB::HARRIS_SCORE, 19, 5);
    for (const cv::Vec2d& squeeze : squeezes) {
        const double sx = upscale * squeeze[0], sy = upscale * squeeze[1];
        cv::Mat image, mask;
        cv::resize(grey, image, cv::Size(), sx, sy, cv::INTER_AREA);
        cv::resize(measured, mask, image.size(), 0, 0, cv::INTER_NEAREST);
        std::vector<cv::KeyPoint> keypoints;
        cv::Mat descriptors;
        orb->detectAndCompute(image, mask, keypoints, descriptors);
        for (size_t i = 0; i < keypoints.size(); ++i) {
            const int x = cvRound(keypoints[i].pt.x / sx) + area.x, y = cvRound(keypoints[i].pt.y / sy) + area.y;
            if (x < 0 || y < 0 || x >= view.points.cols || y >= view.points.rows) continue;
            const cv::Vec3f p = view.points.at<cv::Vec3f>(y, x);
            if (!is_finite_point(p)) continue;
            features.points.emplace_back(p);
            features.descriptors.push_back(descriptors.row(static_cast<int>(i)));
        }
    }
    return features;
}

ViewFeatures geometric_features(const SurfaceSamples& samples, double spacing_mm, double radius_mm) {
    // Thin to the keypoint spacing (one sample per cube).
    std::vector<cv::Vec3d> points, normals;
    {
        std::unordered_set<GridCell, GridCellHash> taken;
        for (size_t i = 0; i < samples.points.size(); ++i) {
            const cv::Vec3d& p = samples.points[i];
            if (!taken.insert(grid_cell(p, spacing_mm)).second) continue;
            points.push_back(p);
            normals.push_back(samples.normals[i]);
        }
    }
    const int bins = 11;
    const PointGrid grid(points, radius_mm);
    std::vector<std::vector<int>> neighbours(points.size());
    cv::Mat simple(static_cast<int>(points.size()), 3 * bins, CV_32F, cv::Scalar(0));
    // Simplified histograms: the Darboux-frame angles between each point and its neighbours.
    for (size_t i = 0; i < points.size(); ++i) {
        grid.within(points[i], radius_mm, neighbours[i]);
        float* histogram = simple.ptr<float>(static_cast<int>(i));
        int counted = 0;
        for (int j : neighbours[i]) {
            if (static_cast<size_t>(j) == i) continue;
            const cv::Vec3d d = points[static_cast<size_t>(j)] - points[i];
            const double length = cv::norm(d);
            if (length < 1e-9) continue;
            const cv::Vec3d& u = normals[i];
            const cv::Vec3d& m = normals[static_cast<size_t>(j)];
            const cv::Vec3d v = cv::normalize(u.cross(d * (1.0 / length)));
            if (!std::isfinite(v[0])) continue;
            const cv::Vec3d w = u.cross(v);
            const double alpha = v.dot(m), phi = u.dot(d) / length, theta = std::atan2(w.dot(m), u.dot(m));
            auto bin = [&](double value, double lo, double hi) {
                return std::clamp(static_cast<int>((value - lo) / (hi - lo) * bins), 0, bins - 1);
            };
            histogram[bin(alpha, -1, 1)] += 1;
            histogram[bins + bin(phi, -1, 1)] += 1;
            histogram[2 * bins + bin(theta, -CV_PI, CV_PI)] += 1;
            ++counted;
        }
        if (counted > 0)
            for (int k = 0; k < 3 * bins; ++k) histogram[k] *= 100.0f / static_cast<float>(counted);
    }
    ViewFeatures features;
    std::vector<std::vector<float>> descriptor_rows;
    for (size_t i = 0; i < points.size(); ++i) {
        if (neighbours[i].size() < 8) continue;  // too sparse to describe
        // Plain loops, not matrix expressions: this runs for every neighbour of every point.
        double weights = 0;
        float spread[3 * bins] = {};
        for (int j : neighbours[i]) {
            if (static_cast<size_t>(j) == i) continue;
            const double weight = 1.0 / std::max(cv::norm(points[static_cast<size_t>(j)] - points[i]), 1e-3);
            const float* theirs = simple.ptr<float>(j);
            for (int k = 0; k < 3 * bins; ++k) spread[k] += static_cast<float>(theirs[k] * weight);
            weights += weight;
        }
        const float* own = simple.ptr<float>(static_cast<int>(i));
        std::vector<float> row(3 * bins);
        for (int k = 0; k < 3 * bins; ++k) row[k] = weights > 0 ? own[k] + static_cast<float>(spread[k] * (1.0 / weights)) : own[k];
        features.points.push_back(points[i]);
        descriptor_rows.push_back(std::move(row));
    }
    features.descriptors.create(static_cast<int>(descriptor_rows.size()), 3 * bins, CV_32F);
    for (size_t r = 0; r < descriptor_rows.size(); ++r)
        std::copy(descriptor_rows[r].begin(), descriptor_rows[r].end(), features.descriptors.ptr<float>(static_cast<int>(r)));
    return features;
}

cv::Matx44d rigid_fit(const std::vector<cv::Vec3d>& from, const std::vector<cv::Vec3d>& to) {
    const size_t n = from.size();
    cv::Vec3d mean_from(0, 0, 0), mean_to(0, 0, 0);
    for (size_t i = 0; i < n; ++i) {
        mean_from += from[i];
        mean_to += to[i];
    }
    mean_from *= 1.0 / static_cast<double>(n);
    mean_to *= 1.0 / static_cast<double>(n);
    cv::Matx33d covariance = cv::Matx33d::zeros();
    for (size_t i = 0; i < n; ++i) covariance += (to[i] - mean_to) * (from[i] - mean_from).t();
    cv::Matx31d w;
    cv::Matx33d u, vt;
    cv::SVD::compute(covariance, w, u, vt);  // fixed-size: no heap matrices in the RANSAC loop
    cv::Matx33d rotation = u * vt;
    if (cv::determinant(rotation) < 0) {  // a reflection: flip the weakest axis
        const cv::Matx33d flip(1, 0, 0, 0, 1, 0, 0, 0, -1);
        rotation = u * flip * vt;
    }
    return rigid_transform(rotation, mean_to - rotation * mean_from);
}

namespace {

// The two nearest fixed descriptors of one moving descriptor (indices -1 when missing).
struct TwoNearest {
    int first = -1, second = -1;
    int first_distance = INT_MAX, second_distance = INT_MAX;
};

// ORB descriptors: 256 bits, four 64-bit words.
constexpr int kOrbWords = 4;

// The descriptors' words, one row after another.
std::vector<std::uint64_t> descriptor_words(const cv::Mat& descriptors) {
    std::vector<std::uint64_t> words(static_cast<size_t>(descriptors.rows) * kOrbWords);
    for (int r = 0; r < descriptors.rows; ++r)
        std::memcpy(words.data() + static_cast<size_t>(r) * kOrbWords, descriptors.ptr(r), kOrbWords * 8);
    return words;
}

// The same words, word by word: every row's first word, then every row's second, and so on,
// so that the distances of one query to a run of rows are computed side by side.
std::vector<std::uint64_t> descriptor_columns(const cv::Mat& descriptors) {
    const size_t rows = static_cast<size_t>(descriptors.rows);
    std::vector<std::uint64_t> columns(rows * kOrbWords);
    for (size_t r = 0; r < rows; ++r) {
        std::uint64_t row[kOrbWords];
        std::memcpy(row, descriptors.ptr(static_cast<int>(r)), kOrbWords * 8);
        for (size_t w = 0; w < kOrbWords; ++w) columns[w * rows + r] = row[w];
    }
    return columns;
}

// Fixed rows whose distances to one query are computed in one run.
constexpr int kRunRows = 256;

// Brute force over 64-bit words with the processor's popcount where it has one (compiled
// for it: AVX-512's vector popcount counts eight words at once, the scalar one one; the plain
// build would count bits in software). The distances of a run of rows are computed first
// (a loop the compiler vectorises), then ranked in row order, so every build finds the same
// matches. Matching 12 000 ORB descriptors against 12 000 was a sixth of a pair's
// registration time through cv::BFMatcher.
inline __attribute__((always_inline)) void two_nearest_run(const std::uint64_t* moving, const std::uint64_t* fixed_columns, int fixed_rows, int begin,
                      int end, TwoNearest* out) {
    const size_t rows = static_cast<size_t>(fixed_rows);
    const std::uint64_t *w0 = fixed_columns, *w1 = w0 + rows, *w2 = w1 + rows, *w3 = w2 + rows;
    int distances[kRunRows];
    for (int q = begin; q < end; ++q) {
        const std::uint64_t* a = moving + static_cast<size_t>(q) * kOrbWords;
        const std::uint64_t a0 = a[0], a1 = a[1], a2 = a[2], a3 = a[3];
        TwoNearest best;
        for (int run = 0; run < fixed_rows; run += kRunRows) {
            const int count = std::min(kRunRows, fixed_rows - run);
            int smallest = INT_MAX;
            for (int k = 0; k < count; ++k) {
                const size_t t = static_cast<size_t>(run + k);
                distances[k] = __builtin_popcountll(a0 ^ w0[t]) + __builtin_popcountll(a1 ^ w1[t]) +
                               __builtin_popcountll(a2 ^ w2[t]) + __builtin_popcountll(a3 ^ w3[t]);
                smallest = std::min(smallest, distances[k]);
            }
            if (smallest >= best.second_distance) continue;  // nothing in this run ranks
            for (int k = 0; k < count; ++k) {
                const int distance = distances[k];
                // As a brute-force matcher ranks them: strictly closer only, so ties keep the lower index.
                if (distance >= best.second_distance) continue;
                if (distance < best.first_distance) {
                    best.second = best.first;
                    best.second_distance = best.first_distance;
                    best.first = run + k;
                    best.first_distance = distance;
                } else {
                    best.second = run + k;
                    best.second_distance = distance;
                }
            }
        }
        out[q] = best;
    }
}

#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
__attribute__((target("avx512f,avx512vpopcntdq"))) void two_nearest_vector_popcount(
    const std::uint64_t* moving, const std::uint64_t* fixed_columns, int fixed_rows, int begin, int end, TwoNearest* out) {
    two_nearest_run(moving, fixed_columns, fixed_rows, begin, end, out);
}
__attribute__((target("popcnt"))) void two_nearest_scalar_popcount(
    const std::uint64_t* moving, const std::uint64_t* fixed_columns, int fixed_rows, int begin, int end, TwoNearest* out) {
    two_nearest_run(moving, fixed_columns, fixed_rows, begin, end, out);
}
#endif

void two_nearest_rows(const std::uint64_t* moving, const std::uint64_t* fixed_columns, int fixed_rows, int begin, int end,
                      TwoNearest* out) {
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
    if (__builtin_cpu_supports("avx512vpopcntdq"))
        return two_nearest_vector_popcount(moving, fixed_columns, fixed_rows, begin, end, out);
    if (__builtin_cpu_supports("popcnt"))
        return two_nearest_scalar_popcount(moving, fixed_columns, fixed_rows, begin, end, out);
#endif
    two_nearest_run(moving, fixed_columns, fixed_rows, begin, end, out);
}

// For each moving ORB descriptor, its two nearest fixed ones by Hamming distance.
std::vector<TwoNearest> two_nearest_hamming(const cv::Mat& moving, const cv::Mat& fixed) {
    CV_Assert(moving.type() == CV_8U && fixed.type() == CV_8U && moving.cols == 8 * kOrbWords && fixed.cols == 8 * kOrbWords);
    const std::vector<std::uint64_t> moving_words = descriptor_words(moving), fixed_columns = descriptor_columns(fixed);
    std::vector<TwoNearest> nearest(static_cast<size_t>(moving.rows));
    parallel_rows(moving.rows, [&](int begin, int end) {
        two_nearest_rows(moving_words.data(), fixed_columns.data(), fixed.rows, begin, end, nearest.data());
    });
    return nearest;
}

cv::Vec3d apply(const cv::Matx44d& t, const cv::Vec3d& p) {
    return {t(0, 0) * p[0] + t(0, 1) * p[1] + t(0, 2) * p[2] + t(0, 3),
            t(1, 0) * p[0] + t(1, 1) * p[1] + t(1, 2) * p[2] + t(1, 3),
            t(2, 0) * p[0] + t(2, 1) * p[1] + t(2, 2) * p[2] + t(2, 3)};
}

}  // namespace

std::vector<CoarseAlignment> match_features(const ViewFeatures& fixed, const ViewFeatures& moving,
                                            const RegistrationOptions& options, int hypotheses) {
    std::vector<CoarseAlignment> results;
    if (fixed.points.size() < 3 || moving.points.size() < 3) return results;
    std::vector<cv::Vec3d> from, to;
    if (moving.descriptors.type() == CV_8U) {
        // ORB descriptors are distinctive: Lowe's ratio test.
        const std::vector<TwoNearest> nearest = two_nearest_hamming(moving.descriptors, fixed.descriptors);
        for (size_t i = 0; i < nearest.size(); ++i) {
            const TwoNearest& n = nearest[i];
            if (n.second < 0 || static_cast<float>(n.first_distance) > 0.8f * static_cast<float>(n.second_distance)) continue;
            from.push_back(moving.points[i]);
            to.push_back(fixed.points[static_cast<size_t>(n.first)]);
        }
    } else {
        // Histograms of a machined part repeat (every flat face looks alike), so they only
        // need to be a mutual best match.
        cv::BFMatcher matcher(cv::NORM_L2);
        std::vector<cv::DMatch> forward, backward;
        matcher.match(moving.descriptors, fixed.descriptors, forward);
        matcher.match(fixed.descriptors, moving.descriptors, backward);
        for (const cv::DMatch& match : forward) {
            if (backward[static_cast<size_t>(match.trainIdx)].trainIdx != match.queryIdx) continue;
            from.push_back(moving.points[static_cast<size_t>(match.queryIdx)]);
            to.push_back(fixed.points[static_cast<size_t>(match.trainIdx)]);
        }
    }
    const int matches = static_cast<int>(from.size());
    if (from.size() < 3) return {CoarseAlignment{cv::Matx44d::eye(), matches, 0}};

    const double inlier = options.ransac_inlier_mm;
    auto inliers_of = [&](const cv::Matx44d& transform, std::vector<int>* indices) {
        int count = 0;
        for (size_t i = 0; i < from.size(); ++i) {
            if (cv::norm(apply(transform, from[i]) - to[i]) > inlier) continue;
            ++count;
            if (indices) indices->push_back(static_cast<int>(i));
        }
        return count;
    };
    auto refit = [&](cv::Matx44d transform) {
        // Refit on all inliers, twice (the set may grow once the fit is better).
        for (int round = 0; round < 2; ++round) {
            std::vector<int> indices;
            inliers_of(transform, &indices);
            if (indices.size() < 3) break;
            std::vector<cv::Vec3d> f, t;
            for (int i : indices) {
                f.push_back(from[static_cast<size_t>(i)]);
                t.push_back(to[static_cast<size_t>(i)]);
            }
            transform = rigid_fit(f, t);
        }
        return CoarseAlignment{transform, matches, inliers_of(transform, nullptr)};
    };
    auto distinct = [&](const cv::Matx44d& a, const cv::Matx44d& b) {
        // Distinct when the sampled points land more than a few inlier distances apart.
        double worst = 0;
        for (size_t i = 0; i < from.size(); i += std::max<size_t>(1, from.size() / 20))
            worst = std::max(worst, cv::norm(apply(a, from[i]) - apply(b, from[i])));
        return worst > 5 * inlier;
    };
    cv::RNG rng(0x5eed);  // deterministic: the same views register the same way
    const int n = static_cast<int>(from.size());
    std::vector<CoarseAlignment> best;  // most inliers first, pairwise distinct
    // Stop once a better consensus than the best would have been drawn with 99.9 % certainty
    // (Fischler & Bolles), but not before 2000 draws, so that the runners-up are sampled too.
    int needed = options.ransac_iterations;
    for (int iteration = 0; iteration < std::min(needed, options.ransac_iterations); ++iteration) {
        if (!best.empty()) {
            const double w = static_cast<double>(best.front().inliers) / n;
            const double draws = std::log(1e-3) / std::log(std::max(1e-12, 1.0 - w * w * w));
            needed = std::max(2000, static_cast<int>(std::min(draws, 1e9)));
        }
        const int a = rng.uniform(0, n), b = rng.uniform(0, n), c = rng.uniform(0, n);
        if (a == b || b == c || a == c) continue;
        // A rigid motion keeps distances: reject inconsistent samples before fitting.
        auto consistent = [&](int i, int j) {
            return std::abs(cv::norm(from[i] - from[j]) - cv::norm(to[i] - to[j])) < 2 * inlier &&
                   cv::norm(from[i] - from[j]) > 5 * inlier;
        };
        if (!consistent(a, b) || !consistent(b, c) || !consistent(a, c)) continue;
        const cv::Matx44d transform = rigid_fit({from[a], from[b], from[c]}, {to[a], to[b], to[c]});
        const int count = inliers_of(transform, nullptr);
        if (count < 3 || (static_cast<int>(best.size()) == hypotheses && count <= best.back().inliers)) continue;
        const CoarseAlignment candidate{transform, matches, count};
        auto same = std::find_if(best.begin(), best.end(), [&](const CoarseAlignment& h) { return !distinct(h.transform, transform); });
        if (same != best.end()) {
            if (same->inliers < count) *same = candidate;
        } else {
            best.push_back(candidate);
        }
        std::sort(best.begin(), best.end(), [](const CoarseAlignment& x, const CoarseAlignment& y) { return x.inliers > y.inliers; });
        if (static_cast<int>(best.size()) > hypotheses) best.pop_back();
    }
    for (const CoarseAlignment& hypothesis : best) results.push_back(refit(hypothesis.transform));
    if (results.empty()) results.push_back(CoarseAlignment{cv::Matx44d::eye(), matches, 0});
    return results;
}

}  // namespace picoscan::detail
