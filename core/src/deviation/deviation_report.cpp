// Figures, histogram, colours, PLY and HTML report of a deviation map.
#include "common/text_format.h"
#include "picoscan/deviation.h"
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace picoscan {

void summarise_deviation(DeviationMap& map, const DeviationOptions& options) {
    map.tolerance_mm = options.tolerance_mm;
    map.range_mm = options.range_mm > 0 ? options.range_mm : 4 * options.tolerance_mm;
    map.histogram.assign(size_t(options.histogram_bins), 0);
    map.below_range = map.above_range = 0;
    DeviationStatistics& s = map.statistics;
    s = DeviationStatistics();
    std::vector<float> magnitudes;
    magnitudes.reserve(map.distances_mm.size());
    double sum = 0, sum_abs = 0, sum_squares = 0;
    size_t within = 0;
    s.min_mm = HUGE_VAL;
    s.max_mm = -HUGE_VAL;
    const double bin_width = 2 * map.range_mm / options.histogram_bins;
    for (const float d : map.distances_mm) {
        if (std::isnan(d)) {
            ++s.ignored;
            continue;
        }
        magnitudes.push_back(std::abs(d));
        sum += d;
        sum_abs += std::abs(d);
        sum_squares += double(d) * d;
        within += std::abs(d) <= options.tolerance_mm;
        s.min_mm = std::min(s.min_mm, double(d));
        s.max_mm = std::max(s.max_mm, double(d));
        const double bin = std::floor((d + map.range_mm) / bin_width);
        if (bin < 0)
            ++map.below_range;
        else if (bin >= options.histogram_bins)
            ++map.above_range;
        else
            ++map.histogram[size_t(bin)];
    }
    s.count = magnitudes.size();
    if (s.count == 0) throw Error("points", "none lies within max_distance_mm of the reference");
    const double n = double(s.count);
    s.mean_mm = sum / n;
    s.mean_abs_mm = sum_abs / n;
    s.sigma_mm = std::sqrt(std::max(0.0, sum_squares / n - s.mean_mm * s.mean_mm));
    s.max_abs_mm = std::max(-s.min_mm, s.max_mm);
    s.within_tolerance = double(within) / n;
    const size_t rank = std::min(s.count - 1, size_t(std::ceil(0.95 * n)) - 1);
    std::nth_element(magnitudes.begin(), magnitudes.begin() + long(rank), magnitudes.end());
    s.p95_abs_mm = magnitudes[rank];
}

cv::Vec3b deviation_colour(double d, double tolerance_mm, double range_mm) {
    if (std::isnan(d)) return {128, 128, 128};
    const double magnitude = std::abs(d);
    if (magnitude <= tolerance_mm) return {0, 200, 0};
    // 0 at the tolerance, 1 at the end of the range.
    const double t = std::clamp((magnitude - tolerance_mm) / std::max(range_mm - tolerance_mm, 1e-12), 0.0, 1.0);
    const auto level = [](double value) { return uchar(std::lround(255 * value)); };
    if (d > 0) return {255, level(1 - t), 0};  // yellow -> red: material where the model has none
    return {0, level(1 - t), 255};             // cyan -> blue: material missing
}

std::vector<cv::Vec3b> deviation_colours(const DeviationMap& map) {
    std::vector<cv::Vec3b> colours(map.distances_mm.size());
    for (size_t i = 0; i < colours.size(); ++i)
        colours[i] = deviation_colour(map.distances_mm[i], map.tolerance_mm, map.range_mm);
    return colours;
}

void write_deviation_ply(const std::vector<cv::Vec3f>& points, const DeviationMap& map, const std::string& path) {
    if (points.size() != map.distances_mm.size())
        throw Error(path, "the deviation map has " + std::to_string(map.distances_mm.size()) + " distances for " +
                              std::to_string(points.size()) + " points");
    PointCloud cloud;
    cloud.points = points;
    cloud.quality = map.distances_mm;
    cloud.colours = deviation_colours(map);
    write_ply(cloud, path);
}

namespace {

std::string summary_line(const DeviationStatistics& s, double tolerance_mm) {
    return format("mean %+.4f mm", s.mean_mm) + format(", sigma %.4f mm", s.sigma_mm) +
           format(", p95 |d| %.4f mm", s.p95_abs_mm) + format(", max |d| %.4f mm", s.max_abs_mm) +
           format(", %.1f %%", 100 * s.within_tolerance) + format(" within +-%.3f mm", tolerance_mm);
}

std::string escape_html(const std::string& text) {
    std::string out;
    for (const char c : text) out += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
    return out;
}

}  // namespace

cv::Mat plot_deviation_histogram(const DeviationMap& map, const std::string& title) {
    const int width = 900, height = 480, left = 70, right = 40, top = 60, bottom = 70;  // room for half a label
    cv::Mat image(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
    const int plot_w = width - left - right, plot_h = height - top - bottom;
    const size_t bins = map.histogram.size();
    const size_t tallest = bins ? *std::max_element(map.histogram.begin(), map.histogram.end()) : 0;
    const auto x_of = [&](double d) { return left + int(std::lround((d + map.range_mm) / (2 * map.range_mm) * plot_w)); };
    const auto bgr = [](const cv::Vec3b& rgb) { return cv::Scalar(rgb[2], rgb[1], rgb[0]); };
    // Tolerance band behind the bars.
    cv::rectangle(image, {x_of(-map.tolerance_mm), top}, {x_of(map.tolerance_mm), top + plot_h}, {225, 245, 225}, cv::FILLED);
    for (size_t b = 0; b < bins && tallest > 0; ++b) {
        const double low = -map.range_mm + 2 * map.range_mm * double(b) / bins;
        const double high = -map.range_mm + 2 * map.range_mm * double(b + 1) / bins;
        const int bar = int(std::lround(double(map.histogram[b]) / tallest * plot_h));
        const cv::Vec3b colour = deviation_colour(0.5 * (low + high), map.tolerance_mm, map.range_mm);
        cv::rectangle(image, {x_of(low) + 1, top + plot_h - bar}, {x_of(high) - 1, top + plot_h}, bgr(colour), cv::FILLED);
    }
    // The colour scale under the axis is the legend.
    for (int x = left; x < left + plot_w; ++x) {
        const double d = (double(x - left) / plot_w * 2 - 1) * map.range_mm;
        cv::line(image, {x, top + plot_h + 4}, {x, top + plot_h + 16}, bgr(deviation_colour(d, map.tolerance_mm, map.range_mm)));
    }
    const cv::Scalar ink(40, 40, 40);
    cv::rectangle(image, {left, top}, {left + plot_w, top + plot_h}, ink);
    const auto text = [&](const std::string& s, cv::Point at, double scale = 0.45) {
        cv::putText(image, s, at, cv::FONT_HERSHEY_SIMPLEX, scale, ink, 1, cv::LINE_AA);
    };
    for (int k = -4; k <= 4; ++k) {  // each label centred under its tick
        const double d = map.range_mm * k / 4;
        const std::string label = format("%+.3f", d);
        int baseline = 0;
        const int label_w = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, 0.45, 1, &baseline).width;
        text(label, {x_of(d) - label_w / 2, top + plot_h + 34});
    }
    text("signed distance to the reference (mm); band: tolerance", {left, top + plot_h + 56});
    text(title, {left, 24}, 0.6);
    text(summary_line(map.statistics, map.tolerance_mm), {left, 46});
    text(std::to_string(map.below_range) + " below", {left + 4, top + 16});
    text(std::to_string(map.above_range) + " above", {left + plot_w - 90, top + 16});
    return image;
}

void write_deviation_report(const DeviationMap& map, const std::string& title, const std::string& html_path) {
    const std::string png_path = html_path + ".png";
    write_image_file(plot_deviation_histogram(map, title), png_path);
    const DeviationStatistics& s = map.statistics;
    const std::string png_name = png_path.substr(png_path.find_last_of('/') + 1);
    std::ostringstream html;
    html << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>Deviation report</title>\n"
         << "<style>body{font-family:sans-serif}td{padding:2px 12px}td:nth-child(2){text-align:right}</style>"
         << "</head><body>\n<h1>Deviation: " << escape_html(title) << "</h1>\n<table>\n"
         << "<tr><td>points measured</td><td>" << s.count << "</td></tr>\n"
         << "<tr><td>points ignored (too far)</td><td>" << s.ignored << "</td></tr>\n"
         << "<tr><td>tolerance</td><td>" << format("&plusmn;%.4f mm", map.tolerance_mm) << "</td></tr>\n"
         << "<tr><td>within tolerance</td><td>" << format("%.2f %%", 100 * s.within_tolerance) << "</td></tr>\n"
         << "<tr><td>mean (signed)</td><td>" << format("%+.4f mm", s.mean_mm) << "</td></tr>\n"
         << "<tr><td>mean |d|</td><td>" << format("%.4f mm", s.mean_abs_mm) << "</td></tr>\n"
         << "<tr><td>sigma</td><td>" << format("%.4f mm", s.sigma_mm) << "</td></tr>\n"
         << "<tr><td>95th percentile |d|</td><td>" << format("%.4f mm", s.p95_abs_mm) << "</td></tr>\n"
         << "<tr><td>max |d|</td><td>" << format("%.4f mm", s.max_abs_mm) << "</td></tr>\n"
         << "<tr><td>min, max (signed)</td><td>" << format("%+.4f", s.min_mm) << format(", %+.4f mm", s.max_mm)
         << "</td></tr>\n</table>\n<p>Positive: the scan lies outside the reference (material the model does not "
            "have); negative: inside.</p>\n<img src=\"" << png_name << "\" alt=\"histogram\">\n</body></html>\n";
    write_file_atomically(html_path, html.str());
}

}  // namespace picoscan
