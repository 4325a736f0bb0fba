// Plane cut of a triangle mesh: every triangle whose vertices lie on both sides gives a segment
// between two of its edges; segments meeting on the same mesh edge are chained into polylines.
// A vertex exactly on the plane counts as above it, so every crossing is on an edge's interior.
#include "picoscan/error.h"
#include "picoscan/section_fit.h"

#include <cmath>
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

}  // namespace

std::vector<SectionPolyline> cut_mesh(const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis,
                                      const cv::Vec3d& v_axis, const ProgressCallback& progress) {
    // A mesh of millions of triangles takes seconds: a cancel point every 65 536 vertices and triangles.
    const double work = double(mesh.vertices.size() + mesh.faces.size()) + 1;
    const auto report = [&](size_t done) {
        if (progress && done % 65536 == 0 && !progress(double(done) / work, "cutting the mesh"))
            throw Error("cancelled", "cutting the mesh was stopped");
    };
    if (std::abs(cv::norm(u_axis) - 1) > 1e-9) throw Error("u_axis", "must be a unit vector");
    if (std::abs(cv::norm(v_axis) - 1) > 1e-9 || std::abs(u_axis.dot(v_axis)) > 1e-9)
        throw Error("v_axis", "must be a unit vector perpendicular to u_axis");
    const cv::Vec3d normal = u_axis.cross(v_axis);

    // Welded vertices and their side of the plane.
    std::unordered_map<cv::Vec3f, int, PositionHash> index_of;
    std::vector<int> welded(mesh.vertices.size());
    std::vector<cv::Vec3d> vertices;
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        report(i);
        const auto inserted = index_of.emplace(mesh.vertices[i], int(vertices.size()));
        if (inserted.second) vertices.emplace_back(mesh.vertices[i]);
        welded[i] = inserted.first->second;
    }
    std::vector<double> height(vertices.size());
    for (size_t i = 0; i < vertices.size(); ++i) height[i] = (vertices[i] - origin).dot(normal);
    const auto above = [&](int v) { return height[size_t(v)] >= 0; };

    // Segments, each between two crossed edges; per crossed edge, the segments that end on it.
    std::vector<std::pair<uint64_t, uint64_t>> segments;
    std::unordered_map<uint64_t, cv::Vec2d> crossing;
    std::unordered_map<uint64_t, std::vector<size_t>> segments_at;
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
        report(mesh.vertices.size() + f);
        int v[3];
        for (int k = 0; k < 3; ++k) {
            const int index = mesh.faces[f][k];
            if (index < 0 || size_t(index) >= mesh.vertices.size())
                throw Error("mesh", "triangle " + std::to_string(f) + " uses vertex " + std::to_string(index) + " of " +
                                        std::to_string(mesh.vertices.size()));
            v[k] = welded[size_t(index)];
        }
        uint64_t ends[2];
        int found = 0;
        for (int k = 0; k < 3 && found < 2; ++k) {
            const int a = v[k], b = v[(k + 1) % 3];
            if (a == b || above(a) == above(b)) continue;
            const uint64_t key = edge_key(a, b);
            if (!crossing.count(key)) {
                const double t = height[size_t(a)] / (height[size_t(a)] - height[size_t(b)]);
                const cv::Vec3d p = vertices[size_t(a)] + t * (vertices[size_t(b)] - vertices[size_t(a)]) - origin;
                crossing[key] = {p.dot(u_axis), p.dot(v_axis)};
            }
            ends[found++] = key;
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
        while (true) {
            size_t next = segments.size();
            for (const size_t s : segments_at[at])
                if (!used[s]) {
                    next = s;
                    break;
                }
            if (next == segments.size()) break;
            used[next] = true;
            at = segments[next].first == at ? segments[next].second : segments[next].first;
            if (at == start) {
                line.closed = true;
                break;
            }
            line.points.push_back(crossing[at]);
        }
        if (line.points.size() > 1) result.push_back(std::move(line));
    };
    for (const auto& [key, list] : segments_at)
        if (list.size() == 1 && !used[list[0]]) walk(key);
    for (size_t s = 0; s < segments.size(); ++s)
        if (!used[s]) walk(segments[s].first);
    return result;
}

}  // namespace picoscan
