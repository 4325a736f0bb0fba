// OpenCASCADE's BREP text format (the "CASCADE Topology V1" layout that BRepTools::Read and
// FreeCAD's Part.Shape.read accept): lines and circles, planes, cylinders and cones, then the topology
// from vertices up to the solid; each face's triangles as its triangulation, each edge's chain of mesh vertices as its
// polygon on those triangulations, and each edge's line on each face's plane as a 2D line (its
// pcurve: without it, the mesher FreeCAD's view provider runs on every shape it draws projects
// each edge onto each plane itself; docs/benchmarks.md has the figures). Shapes refer to each
// other by their place counted from the end of the list.
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/solid.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

namespace picoscan {

namespace {

template <typename... Values>
void append(std::string& out, const char* format, Values... values) {
    char buffer[512];
    const int length = std::snprintf(buffer, sizeof buffer, format, values...);
    out.append(buffer, size_t(length));
}

// A face's surface as written: origin, normal (a cylinder's or cone's axis) and the directions x and
// y; a plane's (u, v) are along x and y, a cylinder's u the angle from x towards y, v along the axis,
// a cone's v along its slant line (its height over the cosine of its half-angle).
struct SurfaceFrame {
    cv::Vec3d origin, normal, x, y;
    double radius = 0;      // > 0: a cylinder, or a cone's radius at origin
    double semi_angle = 0;  // != 0: a cone
    cv::Vec2d uv(const cv::Vec3d& p) const { return {(p - origin).dot(x), (p - origin).dot(y)}; }
    cv::Vec3d at(const cv::Vec2d& uv) const { return origin + uv[0] * x + uv[1] * y; }
};

SurfaceFrame frame_of(const BrepFace& face) {
    const cv::Vec3d n = cv::normalize(face.normal);
    if (face.radius_mm > 0) {
        const cv::Vec3d x = cv::normalize(face.x_axis);
        return {face.origin, n, x, n.cross(x), face.radius_mm, face.semi_angle_rad};
    }
    const cv::Vec3d helper = std::abs(n[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
    const cv::Vec3d x = cv::normalize(helper - helper.dot(n) * n);
    return {face.origin, n, x, n.cross(x)};
}

constexpr double kTwoPi = 6.28318530717958647692;

// An edge's end of parameter: a line's length, a circle's full turn.
double parameter_end(const PlanarFaceModel& model, const BrepEdge& edge) {
    return edge.radius_mm > 0 ? kTwoPi : cv::norm(model.vertices[size_t(edge.end)] - model.vertices[size_t(edge.start)]);
}

// An edge's pcurve on a plane: the 2D line through its start with its direction projected, both
// in the plane's (u, v), parameterised like the edge's line (by length). None when the edge's line
// strays from it by more than the edge's tolerance (the distance is affine in the parameter, so
// largest at an end): then OpenCASCADE projects the edge itself, as without pcurves.
std::optional<std::string> line_on_plane(const SurfaceFrame& plane, const cv::Vec3d& a, const cv::Vec3d& b, double tolerance) {
    const double length = cv::norm(b - a);
    const cv::Vec3d direction = (b - a) / length;
    const cv::Vec2d along(direction.dot(plane.x), direction.dot(plane.y));
    if (cv::norm(along) < 0.5) return std::nullopt;  // the edge runs steeply out of the plane
    const cv::Vec2d start = plane.uv(a), unit = along / cv::norm(along);
    const double deviation = std::max(cv::norm(plane.at(start) - a), cv::norm(plane.at(start + length * unit) - b));
    if (!(deviation <= tolerance)) return std::nullopt;  // NaN too (an edge of no length)
    std::string text;
    append(text, "1 %.17g %.17g %.17g %.17g\n", start[0], start[1], unit[0], unit[1]);
    return text;
}

// A circle's pcurve on a plane (nearly) square to its axis: the circle seen along the plane's
// normal, its angle measured from its x axis as in 3D (the 2D axes turn the other way when the
// plane faces against the circle's axis).
std::string circle_on_plane(const SurfaceFrame& plane, const BrepEdge& circle) {
    const cv::Vec3d y3 = cv::normalize(circle.axis).cross(cv::normalize(circle.x_axis));
    const cv::Vec2d centre = plane.uv(circle.center);
    const cv::Vec2d x = cv::normalize(cv::Vec2d(circle.x_axis.dot(plane.x), circle.x_axis.dot(plane.y)));
    const cv::Vec2d y_seen(y3.dot(plane.x), y3.dot(plane.y));
    const cv::Vec2d square(-x[1], x[0]), y = y_seen.dot(square) >= 0 ? square : -square;
    std::string text;
    append(text, "2 %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", centre[0], centre[1], x[0], x[1], y[0], y[1], circle.radius_mm);
    return text;
}

// An edge's pcurves on a cylinder or cone (u: angle, v: along the axis, a cone's along its slant
// line): a circle about its axis, at the same seam angle, is the line v = its level; the seam (met
// twice) is the line u = 2 pi as run forwards and u = 0 backwards (a cone's seam is its slant line,
// whose length is v's, so both run at unit speed).
std::vector<std::string> curves_on_cylinder(const PlanarFaceModel& model, const SurfaceFrame& cylinder, const BrepEdge& edge,
                                            bool seam, const std::string& path) {
    std::string first, second;
    if (edge.radius_mm > 0) {
        if (std::abs(cv::normalize(edge.axis).dot(cylinder.normal) - 1) > 1e-9 ||
            std::abs(cv::normalize(edge.x_axis).dot(cylinder.x) - 1) > 1e-9 || seam)
            throw Error(path, "a circle on a cylindrical face does not share its axis and seam");
        append(first, "1 0 %.17g 1 0\n", (edge.center - cylinder.origin).dot(cylinder.normal) / std::cos(cylinder.semi_angle));
        return {first};
    }
    if (!seam) throw Error(path, "a straight edge on a cylindrical face is not its seam");
    const cv::Vec3d a = model.vertices[size_t(edge.start)], b = model.vertices[size_t(edge.end)];
    const double up = (b - a).dot(cylinder.normal) >= 0 ? 1 : -1,
                 v = (a - cylinder.origin).dot(cylinder.normal) / std::cos(cylinder.semi_angle);
    append(first, "1 %.17g %.17g 0 %g\n", kTwoPi, v, up);
    append(second, "1 0 %.17g 0 %g\n", v, up);
    return {first, second};
}

}  // namespace

void write_brep(const PlanarFaceModel& model, const std::string& path, const ProgressCallback& progress) {
    if (model.faces.empty()) throw Error(path, "no faces to write");
    const size_t face_count = model.faces.size(), edge_count = model.edges.size();
    // Each face's triangulation numbers its own nodes: the vertices of its triangles, sorted.
    std::vector<std::vector<int>> nodes(face_count);
    std::vector<size_t> triangulation_of(face_count, 0);  // 1-based; 0: none
    std::vector<std::vector<size_t>> faces_of_edge(edge_count);  // the faces with a triangulation along each edge
    size_t triangulation_count = 0, polygon_count = 0;
    for (size_t f = 0; f < face_count; ++f) {
        const BrepFace& face = model.faces[f];
        if (face.triangles.empty()) continue;
        for (const cv::Vec3i& triangle : face.triangles)
            for (int k = 0; k < 3; ++k) {
                if (triangle[k] < 0 || size_t(triangle[k]) >= model.vertices.size())
                    throw Error(path, "face " + std::to_string(f) + " has a triangle corner out of range");
                nodes[f].push_back(triangle[k]);
            }
        std::sort(nodes[f].begin(), nodes[f].end());
        nodes[f].erase(std::unique(nodes[f].begin(), nodes[f].end()), nodes[f].end());
        triangulation_of[f] = ++triangulation_count;
        for (const auto& wire : face.wires)
            for (int e : wire) faces_of_edge[size_t(std::abs(e) - 1)].push_back(f), ++polygon_count;
    }
    // Each edge's pcurves on each face along it: on a plane a line (once per face: an edge met
    // twice in one plane gets none) or a circle, on a cylinder one line, or two for its seam.
    std::vector<SurfaceFrame> surfaces;
    for (const BrepFace& face : model.faces) surfaces.push_back(frame_of(face));
    std::vector<std::vector<std::pair<size_t, std::vector<std::string>>>> pcurves_of_edge(edge_count);
    size_t pcurve_count = 0;
    for (size_t f = 0; f < face_count; ++f) {
        std::vector<size_t> edges;
        for (const auto& wire : model.faces[f].wires)
            for (int e : wire) edges.push_back(size_t(std::abs(e) - 1));
        std::sort(edges.begin(), edges.end());
        for (size_t i = 0; i < edges.size(); ++i) {
            const size_t e = edges[i];
            if (e >= edge_count) throw Error(path, "face " + std::to_string(f) + " refers to a missing edge");
            if (i > 0 && edges[i - 1] == e) continue;
            const bool twice = i + 1 < edges.size() && edges[i + 1] == e;
            const BrepEdge& edge = model.edges[e];
            std::vector<std::string> curves;
            if (surfaces[f].radius > 0) {
                curves = curves_on_cylinder(model, surfaces[f], edge, twice, path);
            } else if (edge.radius_mm > 0) {
                if (!model.faces[f].triangles.empty())
                    throw Error(path, "face " + std::to_string(f) + " has a circle among its edges and a triangulation");
                curves = {circle_on_plane(surfaces[f], edge)};
            } else if (!twice) {
                if (const auto line = line_on_plane(surfaces[f], model.vertices[size_t(edge.start)],
                                                    model.vertices[size_t(edge.end)], edge.tolerance_mm))
                    curves = {*line};
            }
            if (curves.empty()) continue;
            pcurve_count += curves.size();
            pcurves_of_edge[e].emplace_back(f, curves);
        }
    }
    auto node_number = [&](size_t f, int vertex) {
        const auto found = std::lower_bound(nodes[f].begin(), nodes[f].end(), vertex);
        if (found == nodes[f].end() || *found != vertex)
            throw Error(path, "an edge of face " + std::to_string(f) + " runs through a vertex none of its triangles has");
        return size_t(found - nodes[f].begin()) + 1;
    };

    // Tens of thousands of faces take seconds to format: a cancel point every 4096 shapes.
    const double work = double(model.vertices.size() + 3 * edge_count + 3 * face_count) + 1;
    size_t written = 0;
    const auto wrote = [&] {
        if (progress && ++written % 4096 == 0 && !progress(double(written) / work, "solid: writing the B-rep"))
            throw Error("cancelled", "writing the B-rep was stopped");
    };
    std::string out;
    out.reserve(edge_count * 400 + face_count * 500 + model.vertices.size() * 90);
    out += "DBRep_DrawableShape\n\nCASCADE Topology V1, (c) Matra-Datavision\nLocations 0\n";
    append(out, "Curve2ds %zu\n", pcurve_count);
    std::vector<size_t> first_pcurve(edge_count, 0);
    size_t pcurves = 0;
    for (size_t e = 0; e < edge_count; ++e) {
        first_pcurve[e] = pcurves + 1;
        for (const auto& on_face : pcurves_of_edge[e])
            for (const std::string& curve : on_face.second) out += curve, ++pcurves;
    }
    append(out, "Curves %zu\n", edge_count);
    for (const BrepEdge& edge : model.edges) {
        wrote();
        if (edge.radius_mm > 0) {  // centre, axis, x, y, radius
            const cv::Vec3d &c = edge.center, n = cv::normalize(edge.axis), x = cv::normalize(edge.x_axis), y = n.cross(x);
            append(out, "2 %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", c[0], c[1], c[2],
                   n[0], n[1], n[2], x[0], x[1], x[2], y[0], y[1], y[2], edge.radius_mm);
            continue;
        }
        const cv::Vec3d a = model.vertices[edge.start], direction = cv::normalize(model.vertices[edge.end] - a);
        append(out, "1 %.17g %.17g %.17g %.17g %.17g %.17g\n", a[0], a[1], a[2], direction[0], direction[1], direction[2]);
    }
    out += "Polygon3D 0\n";
    // Each edge's chain on the triangulation of each face along it: node numbers, then its
    // deflection (the chain's farthest vertex from its point on the edge's line) and each node's
    // parameter on the line (its distance along it from the start).
    append(out, "PolygonOnTriangulations %zu\n", polygon_count);
    std::vector<size_t> first_polygon(edge_count, 0);
    size_t polygons = 0;
    for (size_t e = 0; e < edge_count; ++e) {
        wrote();
        const BrepEdge& edge = model.edges[e];
        if (!faces_of_edge[e].empty() && edge.radius_mm > 0)
            throw Error(path, "edge " + std::to_string(e) + " is a circle on a face with a triangulation");
        const std::vector<int> chain = edge.chain.empty() ? std::vector<int>{edge.start, edge.end} : edge.chain;
        if (chain.size() < 2 || chain.front() != edge.start || chain.back() != edge.end)
            throw Error(path, "edge " + std::to_string(e) + ": its chain does not run from its start to its end");
        const cv::Vec3d a = model.vertices[edge.start], b = model.vertices[edge.end];
        const double length = cv::norm(b - a);
        const cv::Vec3d direction = (b - a) / length;
        double deflection = 0;
        std::string parameters;
        for (size_t i = 0; i < chain.size(); ++i) {
            const cv::Vec3d offset = model.vertices[chain[i]] - a;
            const double along = i == 0 ? 0 : i + 1 == chain.size() ? length : std::clamp(offset.dot(direction), 0.0, length);
            // OpenCASCADE's check: each node within deflection + the edge's tolerance of the line's point at its parameter.
            deflection = std::max(deflection, cv::norm(offset - along * direction));
            append(parameters, " %.17g", along);
        }
        first_polygon[e] = polygons + 1;
        for (size_t f : faces_of_edge[e]) {
            append(out, "%zu", chain.size());
            for (int v : chain) append(out, " %zu", node_number(f, v));
            append(out, "\np %.17g 1", deflection);
            out += parameters + "\n";
            ++polygons;
        }
    }
    append(out, "Surfaces %zu\n", face_count);
    for (const SurfaceFrame& surface : surfaces) {  // a plane (1), a cylinder (2, its radius), a cone (3, its radius, half-angle)
        wrote();
        const cv::Vec3d &o = surface.origin, &n = surface.normal, &x = surface.x, &y = surface.y;
        const int type = surface.radius > 0 ? (surface.semi_angle != 0 ? 3 : 2) : 1;
        append(out, "%d %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g", type,
               o[0], o[1], o[2], n[0], n[1], n[2], x[0], x[1], x[2], y[0], y[1], y[2]);
        if (surface.radius > 0) append(out, " %.17g", surface.radius);
        if (type == 3) append(out, " %.17g", surface.semi_angle);
        out += "\n";
    }
    // Each face's triangles with their nodes' (u, v) on its plane; its deflection: the farthest node
    // from the plane. The nodes exact (OpenCASCADE's check holds the edges' polygons on them to the
    // edges' tolerances), (u, v) to 9 digits (only drawn; the reader spends its time on long numbers).
    append(out, "Triangulations %zu\n", triangulation_count);
    for (size_t f = 0; f < face_count; ++f) {
        const BrepFace& face = model.faces[f];
        if (face.triangles.empty()) continue;
        wrote();
        const SurfaceFrame& plane = surfaces[f];
        if (plane.radius > 0) throw Error(path, "face " + std::to_string(f) + " is a cylinder with a triangulation");
        double deflection = 0;
        for (int v : nodes[f]) deflection = std::max(deflection, std::abs((model.vertices[v] - face.origin).dot(plane.normal)));
        append(out, "%zu %zu 1 %.17g\n", nodes[f].size(), face.triangles.size(), deflection);
        for (int v : nodes[f]) {
            const cv::Vec3d& p = model.vertices[v];
            append(out, "%.17g %.17g %.17g\n", p[0], p[1], p[2]);
        }
        for (int v : nodes[f]) {  // (u, v) on the plane: along the surface's x and y directions
            const cv::Vec2d uv = plane.uv(model.vertices[v]);
            append(out, "%.9g %.9g\n", uv[0], uv[1]);
        }
        for (const cv::Vec3i& triangle : face.triangles)
            append(out, "%zu %zu %zu\n", node_number(f, triangle[0]), node_number(f, triangle[1]), node_number(f, triangle[2]));
    }
    out += "\n";

    size_t wire_count = 0;
    for (const BrepFace& face : model.faces) wire_count += face.wires.size();
    const size_t vertex_count = model.vertices.size();
    const size_t total = vertex_count + edge_count + wire_count + face_count + 2;
    append(out, "TShapes %zu\n", total);
    auto vertex_ref = [&](int v) { return total - size_t(v); };
    auto edge_ref = [&](size_t e) { return total - vertex_count - e; };  // e counted from 0
    for (size_t v = 0; v < vertex_count; ++v) {
        wrote();
        const cv::Vec3d& p = model.vertices[v];
        append(out, "Ve\n%.17g\n%.17g %.17g %.17g\n0 0\n\n0101101\n*\n", model.vertex_tolerance_mm[v], p[0], p[1], p[2]);
    }
    for (size_t e = 0; e < edge_count; ++e) {
        wrote();
        const BrepEdge& edge = model.edges[e];
        const double end = parameter_end(model, edge);
        append(out, "Ed\n %.17g 1 1 0\n1  %zu 0 0 %.17g\n", edge.tolerance_mm, e + 1, end);
        size_t pcurve = first_pcurve[e];
        for (const auto& [f, curves] : pcurves_of_edge[e]) {
            if (curves.size() == 1)
                append(out, "2  %zu %zu 0 0 %.17g\n", pcurve, f + 1, end);
            else  // a seam: its pcurve run forwards, then backwards; continuous across it
                append(out, "3  %zu %zu CN %zu 0 0 %.17g\n", pcurve, pcurve + 1, f + 1, end);
            pcurve += curves.size();
        }
        for (size_t i = 0; i < faces_of_edge[e].size(); ++i)
            append(out, "6  %zu %zu 0\n", first_polygon[e] + i, triangulation_of[faces_of_edge[e][i]]);
        append(out, "0\n\n0101000\n+%zu 0 -%zu 0 *\n", vertex_ref(edge.start), vertex_ref(edge.end));
    }
    size_t place = vertex_count + edge_count;  // shapes written so far
    std::vector<size_t> face_refs;
    for (size_t f = 0; f < face_count; ++f) {
        wrote();
        const BrepFace& face = model.faces[f];
        std::string wires;
        for (const auto& wire : face.wires) {
            out += "Wi\n\n0101100\n";
            for (int e : wire) append(out, "%c%zu 0 ", e > 0 ? '+' : '-', edge_ref(size_t(std::abs(e) - 1)));
            out += "*\n";
            append(wires, "+%zu 0 ", total - place++);
        }
        // A face's tolerance may not exceed its edges' (OpenCASCADE's rule: face <= edge <= vertex).
        append(out, "Fa\n0  1e-07 %zu 0\n", f + 1);
        if (triangulation_of[f] > 0) append(out, "2  %zu", triangulation_of[f]);
        out += "\n0101000\n" + wires + "*\n";
        face_refs.push_back(total - place++);
    }
    out += "Sh\n\n0101100\n";
    for (size_t f = 0; f < face_count; ++f) append(out, "%c%zu 0 ", model.faces[f].reversed ? '-' : '+', face_refs[f]);
    out += "*\nSo\n\n1100000\n+2 0 *\n\n+1 0\n";
    write_file_atomically(path, out);
}

}  // namespace picoscan
