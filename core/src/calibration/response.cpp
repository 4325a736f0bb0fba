// Projector response (gamma) calibration from flat grey frames.
#include "picoscan/response.h"
#include "picoscan/calibration.h"
#include "picoscan/error.h"

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>

namespace picoscan {

std::vector<int> response_levels(int count) {
    if (count < 3 || count > 256) throw Error("levels", "response measurement needs 3..256 levels");
    std::vector<int> levels;
    for (int index = 0; index < count; ++index) levels.push_back(int(std::lround(255.0 * index / (count - 1))));
    return levels;
}

std::string flat_level_file(int level) {
    if (level < 0 || level > 255) throw Error("level", "must be 0..255");
    char name[32];
    std::snprintf(name, sizeof name, "level_%03d.png", level);
    return name;
}

ProjectorResponse measure_projector_response(const std::vector<int>& levels, const std::vector<cv::Mat>& images,
                                             const cv::Mat& mask) {
    if (levels.size() != images.size() || levels.size() < 3)
        throw Error("response", "need one image per level and at least 3 levels");
    if (levels.front() != 0 || levels.back() != 255)
        throw Error("response", "levels must run from 0 to 255");
    for (size_t index = 1; index < levels.size(); ++index)
        if (levels[index] <= levels[index - 1]) throw Error("response", "levels must increase");
    for (const cv::Mat& image : images)
        if (image.size() != images.front().size() || image.channels() != 1)
            throw Error("response", "images must be single-channel and of one size");

    // Pixels the projector lights well: a clear white-black difference, not saturated.
    cv::Mat darkest, brightest;
    images.front().convertTo(darkest, CV_32F);
    images.back().convertTo(brightest, CV_32F);
    const double full_scale = images.front().depth() == CV_16U ? 65535.0 : 255.0;
    cv::Mat usable = (brightest - darkest > 0.1 * full_scale) & (brightest < 0.98 * full_scale);
    if (!mask.empty()) usable &= mask;
    if (cv::countNonZero(usable) < 100)
        throw Error("response", "fewer than 100 camera pixels see the projector's light change; aim it at a white surface");

    ProjectorResponse response;
    response.levels = levels;
    const double black = cv::mean(darkest, usable)[0], white = cv::mean(brightest, usable)[0];
    for (const cv::Mat& image : images) {
        cv::Mat values;
        image.convertTo(values, CV_32F);
        response.relative_light.push_back((cv::mean(values, usable)[0] - black) / (white - black));
    }
    for (size_t index = 1; index < response.relative_light.size(); ++index)
        if (response.relative_light[index] < response.relative_light[index - 1])
            response.relative_light[index] = response.relative_light[index - 1];  // noise must not fold the curve

    // Power-law fit on the middle levels, for the report: log(light) = gamma log(level).
    double numerator = 0, denominator = 0;
    for (size_t index = 1; index + 1 < levels.size(); ++index) {
        if (response.relative_light[index] <= 0) continue;
        const double x = std::log(levels[index] / 255.0), y = std::log(response.relative_light[index]);
        numerator += x * y;
        denominator += x * x;
    }
    response.gamma = denominator > 0 ? numerator / denominator : 1.0;

    // Inverse: for each wanted light t = k/255, the level whose measured light is t
    // (piecewise-linear interpolation of the measured curve).
    response.inverse_lut.create(1, 256, CV_8U);
    size_t segment = 1;
    for (int wanted = 0; wanted < 256; ++wanted) {
        const double light = wanted / 255.0;
        while (segment + 1 < levels.size() && response.relative_light[segment] < light) ++segment;
        const double low = response.relative_light[segment - 1], high = response.relative_light[segment];
        const double fraction = high > low ? std::clamp((light - low) / (high - low), 0.0, 1.0) : 0.0;
        const double level = levels[segment - 1] + fraction * (levels[segment] - levels[segment - 1]);
        response.inverse_lut.at<uint8_t>(wanted) = cv::saturate_cast<uint8_t>(std::lround(level));
    }
    return response;
}

}  // namespace picoscan
