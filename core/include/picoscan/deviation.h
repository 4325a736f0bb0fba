// Deviation map: the signed distance of every scanned point (or mesh vertex) to a reference
// surface (a CAD model tessellated into triangles, or a mesh), with the figures an inspection
// report gives: mean, sigma, 95th percentile, maximum and the share within a tolerance.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

struct DeviationOptions {
    double tolerance_mm = 0.05;       // |d| <= tolerance is "within tolerance" (green in the colour map)
    // Points farther than this from the reference are not part of it (another object, a fixture):
    // they get NaN and are left out of the figures. 0 keeps every point.
    double max_distance_mm = 0;
    int histogram_bins = 40;
    // The histogram and colour scale span [-range, +range]; 0 chooses 4 x tolerance.
    double range_mm = 0;
};

struct DeviationStatistics {
    size_t count = 0;                 // points measured (within max_distance_mm)
    size_t ignored = 0;               // points farther than max_distance_mm
    double mean_mm = 0;               // signed mean: a scan consistently outside the model is positive
    double mean_abs_mm = 0;
    double sigma_mm = 0;              // standard deviation of the signed distances
    double p95_abs_mm = 0;            // 95 % of the points are nearer than this
    double max_abs_mm = 0;
    double min_mm = 0, max_mm = 0;    // most negative and most positive signed distance
    double within_tolerance = 0;      // fraction (0..1) of the points with |d| <= tolerance
};

struct DeviationMap {
    // One per input point, in mm: positive outside the reference (on the side its triangles'
    // normals point to), negative inside; NaN when ignored (see max_distance_mm).
    std::vector<float> distances_mm;
    DeviationStatistics statistics;
    double tolerance_mm = 0;
    double range_mm = 0;                   // colour scale and histogram: [-range, +range]
    std::vector<size_t> histogram;         // counts of histogram_bins equal bins over [-range, +range]
    size_t below_range = 0, above_range = 0;  // counts outside the histogram
};

// Signed distances of `points` to the triangles (counter-clockwise seen from outside; the sign
// comes from the angle-weighted pseudo-normal at the closest point, Baerentzen & Aanaes 2005, so
// points near edges and corners get the right side). Uses an AABB tree over the triangles.
// Throws Error("reference", ...) for no triangles or indices out of range, Error("points", ...)
// for no points, Error("tolerance_mm"/"histogram_bins"/...) for bad options, Error("cancelled", ...)
// when progress returns false.
DeviationMap measure_deviation(const std::vector<cv::Vec3f>& points, const Mesh& reference,
                               const DeviationOptions& options = {}, const ProgressCallback& progress = nullptr);

// Best fit of a scan onto a model: trimmed point-to-plane ICP against the reference's triangles
// (Chen & Medioni 1992; trimmed as in Chetverikov et al. 2002), from the points' current place.
struct BestFitOptions {
    int max_iterations = 60;
    double keep_fraction = 0.9;        // each step uses the nearest 90 % of the pairs (the rest: outliers)
    double max_distance_mm = 0;        // pairs farther apart are never used; 0: no limit
    int max_points = 50000;            // evenly chosen subset used for the fit
    double converged_deg = 1e-4, converged_mm = 1e-4;  // a step smaller than both ends the fit
};
struct BestFit {
    cv::Matx44d transform = cv::Matx44d::eye();  // moves the points onto the reference
    double rms_mm = 0;                 // of the kept pairs after the last step
    size_t pairs = 0;                  // pairs kept in the last step
    int iterations = 0;
    bool converged = false;
};
// Throws Error("points", ...) when fewer than 6 pairs remain or the pairs do not fix all six
// degrees of freedom (one plane, a sphere, a cylinder alone), Error("reference", ...) for a bad
// mesh, Error("keep_fraction"/"max_iterations", ...) for bad options, Error("cancelled", ...).
BestFit best_fit_to_reference(const std::vector<cv::Vec3f>& points, const Mesh& reference,
                              const BestFitOptions& options = {}, const ProgressCallback& progress = nullptr);

// The statistics and histogram of already-measured signed distances (NaN are ignored).
void summarise_deviation(DeviationMap& map, const DeviationOptions& options);

// Colour of each distance on the map's scale (RGB): green within tolerance, then yellow to red
// outside (positive), cyan to blue inside (negative); saturated beyond the range; grey for NaN.
std::vector<cv::Vec3b> deviation_colours(const DeviationMap& map);
cv::Vec3b deviation_colour(double distance_mm, double tolerance_mm, double range_mm);

// The points with their signed distance as per-vertex "quality" and the map's colours, as PLY.
void write_deviation_ply(const std::vector<cv::Vec3f>& points, const DeviationMap& map, const std::string& path);

// A picture of the histogram with the colour scale as its legend and the tolerance band marked.
cv::Mat plot_deviation_histogram(const DeviationMap& map, const std::string& title);
// An HTML report (figures, histogram) and the histogram PNG beside it (<report>.png).
void write_deviation_report(const DeviationMap& map, const std::string& title, const std::string& html_path);

}  // namespace picoscan
