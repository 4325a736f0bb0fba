// Surface samples of a view and a uniform grid over them for nearest-neighbour queries
// within a bounded distance (all ICP needs: partners farther than the bound are unused).
#pragma once

#include "picoscan/cloud.h"

#include <opencv2/core.hpp>
#include <vector>

namespace picoscan::detail {

struct SurfaceSamples {
    std::vector<cv::Vec3d> points;
    std::vector<cv::Vec3d> normals;  // unit
    std::vector<float> grey;         // white frame / its local mean (paint, not shading); empty without colours
};

// The smallest pixel rectangle holding every valid point of the view (empty when none).
cv::Rect measured_bounds(const ScanView& view);

// One valid point (with a finite normal) per spacing_mm cube, in the view's own frame.
// measured_area: measured_bounds(view), which the caller shares between the steps that need it
// (reading the whole frame costs more than the points in it).
SurfaceSamples sample_view(const ScanView& view, const cv::Rect& measured_area, double spacing_mm);

SurfaceSamples transformed(const SurfaceSamples& samples, const cv::Matx44d& transform);

// A cube of a uniform grid of side cell_mm, by its integer coordinates. Cells are told apart
// by all three coordinates, never by a hash of them alone: a hash shared by two cells would
// merge them (points found twice, or a thinned cloud missing a cell).
using GridCell = cv::Vec<long long, 3>;
GridCell grid_cell(const cv::Vec3d& p, double cell_mm);
struct GridCellHash {
    size_t operator()(const GridCell& cell) const;
};

class PointGrid {
public:
    // cell_mm: the largest distance nearest() and within() will usually be asked for (larger
    // ones work, visiting more cells).
    PointGrid(const std::vector<cv::Vec3d>& points, double cell_mm);

    // Index of the nearest point closer than max_distance_mm, or -1.
    int nearest(const cv::Vec3d& query, double max_distance_mm) const;
    // Indices of all points within radius_mm of the query.
    void within(const cv::Vec3d& query, double radius_mm, std::vector<int>& found) const;


private:
    // The points of one cell: a run of sorted_, in index order. Cells live in an
    // open-addressed table (no node allocations, few cache misses: ICP asks up to 8 per query).
    struct Cell { GridCell at; int begin = -1, end = -1; };
    const Cell* find(const GridCell& at) const;
    // Calls visit(point, index) for every point of the cells that the cube of half-side
    // radius_mm around the query touches (for radius_mm <= cell_mm, 1 to 8 cells, not the 27 around the
    // query's own cell; fewer as ICP tightens its radius). Cells in a fixed order, their
    // points in input order, so ties resolve the same way every time.
    template <class Visit>
    void visit_near(const cv::Vec3d& query, double radius_mm, Visit&& visit) const {
        const double margin = radius_mm + 1e-9;  // rounding never drops a cell that holds a point in range
        const GridCell low = grid_cell(query - cv::Vec3d::all(margin), cell_mm_), high = grid_cell(query + cv::Vec3d::all(margin), cell_mm_);
        for (long long x = low[0]; x <= high[0]; ++x)
            for (long long y = low[1]; y <= high[1]; ++y)
                for (long long z = low[2]; z <= high[2]; ++z) {
                    const Cell* cell = find(GridCell(x, y, z));
                    if (!cell) continue;
                    for (int k = cell->begin; k < cell->end; ++k)
                        visit(sorted_[static_cast<size_t>(k)], index_[static_cast<size_t>(k)]);
                }
    }
    double cell_mm_;
    std::vector<cv::Vec3d> sorted_;  // the points grouped by cell
    std::vector<int> index_;         // their indices in the input
    std::vector<Cell> table_;
    size_t mask_ = 0;
};

// What the last search for one slowly moving query (an ICP sample, from one iteration to the
// next) learned about its neighbourhood. Poses change little between iterations: while the
// query has moved less than the gap to the runner-up allows, the point found stays the
// nearest, and where nothing lay within reach nothing can be found before the query has moved
// closer than that reach. Either way the answer is the one a full search would give.
struct SearchMemory {
    int nearest = -1;     // the point found last time (NearestGrid's own numbering), or -1
    double clear_mm = 0;  // no point other than `nearest` lay this close to `at`
    cv::Vec3d at{0, 0, 0};
};

// PointGrid's nearest-point search over a dense table of the occupied cells' box instead of a
// hash (one lookup per row of cells, not one per cell), with a memory per query: ICP asks it
// for every sample in every iteration. The same cells in the same order, so it finds what
// PointGrid::nearest finds (built with the same cell size).
class NearestGrid {
public:
    NearestGrid(const std::vector<cv::Vec3d>& points, double cell_mm);
    // The index of the nearest point closer than max_distance_mm, or -1 (PointGrid::nearest's answer).
    int nearest(const cv::Vec3d& query, double max_distance_mm) const;
    // The index of the nearest point closer than max_distance_mm, or -1. `memory` starts empty and belongs to one query point, which may
    // have moved since the last call.
    int nearest_remembered(const cv::Vec3d& query, double max_distance_mm, SearchMemory& memory) const;

    // How much farther than needed a search reaches: what it finds there (the runner-up, or
    // that nothing lies that close) lets later calls skip the search while the query moves
    // less than this, also for a query with nothing in reach. (Cells 1.5 mm wide instead of
    // ICP's 3 mm reach tested a third of the points but took longer: a larger table.)
    static constexpr double kMarginMm = 0.3;

private:
    // The slot in sorted_ of the nearest point closer than radius_mm (-1: none), its squared
    // distance, and the clearance: no point other than the one found lies closer to the query
    // (the second nearest, or radius_mm when that is nearer).
    int search(const cv::Vec3d& query, double radius_mm, double& best_squared, double& clearance_mm) const;

    double cell_mm_;
    // Cells per axis size_, the first at first_: cell c holds sorted_[start_[c]] ..
    // sorted_[start_[c + 1] - 1], numbered z fastest, so a row of cells along z is one run.
    cv::Vec<long long, 3> first_{0, 0, 0}, size_{0, 0, 0};
    std::vector<int> start_;
    std::vector<cv::Vec3d> sorted_;  // the points grouped by cell, each cell's in input order
    std::vector<int> index_;         // their indices in the input
};

}  // namespace picoscan::detail
