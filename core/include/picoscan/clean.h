// Cleaning one organised view: removing stray-light and other unreliable points before
// stitching and meshing. Filters work on the camera's pixel grid, so they are fast and
// scale-aware (distances are measured in pixel footprints at the point's depth).
#pragma once

#include "picoscan/cloud.h"

#include <opencv2/core.hpp>

namespace picoscan {

struct CleanOptions {
    double min_quality = 0;          // points whose quality (fringe modulation) is below this go
    double max_grazing_deg = 80;     // points seen more obliquely than this (normal vs view ray) go; >= 90 disables
    bool use_working_volume = false; // points outside the box [volume_min, volume_max] (camera frame, mm) go
    cv::Vec3d volume_min{-1e9, -1e9, -1e9}, volume_max{1e9, 1e9, 1e9};
    int window_px = 2;               // neighbourhood: a (2w+1)^2 window of pixels
    // Statistical outliers: a point whose distance to its 4th nearest window neighbour (in pixel
    // footprints) exceeds median + outlier_sigma * robust sigma of that distance over the view.
    double outlier_sigma = 4;
    // Radius outliers: fewer than min_neighbours window neighbours within radius_footprints.
    double radius_footprints = 4;
    int min_neighbours = 3;
    // Small disconnected clusters (neighbours joined when closer than 8 footprints).
    int min_cluster_points = 100;
};

// How many points each filter removed, in the order they run.
struct CleanReport {
    int by_quality = 0, by_grazing = 0, by_working_volume = 0, by_statistics = 0, by_radius = 0, by_cluster = 0;
    int remaining = 0;
    int removed() const { return by_quality + by_grazing + by_working_volume + by_statistics + by_radius + by_cluster; }
};

// Background removal with a scan of the empty scene (same rig, same camera pose): a point
// that lies within tolerance_mm of the background's point at the same pixel, or behind it,
// is background and goes. Returns how many points were removed.
int remove_background(ScanView& view, const ScanView& background, double tolerance_mm = 1.0);

// Sets removed points (and their normals) to NaN. The view's camera gives a pixel's footprint.
CleanReport clean_view(ScanView& view, const CleanOptions& options = {});

}  // namespace picoscan
