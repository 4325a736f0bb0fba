// OpenCASCADE's BREP text format (the "CASCADE Topology V1" layout that BRepTools::Read and
// FreeCAD's Part.Shape.read accept): lines and planes, then the topology from vertices up to
// the solid. Shapes refer to each other by their place counted from the end of the list.
#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/solid.h"

#include <cmath>
#include <cstdio>
#include <string>

namespace picoscan {

namespace {

template <typename... Values>
void append(std::string& out, const char* format, Values... values) {
    char buffer[512];
    const int length = std::snprintf(buffer, sizeof buffer, format, values...);
    out.append(buffer, size_t(length));
}

cv::Vec3d perpendicular(const cv::Vec3d& normal) {
    const cv::Vec3d helper = std::abs(normal[0]) < 0.9 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
    return cv::normalize(helper - helper.dot(normal) * normal);
}

}  // namespace

void write_brep(const PlanarFaceModel& model, const std::string& path, const ProgressCallback& progress) {
    if (model.faces.empty()) throw Error(path, "no faces to write");
    // Tens of thousands of faces take seconds to format: a cancel point every 4096 shapes.
    const double work = double(model.vertices.size() + 2 * model.edges.size() + 2 * model.faces.size()) + 1;
    size_t written = 0;
    const auto wrote = [&] {
        if (progress && ++written % 4096 == 0 && !progress(double(written) / work, "solid: writing the B-rep"))
            throw Error("cancelled", "writing the B-rep was stopped");
    };
    std::string out;
    out.reserve(model.edges.size() * 200 + model.faces.size() * 200 + model.vertices.size() * 90);
    out += "DBRep_DrawableShape\n\nCASCADE Topology V1, (c) Matra-Datavision\nLocations 0\nCurve2ds 0\n";
    append(out, "Curves %zu\n", model.edges.size());
    for (const BrepEdge& edge : model.edges) {
        wrote();
        const cv::Vec3d a = model.vertices[edge.start], direction = cv::normalize(model.vertices[edge.end] - a);
        append(out, "1 %.17g %.17g %.17g %.17g %.17g %.17g\n", a[0], a[1], a[2], direction[0], direction[1], direction[2]);
    }
    out += "Polygon3D 0\nPolygonOnTriangulations 0\n";
    append(out, "Surfaces %zu\n", model.faces.size());
    for (const BrepFace& face : model.faces) {
        wrote();
        const cv::Vec3d& o = face.origin;
        const cv::Vec3d n = cv::normalize(face.normal), x = perpendicular(n), y = n.cross(x);
        append(out, "1 %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", o[0], o[1], o[2], n[0],
               n[1], n[2], x[0], x[1], x[2], y[0], y[1], y[2]);
    }
    out += "Triangulations 0\n\n";

    size_t wire_count = 0;
    for (const BrepFace& face : model.faces) wire_count += face.wires.size();
    const size_t vertex_count = model.vertices.size(), edge_count = model.edges.size();
    const size_t total = vertex_count + edge_count + wire_count + model.faces.size() + 2;
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
        const double length = cv::norm(model.vertices[edge.end] - model.vertices[edge.start]);
        append(out, "Ed\n %.17g 1 1 0\n1  %zu 0 0 %.17g\n0\n\n0101000\n+%zu 0 -%zu 0 *\n", edge.tolerance_mm, e + 1, length,
               vertex_ref(edge.start), vertex_ref(edge.end));
    }
    size_t place = vertex_count + edge_count;  // shapes written so far
    std::vector<size_t> face_refs;
    for (size_t f = 0; f < model.faces.size(); ++f) {
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
        append(out, "Fa\n0  1e-07 %zu 0\n\n0101000\n", f + 1);
        out += wires + "*\n";
        face_refs.push_back(total - place++);
    }
    out += "Sh\n\n0101100\n";
    for (size_t ref : face_refs) append(out, "+%zu 0 ", ref);
    out += "*\nSo\n\n1100000\n+2 0 *\n\n+1 0\n";
    write_file_atomically(path, out);
}

}  // namespace picoscan
