#include "register/point_grid.h"

#include <opencv2/imgproc.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>
#include <unordered_set>

namespace picoscan::detail {

cv::Rect measured_bounds(const ScanView& view) {
    int left = view.points.cols, top = view.points.rows, right = -1, bottom = -1;
    for (int y = 0; y < view.points.rows; ++y) {
        const cv::Vec3f* row = view.points.ptr<cv::Vec3f>(y);
        for (int x = 0; x < view.points.cols; ++x) {
            if (!is_finite_point(row[x])) continue;
            left = std::min(left, x);
            right = std::max(right, x);
            top = std::min(top, y);
            bottom = std::max(bottom, y);
        }
    }
    return right < 0 ? cv::Rect() : cv::Rect(left, top, right - left + 1, bottom - top + 1);
}

SurfaceSamples sample_view(const ScanView& view, const cv::Rect& measured_area, double spacing_mm) {
    SurfaceSamples samples;
    if (view.points.empty()) return samples;
    const bool has_normals = !view.normals.empty();
    // Paint only: the white frame divided by its local mean (over measured pixels), so that
    // shading, which any two faces share, does not count as texture.
    cv::Mat paint;  // over `measured_area` only
    if (!view.colours.empty() && !measured_area.empty()) {
        // The local mean spans about 1.3 mm of surface at the working distance whatever the
        // camera's resolution (8 pixels of the seed camera, fx 2500): wider, the shading near
        // an edge would count as paint on a lower-resolution camera.
        const double fx = view.camera_matrix(0, 0);
        const double sigma_px = fx > 0 ? std::clamp(8.0 * fx / 2500.0, 1.0, 32.0) : 8.0;
        // Filtered over the measured area and a margin wider than the kernel, not the whole
        // frame: outside the measured pixels the weights are zero, so the result is the same.
        const int margin = static_cast<int>(std::ceil(4 * sigma_px)) + 2;
        const cv::Rect area = (measured_area + cv::Point(-margin, -margin) + cv::Size(2 * margin, 2 * margin)) &
                              cv::Rect(0, 0, view.points.cols, view.points.rows);
        cv::Mat grey, measured(area.size(), CV_32F);
        cv::cvtColor(view.colours(area), grey, cv::COLOR_BGR2GRAY);
        grey.convertTo(grey, CV_32F);
        for (int y = 0; y < measured.rows; ++y)
            for (int x = 0; x < measured.cols; ++x)
                measured.at<float>(y, x) = is_finite_point(view.points.at<cv::Vec3f>(y + area.y, x + area.x)) ? 1.f : 0.f;
        cv::Mat local_sum, local_count;
        cv::GaussianBlur(grey.mul(measured), local_sum, cv::Size(), sigma_px);
        cv::GaussianBlur(measured, local_count, cv::Size(), sigma_px);
        paint = cv::Mat(grey / cv::max(local_sum / cv::max(local_count, 1e-3), 1.0))(measured_area - area.tl());
    }
    std::unordered_set<GridCell, GridCellHash> taken;
    for (int y = measured_area.y; y < measured_area.y + measured_area.height; ++y) {
        const cv::Vec3f* row = view.points.ptr<cv::Vec3f>(y);
        for (int x = measured_area.x; x < measured_area.x + measured_area.width; ++x) {
            if (!is_finite_point(row[x])) continue;
            cv::Vec3d normal(0, 0, -1);
            if (has_normals) {
                const cv::Vec3f n = view.normals.at<cv::Vec3f>(y, x);
                if (!is_finite_point(n) || cv::norm(n) < 0.5) continue;
                normal = cv::normalize(cv::Vec3d(n));
            }
            if (!taken.insert(grid_cell(cv::Vec3d(row[x]), spacing_mm)).second) continue;
            samples.points.emplace_back(row[x]);
            samples.normals.push_back(normal);
            if (!paint.empty()) samples.grey.push_back(paint.at<float>(y - measured_area.y, x - measured_area.x));
        }
    }
    return samples;
}

SurfaceSamples transformed(const SurfaceSamples& samples, const cv::Matx44d& transform) {
    const cv::Matx33d rotation = transform.get_minor<3, 3>(0, 0);
    const cv::Vec3d translation(transform(0, 3), transform(1, 3), transform(2, 3));
    SurfaceSamples out;
    out.points.reserve(samples.points.size());
    out.normals.reserve(samples.normals.size());
    out.grey = samples.grey;
    for (size_t i = 0; i < samples.points.size(); ++i) {
        out.points.push_back(rotation * samples.points[i] + translation);
        out.normals.push_back(rotation * samples.normals[i]);
    }
    return out;
}

namespace {

// Cells beyond +-2^40 along an axis share the last one (NaN the upper one): converting a
// larger value to long long is undefined (a pose or a cloud can put points anywhere), and
// differences of clamped cells cannot overflow. Clamping keeps the order of cells, so the
// cells a search visits still hold every point in reach, only with more of them.
long long clamped_cell(double coordinate, double cell_mm) {
    constexpr double kLastCell = 1099511627776.0;  // 2^40
    const double cell = std::floor(coordinate / cell_mm);
    if (!(cell < kLastCell)) return static_cast<long long>(kLastCell);  // NaN too
    return static_cast<long long>(std::max(cell, -kLastCell));
}

}  // namespace

GridCell grid_cell(const cv::Vec3d& p, double cell_mm) {
    return {clamped_cell(p[0], cell_mm), clamped_cell(p[1], cell_mm), clamped_cell(p[2], cell_mm)};
}

size_t GridCellHash::operator()(const GridCell& cell) const {
    // Each coordinate times its own odd constant, then mixed (the finaliser of MurmurHash3's
    // 64-bit hash), so that neighbouring cells spread over the whole table.
    unsigned long long h = static_cast<unsigned long long>(cell[0]) * 0x9E3779B97F4A7C15ULL ^
                           static_cast<unsigned long long>(cell[1]) * 0xC2B2AE3D27D4EB4FULL ^
                           static_cast<unsigned long long>(cell[2]) * 0x165667B19E3779F9ULL;
    h ^= h >> 33;
    h *= 0xFF51AFD7ED558CCDULL;
    h ^= h >> 33;
    return static_cast<size_t>(h);
}

PointGrid::PointGrid(const std::vector<cv::Vec3d>& points, double cell_mm) : cell_mm_(cell_mm) {
    std::vector<std::pair<GridCell, int>> keyed(points.size());
    for (size_t i = 0; i < points.size(); ++i) keyed[i] = {grid_cell(points[i], cell_mm_), static_cast<int>(i)};
    // By cell, then index: each cell's points in input order.
    std::sort(keyed.begin(), keyed.end(), [](const std::pair<GridCell, int>& a, const std::pair<GridCell, int>& b) {
        const GridCell &p = a.first, &q = b.first;
        return std::tie(p[0], p[1], p[2], a.second) < std::tie(q[0], q[1], q[2], b.second);
    });
    sorted_.reserve(points.size());
    index_.reserve(points.size());
    size_t cells = 0;
    for (size_t i = 0; i < keyed.size(); ++i) {
        if (i == 0 || keyed[i].first != keyed[i - 1].first) ++cells;
        sorted_.push_back(points[static_cast<size_t>(keyed[i].second)]);
        index_.push_back(keyed[i].second);
    }
    size_t size = 16;
    while (size < 2 * cells) size *= 2;
    table_.assign(size, Cell{});
    mask_ = size - 1;
    for (size_t i = 0; i < keyed.size();) {
        size_t end = i;
        while (end < keyed.size() && keyed[end].first == keyed[i].first) ++end;
        size_t slot = GridCellHash()(keyed[i].first) & mask_;
        while (table_[slot].begin >= 0) slot = (slot + 1) & mask_;
        table_[slot] = {keyed[i].first, static_cast<int>(i), static_cast<int>(end)};
        i = end;
    }
}

const PointGrid::Cell* PointGrid::find(const GridCell& at) const {
    for (size_t slot = GridCellHash()(at) & mask_;; slot = (slot + 1) & mask_) {
        const Cell& cell = table_[slot];
        if (cell.begin < 0) return nullptr;
        if (cell.at == at) return &cell;
    }
}

int PointGrid::nearest(const cv::Vec3d& query, double max_distance_mm) const {
    double best = max_distance_mm * max_distance_mm;
    int best_index = -1;
    visit_near(query, max_distance_mm, [&](const cv::Vec3d& point, int index) {
        const cv::Vec3d d = point - query;
        const double distance = d.dot(d);
        if (distance < best) {
            best = distance;
            best_index = index;
        }
    });
    return best_index;
}

void PointGrid::within(const cv::Vec3d& query, double radius_mm, std::vector<int>& found) const {
    found.clear();
    const double limit = radius_mm * radius_mm;
    visit_near(query, radius_mm, [&](const cv::Vec3d& point, int index) {
        const cv::Vec3d d = point - query;
        if (d.dot(d) <= limit) found.push_back(index);
    });
}

NearestGrid::NearestGrid(const std::vector<cv::Vec3d>& all_points, double cell_mm) : cell_mm_(cell_mm) {
    // A point with an infinite or NaN coordinate is never within reach of a query, and no cell
    // size would bring it into the box below: it is left out.
    std::vector<cv::Vec3d> points;
    std::vector<int> numbers;  // index in all_points of each of `points`
    for (size_t i = 0; i < all_points.size(); ++i)
        if (std::isfinite(all_points[i][0]) && std::isfinite(all_points[i][1]) && std::isfinite(all_points[i][2])) {
            points.push_back(all_points[i]);
            numbers.push_back(static_cast<int>(i));
        }
    if (points.empty()) return;
    // A box stretched by stray points takes larger cells (the same points are found, by more
    // distance tests), so the table stays within a few entries per point.
    const double max_cells = 32.0 * static_cast<double>(points.size()) + 65536;
    std::vector<cv::Vec<long long, 3>> cells(points.size());
    for (;;) {
        cv::Vec<long long, 3> last;
        for (size_t i = 0; i < points.size(); ++i) {
            cells[i] = grid_cell(points[i], cell_mm_);
            for (int a = 0; a < 3; ++a) {
                first_[a] = i == 0 ? cells[i][a] : std::min(first_[a], cells[i][a]);
                last[a] = i == 0 ? cells[i][a] : std::max(last[a], cells[i][a]);
            }
        }
        for (int a = 0; a < 3; ++a) size_[a] = last[a] - first_[a] + 1;
        if (static_cast<double>(size_[0]) * static_cast<double>(size_[1]) * static_cast<double>(size_[2]) <= max_cells) break;
        cell_mm_ *= 2;
    }
    auto number = [&](const cv::Vec<long long, 3>& c) {
        return static_cast<size_t>(((c[0] - first_[0]) * size_[1] + (c[1] - first_[1])) * size_[2] + (c[2] - first_[2]));
    };
    // Counting sort by cell; each cell's points stay in input order.
    start_.assign(static_cast<size_t>(size_[0] * size_[1] * size_[2]) + 1, 0);
    for (const cv::Vec<long long, 3>& c : cells) ++start_[number(c) + 1];
    for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    std::vector<int> next(start_.begin(), start_.end() - 1);
    sorted_.resize(points.size());
    index_.resize(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
        const int at = next[number(cells[i])]++;
        sorted_[static_cast<size_t>(at)] = points[i];
        index_[static_cast<size_t>(at)] = numbers[i];
    }
}

int NearestGrid::nearest(const cv::Vec3d& query, double max_distance_mm) const {
    double best_squared = 0, clearance_mm = 0;
    const int slot = search(query, max_distance_mm, best_squared, clearance_mm);
    return slot >= 0 ? index_[static_cast<size_t>(slot)] : -1;
}

int NearestGrid::nearest_remembered(const cv::Vec3d& query, double max_distance_mm, SearchMemory& memory) const {
    constexpr double hair_mm = 1e-9;  // far above rounding: the bounds never leave out a point in reach
    const double moved = cv::norm(query - memory.at);
    double radius = max_distance_mm;
    if (memory.nearest < 0) {
        // Nothing lay within clear_mm of `at`, so nothing lies within clear_mm - moved of the query.
        if (memory.clear_mm - moved - hair_mm >= max_distance_mm) return -1;
    } else {
        // Every other point lies at least clear_mm - moved from the query.
        const double to_nearest = cv::norm(query - sorted_[static_cast<size_t>(memory.nearest)]);
        if (to_nearest + moved + hair_mm < memory.clear_mm) {
            if (to_nearest + hair_mm < max_distance_mm) return index_[static_cast<size_t>(memory.nearest)];
            if (to_nearest - hair_mm >= max_distance_mm) return -1;
        }
        radius = std::min(max_distance_mm, to_nearest);  // the nearest is no farther than the last one
    }
    double best_squared = 0;
    const int slot = search(query, radius + kMarginMm, best_squared, memory.clear_mm);
    memory.nearest = slot;
    memory.at = query;
    // The same test as PointGrid::nearest's: the squared distance below the squared bound.
    return slot >= 0 && best_squared < max_distance_mm * max_distance_mm ? index_[static_cast<size_t>(slot)] : -1;
}

int NearestGrid::search(const cv::Vec3d& query, double radius_mm, double& best_squared, double& clearance_mm) const {
    double best = radius_mm * radius_mm, second = best;
    int best_slot = -1;
    best_squared = best;
    clearance_mm = radius_mm;
    if (sorted_.empty()) return -1;
    // The cells the cube of half-side radius_mm around the query touches, and the same strict
    // comparison, as PointGrid::nearest: the same point (ties included) is found. Every point
    // in reach is visited, so the runner-up bounds the rest.
    const double margin = radius_mm + 1e-9;
    const cv::Vec<long long, 3> low_cell = grid_cell(query - cv::Vec3d::all(margin), cell_mm_), high_cell = grid_cell(query + cv::Vec3d::all(margin), cell_mm_);
    long long low[3], high[3];
    for (int a = 0; a < 3; ++a) {
        low[a] = std::max(low_cell[a] - first_[a], 0LL);
        high[a] = std::min(high_cell[a] - first_[a], size_[a] - 1);
        if (low[a] > high[a]) return -1;
    }
    for (long long x = low[0]; x <= high[0]; ++x)
        for (long long y = low[1]; y <= high[1]; ++y) {
            const size_t row = static_cast<size_t>((x * size_[1] + y) * size_[2]);
            const int end = start_[row + static_cast<size_t>(high[2]) + 1];
            for (int k = start_[row + static_cast<size_t>(low[2])]; k < end; ++k) {
                const cv::Vec3d d = sorted_[static_cast<size_t>(k)] - query;
                const double distance = d.dot(d);
                if (distance < best) {
                    second = best;
                    best = distance;
                    best_slot = k;
                } else if (distance < second) {
                    second = distance;
                }
            }
        }
    best_squared = best;
    clearance_mm = std::sqrt(second);
    return best_slot;
}

}  // namespace picoscan::detail
