// Error-bounded simplification of the facets a solid keeps as triangles (its curved regions): the
// one translation unit of the solid stage that includes CGAL.
#pragma once

#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <vector>

namespace picoscan::detail {

struct SimplifiedSurface {
    std::vector<cv::Vec3d> vertices;  // the input's, those the collapses kept moved to their new places
    std::vector<cv::Vec3i> facets;    // indices into `vertices`, orientation kept
    double max_deviation_mm = 0;      // the farthest input vertex from the simplified facets
};

// Collapses edges of `facets` (a consistently oriented surface, its border, if any, on `fixed`
// vertices; `others`, the facets that stay, close it: their edges are not made twice) while every
// input vertex stays within `tolerance_mm` of the facets (and each new vertex within it of the
// facets before) and no facet turns over; each new vertex placed so that the enclosed volume stays
// as it was (Lindstrom-Turk). Vertices marked in `fixed` neither move nor go. Returns the input
// unchanged when the facets do not make a surface CGAL can hold. `progress` is told every 1024
// edges looked at; answering false stops it (Error("cancelled", ...)).
SimplifiedSurface simplify_surface(const std::vector<cv::Vec3d>& vertices, const std::vector<cv::Vec3i>& facets,
                                   const std::vector<cv::Vec3i>& others, const std::vector<char>& fixed,
                                   double tolerance_mm, const ProgressCallback& progress = nullptr);

}  // namespace picoscan::detail
