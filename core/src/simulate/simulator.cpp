// The virtual rig: one ray-casting pass builds per-pixel geometry and lighting terms,
// after which each rendered frame is a cheap per-pixel sampling of the pattern.
#include "picoscan/simulate.h"

#include "common/memory_budget.h"
#include "common/parallel.h"
#include "picoscan/error.h"
#include "simulate/lens_model.h"
#include "simulate/scene_tracer.h"

#include <opencv2/imgproc.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace picoscan {

namespace {

// Shadow rays start this far from the surface so it does not shadow itself.
constexpr double kShadowOffsetMm = 1e-4;

uint64_t splitmix64(uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

// Two independent standard normal values for one pair of pixels (Box–Muller on a
// counter-based hash), so noise depends only on seed, frame and pixel, never on threads.
inline void gaussian_pair(uint64_t frame_key, uint64_t pair_index, float& z0, float& z1) {
    const uint64_t h = splitmix64(frame_key ^ (pair_index * 0xD1B54A32D192ED03ull));
    // 24-bit uniforms: exact in float; u1 in (0, 1] keeps the log finite (tails to 5.8 sigma).
    const float u1 = (static_cast<float>(h >> 40) + 1.0f) * (1.0f / 16777216.0f);
    const float u2 = static_cast<float>((h >> 8) & 0xFFFFFFull) * (1.0f / 16777216.0f);
    const float radius = std::sqrt(-2.0f * std::log(u1));
    const float angle = 6.2831853f * u2;
    z0 = radius * std::cos(angle);
    z1 = radius * std::sin(angle);
}

// Defocus beyond this blurs a fringe period away; the kernel's cost grows with sigma.
constexpr double kLargestBlurSigmaPx = 20;

void validate_options(const SimulationOptions& o) {
    auto check = [](bool ok, const std::string& problem) {
        if (!ok) throw Error("simulation options", problem);
    };
    check(std::isfinite(o.full_scale_dn) && o.full_scale_dn >= 0, "full_scale_dn must be finite and non-negative");
    check(std::isfinite(o.ambient_dn) && o.ambient_dn >= 0, "ambient_dn must be finite and non-negative");
    check(o.projector_black >= 0 && o.projector_black <= 1, "projector_black must be within 0..1");
    check(std::isfinite(o.projector_gamma) && o.projector_gamma > 0, "projector_gamma must be positive");
    check(std::isfinite(o.noise_sigma_dn) && o.noise_sigma_dn >= 0, "noise_sigma_dn must be finite and non-negative");
    check(std::isfinite(o.blur_sigma_px) && o.blur_sigma_px >= 0 && o.blur_sigma_px <= kLargestBlurSigmaPx,
          "blur_sigma_px must be within 0.." + std::to_string(int(kLargestBlurSigmaPx)));
    check(o.bit_depth == 8 || o.bit_depth == 16, "bit_depth must be 8 or 16, got " + std::to_string(o.bit_depth));
}

void validate_rig(const Calibration& c) {
    auto check_size = [](cv::Size size, const char* key) {
        if (size.width <= 0 || size.height <= 0 || size.width > kLargestImageSide || size.height > kLargestImageSide ||
            int64_t(size.width) * size.height > kLargestImagePixels)
            throw Error("calibration", std::string(key) + " must be positive, at most " +
                                           std::to_string(kLargestImageSide) + " pixels a side and " +
                                           std::to_string(kLargestImagePixels >> 20) + " Mpixel in all");
    };
    check_size(c.camera_size, "camera_size");
    check_size(c.projector_size, "projector_size");
    const cv::Matx33d should_be_identity = c.R.t() * c.R;
    if (!(cv::norm(should_be_identity - cv::Matx33d::eye()) < 1e-6) || !(cv::determinant(c.R) > 0))
        throw Error("calibration", "R must be a rotation matrix");
    if (!(std::isfinite(c.T[0]) && std::isfinite(c.T[1]) && std::isfinite(c.T[2])))
        throw Error("calibration", "T must be finite");
}

double width_times_height(cv::Size s) { return double(s.width) * double(s.height); }

std::string size_text(cv::Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

}  // namespace

struct Simulator::Impl {
    // Where a camera pixel samples the projector image: bilinear between the projector
    // pixels at (x0, y0) and (x0 + step_x, y0 + step_y), borders clamped.
    struct PixelLight {
        int32_t base = 0;    // y0 * projector width + x0
        int32_t step_y = 0;  // 0 or projector width
        float wx = 0, wy = 0;
        float gain = 0;      // full_scale_dn * shading where lit, 0 otherwise
        int32_t step_x = 0;  // 0 or 1
    };

    SimulationOptions options;
    cv::Size camera_size, projector_size;
    SimulatedGeometry geometry;
    std::vector<PixelLight> light;    // per camera pixel
    std::vector<float> ambient_dn;    // per camera pixel
    float light_of_level[256];        // projector light per pattern value
};

Simulator::Simulator(const Calibration& calibration, const Scene& scene, const SimulationOptions& options)
    : impl_(std::make_unique<Impl>()) {
    validate_options(options);
    validate_rig(calibration);
    Impl& s = *impl_;
    s.options = options;
    s.camera_size = calibration.camera_size;
    s.projector_size = calibration.projector_size;

    const detail::LensModel camera(calibration.camera_matrix, calibration.camera_distortion, calibration.camera_size,
                                   "calibration camera");
    const detail::LensModel projector(calibration.projector_matrix, calibration.projector_distortion,
                                      calibration.projector_size, "calibration projector");
    const detail::SceneTracer tracer(scene);

    const cv::Matx33d R = calibration.R;
    const cv::Vec3d T = calibration.T;
    const cv::Vec3d projector_centre = -(R.t() * T);  // in the camera frame

    // Geometry, light and ambient per camera pixel (about 80 bytes), before allocating them.
    detail::check_memory_budget(80.0 * width_times_height(s.camera_size), "calibration",
                                "simulating the " + size_text(s.camera_size) + " camera");
    const int width = s.camera_size.width, height = s.camera_size.height;
    const int proj_w = s.projector_size.width, proj_h = s.projector_size.height;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    SimulatedGeometry& g = s.geometry;
    g.points.create(s.camera_size, CV_32FC3);
    g.normals.create(s.camera_size, CV_32FC3);
    g.projector.create(s.camera_size, CV_32FC2);
    g.lit.create(s.camera_size, CV_8U);
    g.shading.create(s.camera_size, CV_32F);
    g.albedo.create(s.camera_size, CV_32F);
    s.light.assign(static_cast<size_t>(width) * height, Impl::PixelLight{});
    s.ambient_dn.assign(static_cast<size_t>(width) * height, 0.0f);

    // One pixel step in normalised distorted coordinates (the camera matrix is affine).
    const cv::Vec2d distorted_step_x = camera.from_pixel(cv::Vec2d(1, 0)) - camera.from_pixel(cv::Vec2d(0, 0));
    const cv::Vec2d distorted_step_y = camera.from_pixel(cv::Vec2d(0, 1)) - camera.from_pixel(cv::Vec2d(0, 0));

    detail::parallel_rows(height, [&](int row_begin, int row_end) {
        for (int row = row_begin; row < row_end; ++row) {
            auto* points = g.points.ptr<cv::Vec3f>(row);
            auto* normals = g.normals.ptr<cv::Vec3f>(row);
            auto* proj_uv = g.projector.ptr<cv::Vec2f>(row);
            auto* lit = g.lit.ptr<uint8_t>(row);
            auto* shading = g.shading.ptr<float>(row);
            auto* albedo = g.albedo.ptr<float>(row);
            // Start each undistortion from the previous pixel's, stepped by the inverse
            // Jacobian there: one Newton step then reaches rounding level.
            cv::Vec2d previous_distorted, previous_undistorted;
            cv::Matx22d previous_inverse_jacobian;
            bool have_previous = false;
            for (int col = 0; col < width; ++col) {
                const size_t index = static_cast<size_t>(row) * width + col;
                points[col] = cv::Vec3f(nan, nan, nan);
                normals[col] = cv::Vec3f(nan, nan, nan);
                proj_uv[col] = cv::Vec2f(nan, nan);
                lit[col] = 0;
                shading[col] = 0;
                albedo[col] = 0;

                const cv::Vec2d distorted = camera.from_pixel(cv::Vec2d(col, row));
                const cv::Vec2d start = previous_undistorted + previous_inverse_jacobian * (distorted - previous_distorted);
                cv::Vec2d undistorted;
                cv::Matx22d jacobian;
                have_previous = camera.undistort(distorted, undistorted, have_previous ? &start : nullptr, &jacobian);
                if (!have_previous) continue;
                previous_distorted = distorted;
                previous_undistorted = undistorted;
                previous_inverse_jacobian = jacobian.inv();
                const cv::Vec3d direction = cv::normalize(cv::Vec3d(undistorted[0], undistorted[1], 1.0));
                detail::SurfaceHit hit;
                if (!tracer.nearest(cv::Vec3d(0, 0, 0), direction, 0.0, std::numeric_limits<double>::infinity(), hit))
                    continue;
                const cv::Vec3d point = hit.t * direction;
                cv::Vec3d normal = hit.normal;
                if (normal.dot(direction) > 0) normal = -normal;  // the side the camera sees
                points[col] = cv::Vec3f(point);
                normals[col] = cv::Vec3f(normal);
                if (hit.board >= 0) {
                    // A printed pattern aliases when point-sampled: average it over the pixel's
                    // footprint, from the ray differentials of a pixel step (the undistortion's
                    // inverse Jacobian carries the step through the lens).
                    const cv::Vec2d step_x = previous_inverse_jacobian * distorted_step_x;
                    const cv::Vec2d step_y = previous_inverse_jacobian * distorted_step_y;
                    hit.albedo = tracer.board_albedo(hit.board, cv::Vec3d(0, 0, 0),
                                                     cv::Vec3d(undistorted[0], undistorted[1], 1.0),
                                                     cv::Vec3d(step_x[0], step_x[1], 0.0),
                                                     cv::Vec3d(step_y[0], step_y[1], 0.0));
                }
                albedo[col] = static_cast<float>(hit.albedo);
                s.ambient_dn[index] = static_cast<float>(options.ambient_dn * hit.albedo);

                cv::Vec2d uv;
                const bool in_image = projector.project(R * point + T, uv) && uv[0] >= -0.5 &&
                                      uv[0] <= proj_w - 0.5 && uv[1] >= -0.5 && uv[1] <= proj_h - 0.5;
                if (in_image) proj_uv[col] = cv::Vec2f(uv);

                const cv::Vec3d to_projector = projector_centre - point;
                const double distance = cv::norm(to_projector);
                const cv::Vec3d towards = to_projector * (1.0 / distance);
                const double cosine = normal.dot(towards);
                if (!(cosine > 0)) continue;  // faces away from the projector
                shading[col] = static_cast<float>(hit.albedo * cosine);
                if (!in_image || tracer.occluded(point, towards, kShadowOffsetMm, distance - kShadowOffsetMm)) continue;
                lit[col] = 255;

                Impl::PixelLight& pl = s.light[index];
                const double x_floor = std::floor(uv[0]), y_floor = std::floor(uv[1]);
                int x0 = static_cast<int>(x_floor), y0 = static_cast<int>(y_floor);
                int x1 = x0 + 1, y1 = y0 + 1;
                pl.wx = static_cast<float>(uv[0] - x_floor);
                pl.wy = static_cast<float>(uv[1] - y_floor);
                x0 = std::max(0, std::min(proj_w - 1, x0));
                x1 = std::max(0, std::min(proj_w - 1, x1));
                y0 = std::max(0, std::min(proj_h - 1, y0));
                y1 = std::max(0, std::min(proj_h - 1, y1));
                pl.base = y0 * proj_w + x0;
                pl.step_x = x1 - x0;
                pl.step_y = (y1 - y0) * proj_w;
                pl.gain = static_cast<float>(options.full_scale_dn * hit.albedo * cosine);
            }
        }
    });

    // Each projector pixel emits its own light (black level + gamma); the camera then
    // sees a bilinear mix of neighbouring pixels' light, as optics mix light, not levels.
    for (int level = 0; level < 256; ++level)
        s.light_of_level[level] = static_cast<float>(
            options.projector_black + (1.0 - options.projector_black) * std::pow(level / 255.0, options.projector_gamma));
}

Simulator::~Simulator() = default;

const SimulatedGeometry& Simulator::geometry() const { return impl_->geometry; }

cv::Mat Simulator::render(const cv::Mat& pattern, int frame_index) const {
    const Impl& s = *impl_;
    if (pattern.type() != CV_8UC1 || pattern.size() != s.projector_size)
        throw Error("pattern", "expected an 8-bit single-channel " + size_text(s.projector_size) + " image, got " +
                                   size_text(pattern.size()) + " with " + std::to_string(pattern.channels()) +
                                   " channel(s) of depth " + std::to_string(pattern.depth()));
    const cv::Mat projected = pattern.isContinuous() ? pattern : pattern.clone();
    const uint8_t* levels = projected.ptr<uint8_t>();
    const int width = s.camera_size.width, height = s.camera_size.height;

    cv::Mat clean(s.camera_size, CV_32F);
    detail::parallel_rows(height, [&](int row_begin, int row_end) {
        for (int row = row_begin; row < row_end; ++row) {
            float* out = clean.ptr<float>(row);
            const size_t first = static_cast<size_t>(row) * width;
            const Impl::PixelLight* light = s.light.data() + first;
            const float* ambient = s.ambient_dn.data() + first;
            for (int col = 0; col < width; ++col) {
                const Impl::PixelLight& p = light[col];
                float value = ambient[col];
                if (p.gain > 0.0f) {
                    const uint8_t* q = levels + p.base;
                    const float l00 = s.light_of_level[q[0]], l01 = s.light_of_level[q[p.step_x]];
                    const float l10 = s.light_of_level[q[p.step_y]], l11 = s.light_of_level[q[p.step_y + p.step_x]];
                    const float top = l00 + p.wx * (l01 - l00);
                    const float bottom = l10 + p.wx * (l11 - l10);
                    value += p.gain * (top + p.wy * (bottom - top));
                }
                out[col] = value;
            }
        }
    });
    if (s.options.blur_sigma_px > 0)
        cv::GaussianBlur(clean, clean, cv::Size(0, 0), s.options.blur_sigma_px, s.options.blur_sigma_px,
                         cv::BORDER_REPLICATE);

    const bool sixteen_bit = s.options.bit_depth == 16;
    cv::Mat image(s.camera_size, sixteen_bit ? CV_16U : CV_8U);
    const float sigma = static_cast<float>(s.options.noise_sigma_dn);
    const uint64_t frame_key =
        splitmix64(splitmix64(s.options.seed) ^ (static_cast<uint64_t>(static_cast<int64_t>(frame_index)) * 0xA24BAED4963EE407ull));
    const float* clean_values = clean.ptr<float>();  // freshly allocated, so continuous
    uint8_t* out8 = sixteen_bit ? nullptr : image.ptr<uint8_t>();
    uint16_t* out16 = sixteen_bit ? image.ptr<uint16_t>() : nullptr;
    auto store = [&](size_t i, float value) {
        if (sixteen_bit) {
            const int q = cvRound(value * 257.0f);
            out16[i] = static_cast<uint16_t>(std::max(0, std::min(65535, q)));
        } else {
            const int q = cvRound(value);
            out8[i] = static_cast<uint8_t>(std::max(0, std::min(255, q)));
        }
    };
    detail::parallel_rows(height, [&](int row_begin, int row_end) {
        const size_t end = static_cast<size_t>(row_end) * width;
        size_t i = static_cast<size_t>(row_begin) * width;
        if (sigma == 0.0f) {
            for (; i < end; ++i) store(i, clean_values[i]);
            return;
        }
        // Pixels 2k and 2k+1 share one hash; a chunk edge inside a pair just recomputes it.
        while (i < end) {
            float z0, z1;
            gaussian_pair(frame_key, i >> 1, z0, z1);
            if ((i & 1) == 0) {
                store(i, clean_values[i] + sigma * z0);
                if (i + 1 < end) store(i + 1, clean_values[i + 1] + sigma * z1);
                i += 2;
            } else {
                store(i, clean_values[i] + sigma * z1);
                i += 1;
            }
        }
    });
    return image;
}

CaptureSet simulate_capture(const PatternSequence& sequence, const Calibration& calibration, const Scene& scene,
                            const SimulationOptions& options, const ProgressCallback& progress) {
    if (calibration.projector_size != sequence.projector_size)
        throw Error("calibration", "projector size " + size_text(calibration.projector_size) +
                                       " does not match the pattern sequence's " + size_text(sequence.projector_size));
    if (sequence.frames.empty()) throw Error("pattern sequence", "has no frames to simulate");
    auto report = [&](double fraction) {
        if (progress && !progress(fraction, "simulate")) throw Error("cancelled", "simulation cancelled");
    };
    report(0.0);
    const Simulator simulator(calibration, scene, options);
    detail::check_memory_budget(width_times_height(calibration.camera_size) * double(sequence.frames.size()) *
                                    (options.bit_depth / 8),
                                "calibration", std::to_string(sequence.frames.size()) + " simulated frames of " +
                                                   size_text(calibration.camera_size));

    CaptureSet captures;
    captures.sequence = sequence;
    captures.images.reserve(sequence.frames.size());
    const int frame_count = static_cast<int>(sequence.frames.size());
    for (int i = 0; i < frame_count; ++i) {
        const Frame& frame = sequence.frames[i];
        const cv::Mat pattern = render_pattern(sequence, frame, calibration.projector_inverse_response);  // as a real projector would be fed
        captures.images.push_back(simulator.render(pattern, i));
        if (frame.kind == FrameKind::White && captures.white_colour.empty()) {
            cv::Mat grey = captures.images.back();
            if (grey.depth() == CV_16U) grey.convertTo(grey, CV_8U, 1.0 / 257.0);
            cv::cvtColor(grey, captures.white_colour, cv::COLOR_GRAY2BGR);
        }
        report(static_cast<double>(i + 1) / frame_count);
    }
    return captures;
}

}  // namespace picoscan
