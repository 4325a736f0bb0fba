// Plane cuts of a triangle mesh: every triangle whose vertices lie on both sides gives a segment
// between two of its edges; segments meeting on the same mesh edge are chained into polylines.
#include "cloud/view_check.h"
#include "common/text_format.h"
#include "picoscan/error.h"
#include "picoscan/section_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <unordered_map>

namespace picoscan {

namespace {

struct PositionHash {
    size_t operator()(const cv::Vec3f& p) const {
        uint32_t bits[3];
        std::memcpy(bits, p.val, sizeof bits);
        return (size_t(bits[0]) * 73856093u) ^ (size_t(bits[1]) * 19349663u) ^ (size_t(bits[2]) * 83492791u);
    }
};

uint64_t edge_key(int a, int b) { return (uint64_t(std::min(a, b)) << 32) | uint64_t(std::max(a, b)); }

// A mesh of millions of triangles takes seconds per cut: a cancel point every 65 536 vertices and
// triangles, with the fraction of all the work (`total` items) done.
class CutProgress {
public:
    CutProgress(const ProgressCallback& progress, double total) : progress_(progress), total_(total + 1) {}
    void step(const char* stage) {
        if (progress_ && done_ % 65536 == 0 && !progress_(double(done_) / total_, stage))
            throw Error("cancelled", std::string(stage) + " was stopped");
        ++done_;
    }

private:
    const ProgressCallback& progress_;
    double total_;
    size_t done_ = 0;
};

// The mesh with its vertices welded by position, so that triangles are joined across shared edges.
struct WeldedMesh {
    std::vector<cv::Vec3d> vertices;
    std::vector<cv::Vec3i> faces;  // indices into `vertices`
};

WeldedMesh weld(const Mesh& mesh, CutProgress& progress) {
    WeldedMesh welded;
    std::unordered_map<cv::Vec3f, int, PositionHash> index_of;
    std::vector<int> welded_index(mesh.vertices.size());
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        progress.step("cutting the mesh");
        // A NaN or infinite vertex cuts nowhere (its mesh was reported as "not cut by the plane");
        // beyond 1 km a float vertex is coarser than 0.06 mm, and the fit's run counts overflow.
        const cv::Vec3f& p = mesh.vertices[i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
            throw Error("mesh", "vertex " + std::to_string(i) + " is not a finite point (NaN or infinite): not a mesh of a part");
        if (detail::beyond_reach(p))
            throw Error("mesh", "vertex " + std::to_string(i) + " lies " + format("%.3g", cv::norm(cv::Vec3d(p))) +
                                    " mm from the origin, beyond 1 km: too far to cut at the vertices' precision; bring the "
                                    "mesh near the origin");
        const auto inserted = index_of.emplace(mesh.vertices[i], int(welded.vertices.size()));
        if (inserted.second) welded.vertices.emplace_back(mesh.vertices[i]);
        welded_index[i] = inserted.first->second;
    }
    welded.faces.reserve(mesh.faces.size());
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        cv::Vec3i face;
        for (int k = 0; k < 3; ++k) {
            const int index = mesh.faces[f][k];
            if (index < 0 || size_t(index) >= mesh.vertices.size())
                throw Error("mesh", "triangle " + std::to_string(f) + " uses vertex " + std::to_string(index) + " of " +
                                        std::to_string(mesh.vertices.size()));
            face[k] = welded_index[size_t(index)];
        }
        welded.faces.push_back(face);
    }
    return welded;
}

std::string format_mm(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.2f mm", value);
    return text;
}

void check_axes(const cv::Vec3d& u_axis, const cv::Vec3d& v_axis) {
    if (std::abs(cv::norm(u_axis) - 1) > 1e-9) throw Error("u_axis", "must be a unit vector");
    if (std::abs(cv::norm(v_axis) - 1) > 1e-9 || std::abs(u_axis.dot(v_axis)) > 1e-9)
        throw Error("v_axis", "must be a unit vector perpendicular to u_axis");
}

// The cut of the welded mesh by the plane through `origin` spanned by the (orthonormal) axes.
// A vertex exactly on the plane counts as above it, so every crossing is on an edge's interior.
std::vector<SectionPolyline> cut_welded(const WeldedMesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis,
                                        const cv::Vec3d& v_axis, CutProgress& progress, const char* stage) {
    const cv::Vec3d normal = u_axis.cross(v_axis);
    std::vector<double> height(mesh.vertices.size());
    for (size_t i = 0; i < mesh.vertices.size(); ++i) height[i] = (mesh.vertices[i] - origin).dot(normal);
    const auto above = [&](int v) { return height[size_t(v)] >= 0; };

    // Segments, each between two crossed edges; per crossed edge, the segments that end on it.
    std::vector<std::pair<uint64_t, uint64_t>> segments;
    std::unordered_map<uint64_t, cv::Vec2d> crossing;
    std::unordered_map<uint64_t, std::vector<size_t>> segments_at;
    for (const cv::Vec3i& v : mesh.faces) {
        progress.step(stage);
        uint64_t ends[2];
        int found = 0;
        for (int k = 0; k < 3 && found < 2; ++k) {
            const int a = v[k], b = v[(k + 1) % 3];
            if (a == b || above(a) == above(b)) continue;
            const uint64_t key = edge_key(a, b);
            if (!crossing.count(key)) {
                const double t = height[size_t(a)] / (height[size_t(a)] - height[size_t(b)]);
                const cv::Vec3d p = mesh.vertices[size_t(a)] + t * (mesh.vertices[size_t(b)] - mesh.vertices[size_t(a)]) - origin;
                crossing[key] = {p.dot(u_axis), p.dot(v_axis)};
            }
            // Each segment runs from the edge the winding crosses downwards to the one it crosses
            // upwards: around the material counter-clockwise seen from the plane's normal.
            ends[above(a) ? 0 : 1] = key;
            ++found;
        }
        if (found != 2) continue;
        segments_at[ends[0]].push_back(segments.size());
        segments_at[ends[1]].push_back(segments.size());
        segments.emplace_back(ends[0], ends[1]);
    }

    // Chains: from the edges with one segment (open ends) first, then the remaining loops.
    std::vector<bool> used(segments.size(), false);
    std::vector<SectionPolyline> result;
    const auto walk = [&](uint64_t start) {
        SectionPolyline line;
        uint64_t at = start;
        line.points.push_back(crossing[at]);
        long along = 0;  // segments walked their own way minus those walked against it
        while (true) {
            size_t next = segments.size();
            for (const size_t s : segments_at[at])
                if (!used[s]) {
                    next = s;
                    break;
                }
            if (next == segments.size()) break;
            used[next] = true;
            along += segments[next].first == at ? 1 : -1;
            at = segments[next].first == at ? segments[next].second : segments[next].first;
            if (at == start) {
                line.closed = true;
                break;
            }
            line.points.push_back(crossing[at]);
        }
        if (along < 0) std::reverse(line.points.begin(), line.points.end());  // the way its triangles run
        if (line.points.size() > 1) result.push_back(std::move(line));
    };
    for (const auto& [key, list] : segments_at)
        if (list.size() == 1 && !used[list[0]]) walk(key);
    for (size_t s = 0; s < segments.size(); ++s)
        if (!used[s]) walk(segments[s].first);
    return result;
}

}  // namespace

std::vector<SectionPolyline> cut_mesh(const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis,
                                      const cv::Vec3d& v_axis, const ProgressCallback& progress) {
    CutProgress steps(progress, double(mesh.vertices.size() + mesh.faces.size()));
    check_axes(u_axis, v_axis);
    return cut_welded(weld(mesh, steps), origin, u_axis, v_axis, steps, "cutting the mesh");
}

std::vector<double> section_band_offsets(double band_mm) {
    if (!std::isfinite(band_mm) || band_mm < 0)
        throw Error("band_mm", "must be 0 (one cut) or positive, is " + std::to_string(band_mm) + " mm");
    std::vector<double> offsets;
    for (int step = 0; step <= kSectionBandCuts && band_mm > 0; ++step)
        if (step != kSectionBandCuts / 2) offsets.push_back(band_mm * (2.0 * step / kSectionBandCuts - 1.0));
    return offsets;
}

MeshSection cut_mesh_section(const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis, const cv::Vec3d& v_axis,
                             double band_mm, const ProgressCallback& progress) {
    const std::vector<double> offsets = section_band_offsets(band_mm);
    check_axes(u_axis, v_axis);
    CutProgress steps(progress, double(mesh.vertices.size() + (offsets.size() + 1) * mesh.faces.size()));
    const WeldedMesh welded = weld(mesh, steps);
    MeshSection section;
    section.polylines = cut_welded(welded, origin, u_axis, v_axis, steps, "cutting the mesh");
    if (section.polylines.empty()) {
        // Where the mesh lies, for the user to move the plane there.
        const cv::Vec3d normal = u_axis.cross(v_axis);
        double low = HUGE_VAL, high = -HUGE_VAL;
        for (const cv::Vec3d& v : welded.vertices) {
            low = std::min(low, (v - origin).dot(normal));
            high = std::max(high, (v - origin).dot(normal));
        }
        throw Error("plane", welded.vertices.empty() ? std::string("does not cut the mesh: it is empty")
                                                     : "does not cut the mesh: the mesh lies from " + format_mm(low) +
                                                           " to " + format_mm(high) + " from it along its normal");
    }
    if (std::all_of(section.polylines.begin(), section.polylines.end(),
                    [](const SectionPolyline& line) { return line.points.size() < 4; }))
        throw Error("plane", "only grazes the mesh (no polyline of 4 points or more: a few facets touched)");
    for (const double offset : offsets)
        for (SectionPolyline& line : cut_welded(welded, origin + offset * u_axis.cross(v_axis), u_axis, v_axis, steps,
                                                "parallel cuts"))
            section.parallel_cuts.push_back({offset, std::move(line.points)});
    return section;
}

}  // namespace picoscan
