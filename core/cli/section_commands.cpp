// picoscan section: a fitted profile (lines, arcs, circles) of a mesh, as FreeCAD's Cross-section
// makes it, written as SVG and DXF for users without FreeCAD.
#include "cli_support.h"
#include "commands.h"

#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"
#include "picoscan/section_fit.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <optional>

namespace picoscan::cli {

namespace {

const char* kSectionHelp = R"(picoscan section MESH --axis x|y|z [--at MM] [--svg PROFILE.svg] [--dxf PROFILE.dxf] [options]
picoscan section MESH --normal DX,DY,DZ [--point X,Y,Z] [...]

Cuts a mesh (STL, PLY or 3MF, in millimetres) with a plane and fits lines, arcs and circles
to the cut, as FreeCAD's Cross-section does, so that a designer gets an editable profile: each
element within a tolerance of its points, each reported with its size, direction and residual.
Crumbs of the mesh (loops or chains too small or too noisy to be a feature of the part) are left
out, each with the reason. When the part's outline itself cannot be fitted, nothing is written.

The plane:
  --axis x|y|z       across this axis of the mesh's coordinates
  --at MM            where along --axis (default: the middle of the mesh)
  --normal DX,DY,DZ  or any plane, by its normal ...
  --point X,Y,Z      ... and a point of it (default: the centre of the mesh's bounding box)
The drawing's x and y are those of a view looking at the plane against its normal: --axis z
draws x, y (the top view), --axis y draws x, z (the front view), --axis x draws y, z (the right
view), in the mesh's own coordinates. With --normal, the drawing's origin is --point, its x runs
along the plane square to Z (to Y for a plane nearly across Z), its y up; both are printed.

The fit:
  --band MM          each element is fitted again with the points of 16 more cuts spread over
                     +- MM around the plane, wherever they follow it (a pad's sides): one cut of
                     a scanned mesh gives a short line's direction to about 0.1 degrees, the band
                     to about 0.04. An element whose cuts trend with their height (a drafted wall,
                     a cone, a sphere) keeps to its own cut, and the report says why.
                     Default 3; 0: the one cut.
  --tolerance MM     largest distance of a point to its element (default: 5 x the noise of the
                     --scan, else 5 x the noise the cut shows; at least 0.005 mm)
  --scan CLOUD.ply   the scan the mesh was made from (a view or a stitched cloud): its noise sets
                     the default tolerance. Give it for a Poisson or sharpened mesh, whose flattened
                     faces leave the cut almost no noise (micrometres), which says nothing of how
                     well the scan knows the part. In the mesh's frame: a cloud of which under 80 %
                     of the points lie within 3 x its noise of the mesh is refused (not its scan)

Outputs (each optional; the report is always printed):
  --svg FILE.svg     lines and arcs as SVG paths, circles as circles, in millimetres
  --dxf FILE.dxf     LINE, ARC and CIRCLE entities (DXF R12 ASCII, millimetres), for CAD tools
Both are replaced together, and only when the fit succeeds.

The report: the plane, the noise, the tolerance and where it came from (given, the --scan, or the
cut: then set it yourself), then per polyline its elements: kind, length and
direction (lines, degrees from the drawing's x axis) or radius and swept angle (arcs, circles),
the standard error of the direction or radius, RMS and largest distance of its points, and how
many band cuts refitted it (or why it kept to its own cut); then the polylines left out, and why.

Example (the built-in demo part, cut across its block at 12 mm height):
  picoscan demo --out demo
  picoscan section demo/part.stl --axis z --at 12 --svg outline.svg --dxf outline.dxf
)";

std::string vector_text(const cv::Vec3d& v) {
    char text[96];
    std::snprintf(text, sizeof text, "(%.4f, %.4f, %.4f)", v[0], v[1], v[2]);
    return text;
}

cv::Vec3d box_centre(const Mesh& mesh) {
    cv::Vec3d low(HUGE_VAL, HUGE_VAL, HUGE_VAL), high(-HUGE_VAL, -HUGE_VAL, -HUGE_VAL);
    for (const cv::Vec3f& p : mesh.vertices)
        for (int k = 0; k < 3; ++k) {
            low[k] = std::min(low[k], double(p[k]));
            high[k] = std::max(high[k], double(p[k]));
        }
    return 0.5 * (low + high);
}

// The plane as the options give it (--axis/--at or --normal/--point), read before the mesh so
// that a mistyped option is refused at once; the mesh's middle fills in what is left out.
struct PlaneRequest {
    int axis = -1;  // 0, 1, 2 for --axis x, y, z; -1 with --normal
    std::optional<double> at;
    cv::Vec3d normal;
    std::optional<cv::Vec3d> point;
    std::string flag;  // the option that placed the plane, named when it misses the mesh
};

PlaneRequest plane_request(const Arguments& arguments) {
    const bool by_axis = arguments.has("--axis") || arguments.has("--at");
    const bool by_normal = arguments.has("--normal") || arguments.has("--point");
    if (by_axis && by_normal) throw Error("--axis", "give either --axis (and --at) or --normal (and --point), not both");
    if (!by_axis && !by_normal) throw Error("--axis", "give the plane: --axis x|y|z (and --at MM) or --normal DX,DY,DZ");
    PlaneRequest request;
    if (by_normal) {
        if (!arguments.has("--normal")) throw Error("--normal", "give the plane's normal with its --point");
        const std::vector<double> n = arguments.numbers("--normal", 3);
        request.normal = {n[0], n[1], n[2]};
        if (!(cv::norm(request.normal) > 1e-9) || !std::isfinite(cv::norm(request.normal)))
            throw Error("--normal", "must be a non-zero direction, e.g. 0,0,1");
        if (arguments.has("--point")) {
            const std::vector<double> p = arguments.numbers("--point", 3);
            request.point = cv::Vec3d(p[0], p[1], p[2]);
        }
        request.flag = request.point ? "--point" : "--normal";
        return request;
    }
    const std::string axis = arguments.text("--axis");
    const std::string axes = "xyz";
    if (axis.size() != 1 || axes.find(char(std::tolower(axis[0]))) == std::string::npos)
        throw Error("--axis", "must be x, y or z, not '" + axis + "'");
    request.axis = int(axes.find(char(std::tolower(axis[0]))));
    if (arguments.has("--at")) {
        request.at = arguments.number("--at", 0);
        if (!std::isfinite(*request.at)) throw Error("--at", "must be a finite position in mm");
    }
    request.flag = "--at";
    return request;
}

SectionPlane plane_of(const PlaneRequest& request, const Mesh& mesh) {
    const cv::Vec3d centre = box_centre(mesh);
    if (request.axis < 0) return section_plane(request.point.value_or(centre), request.normal);
    return section_plane_across(request.axis, request.at.value_or(centre[request.axis]));
}

int run_section(const Arguments& arguments) {
    const std::string input = single_input(arguments);
    const std::string svg = arguments.text("--svg"), dxf = arguments.text("--dxf");
    check_extension(svg, {".svg"}, "SVG drawing");
    check_extension(dxf, {".dxf"}, "DXF drawing");
    for (const std::string& out : {svg, dxf})
        if (!out.empty()) refuse_overwriting(out, {input});
    const double band = arguments.number("--band", kDefaultSectionBandMm);
    if (!std::isfinite(band) || band < 0) throw Error("--band", "must be 0 (one cut) or a positive distance in mm");
    SectionFitOptions options;
    if (arguments.has("--tolerance")) {
        options.tolerance_mm = arguments.number("--tolerance", 0);
        if (!std::isfinite(options.tolerance_mm) || options.tolerance_mm <= 0)
            throw Error("--tolerance", "must be a positive distance in mm (leave it out for 5 x the noise of the --scan, or of the cut)");
    }
    const std::string scan = arguments.text("--scan");
    check_extension(scan, {".ply"}, "scan");
    if (!scan.empty() && arguments.has("--tolerance"))
        throw Error("--scan", "sets the default tolerance: give either --scan or --tolerance, not both");
    const PlaneRequest request = plane_request(arguments);
    arguments.reject_unknown();
    const Mesh mesh = read_mesh(input);
    if (mesh.faces.empty()) throw Error(input, "holds no triangles (a point cloud? mesh it first with 'picoscan mesh')");
    std::optional<PointCloud> cloud;
    if (!scan.empty()) {
        cloud.emplace();
        cloud->points = read_ply(scan).vertices;
    }
    const SectionPlane plane = plane_of(request, mesh);

    MeshSectionFit section;
    try {
        section = section_mesh(mesh, plane.origin, plane.u, plane.v, band, options, terminal_progress(),
                               cloud ? &*cloud : nullptr);
    } catch (const Error& error) {
        if (error.subject() == "scan") throw Error(scan, std::string(error.what()).substr(error.subject().size() + 2));
        if (error.subject() == "mesh") throw Error(input, std::string(error.what()).substr(error.subject().size() + 2));
        if (error.subject() != "plane") throw;
        throw Error(request.flag, "the plane through " + vector_text(plane.origin) + " with normal " +
                                    vector_text(plane.normal) + " " + std::string(error.what()).substr(7));
    }
    for (const std::string& line : section.report) std::printf("%s\n", line.c_str());
    const SectionFits& fits = section.fits;

    OutputBatch outputs;  // the drawings appear together
    if (!svg.empty()) write_file_atomically(svg, section_svg(fits));
    if (!dxf.empty()) write_file_atomically(dxf, section_dxf(fits));
    outputs.commit();
    for (const std::string& out : {svg, dxf})
        if (!out.empty()) std::printf("wrote %s\n", out.c_str());
    return 0;
}

}  // namespace

std::vector<Command> section_commands() {
    return {{"section", "fit lines, arcs and circles to a plane cut of a mesh -> SVG/DXF profile", kSectionHelp,
             run_section, {{}, {}, true}}};
}

}  // namespace picoscan::cli
