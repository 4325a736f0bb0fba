#include "bindings.h"

#include "picoscan/section_fit.h"

namespace picoscan::python {

void bind_section_fit(py::module_& m) {
    m.attr("DEFAULT_SECTION_BAND_MM") = kDefaultSectionBandMm;
    m.attr("SECTION_BAND_CUTS") = kSectionBandCuts;
    py::enum_<SectionElementKind>(m, "SectionElementKind")
        .value("Line", SectionElementKind::Line)
        .value("Arc", SectionElementKind::Arc)
        .value("Circle", SectionElementKind::Circle);
    py::enum_<SectionConstraintKind>(m, "SectionConstraintKind")
        .value("Horizontal", SectionConstraintKind::Horizontal)
        .value("Vertical", SectionConstraintKind::Vertical)
        .value("Parallel", SectionConstraintKind::Parallel)
        .value("Perpendicular", SectionConstraintKind::Perpendicular)
        .value("EqualRadius", SectionConstraintKind::EqualRadius);
    py::class_<SectionFitOptions>(m, "SectionFitOptions")
        .def(py::init<>())
        .def_readwrite("tolerance_mm", &SectionFitOptions::tolerance_mm)
        .def_readwrite("min_tolerance_mm", &SectionFitOptions::min_tolerance_mm)
        .def_readwrite("scan_noise_mm", &SectionFitOptions::scan_noise_mm)
        .def_readwrite("noise_window_mm", &SectionFitOptions::noise_window_mm)
        .def_readwrite("min_line_points", &SectionFitOptions::min_line_points)
        .def_readwrite("min_arc_points", &SectionFitOptions::min_arc_points)
        .def_readwrite("max_arc_radius_mm", &SectionFitOptions::max_arc_radius_mm)
        .def_readwrite("tangent_angle_deg", &SectionFitOptions::tangent_angle_deg)
        .def_readwrite("snap_angle_deg", &SectionFitOptions::snap_angle_deg)
        .def_readwrite("min_polyline_points", &SectionFitOptions::min_polyline_points)
        .def_readwrite("loop_noise_limit_mm", &SectionFitOptions::loop_noise_limit_mm)
        .def_readwrite("max_bridged_gap_mm", &SectionFitOptions::max_bridged_gap_mm)
        .def_readwrite("band_trend_fraction", &SectionFitOptions::band_trend_fraction);
    py::class_<SectionElement>(m, "SectionElement")
        .def_readonly("kind", &SectionElement::kind)
        .def_readonly("start", &SectionElement::start)
        .def_readonly("end", &SectionElement::end)
        .def_readonly("centre", &SectionElement::centre)
        .def_readonly("radius_mm", &SectionElement::radius_mm)
        .def_readonly("counter_clockwise", &SectionElement::counter_clockwise)
        .def_readonly("first_point", &SectionElement::first_point)
        .def_readonly("point_count", &SectionElement::point_count,
                      "The points fitted (a faceted cut's chords' inner points not counted)")
        .def_readonly("rms_mm", &SectionElement::rms_mm)
        .def_readonly("max_mm", &SectionElement::max_mm)
        .def_readonly("chord_sag_mm", &SectionElement::chord_sag_mm,
                      "Faceted cut: how far inside the arc the points on its chords may lie (not fitted)")
        .def_readonly("angle_sigma_deg", &SectionElement::angle_sigma_deg)
        .def_readonly("radius_sigma_mm", &SectionElement::radius_sigma_mm)
        .def_readonly("tangent_to_next", &SectionElement::tangent_to_next)
        .def_readonly("band_cuts", &SectionElement::band_cuts)
        .def_readonly("band_note", &SectionElement::band_note)
        .def("__repr__", [](const SectionElement& e) {
            return "<SectionElement " + to_string(e.kind) + (e.kind == SectionElementKind::Line ? "" : " radius " + std::to_string(e.radius_mm)) +
                   " mm, " + std::to_string(e.point_count) + " points, max " + std::to_string(e.max_mm) + " mm>";
        });
    py::class_<SectionConstraint>(m, "SectionConstraint")
        .def_readonly("kind", &SectionConstraint::kind)
        .def_readonly("first", &SectionConstraint::first)
        .def_readonly("second", &SectionConstraint::second)
        .def_readonly("max_mm", &SectionConstraint::max_mm);
    py::class_<SectionFit>(m, "SectionFit")
        .def_readonly("elements", &SectionFit::elements)
        .def_readonly("constraints", &SectionFit::constraints)
        .def_readonly("closed", &SectionFit::closed)
        .def_readonly("tolerance_mm", &SectionFit::tolerance_mm)
        .def_readonly("noise_mm", &SectionFit::noise_mm);
    py::class_<LeftOutPolyline>(m, "LeftOutPolyline")
        .def_readonly("index", &LeftOutPolyline::index)
        .def_readonly("point_count", &LeftOutPolyline::point_count)
        .def_readonly("closed", &LeftOutPolyline::closed)
        .def_readonly("centre", &LeftOutPolyline::centre)
        .def_readonly("across_mm", &LeftOutPolyline::across_mm)
        .def_readonly("reason", &LeftOutPolyline::reason);
    py::class_<SectionFits>(m, "SectionFits")
        .def_readonly("fits", &SectionFits::fits)
        .def_readonly("fitted_index", &SectionFits::fitted_index)
        .def_readonly("left_out", &SectionFits::left_out)
        .def_readonly("noise_mm", &SectionFits::noise_mm)
        .def_readonly("tolerance_mm", &SectionFits::tolerance_mm);
    py::class_<ParallelCut>(m, "ParallelCut")
        .def(py::init([](double offset_mm, const py::array& points) {
                 return ParallelCut{offset_mm, array_to_vector<cv::Vec2d>(points, "points")};
             }),
             py::arg("offset_mm"), py::arg("points"))
        .def_readonly("offset_mm", &ParallelCut::offset_mm)
        .def_property_readonly("points", [](py::object self) { return vector_view(self.cast<ParallelCut&>().points, self); },
                               "N x 2 (mm) in the section's 2D frame");
    py::class_<SectionPolyline>(m, "SectionPolyline")
        .def(py::init([](const py::array& points, bool closed) {
                 return SectionPolyline{array_to_vector<cv::Vec2d>(points, "points"), closed};
             }),
             py::arg("points"), py::arg("closed"))
        .def_property_readonly("points", [](py::object self) { return vector_view(self.cast<SectionPolyline&>().points, self); },
                               "N x 2 (mm) in the cutting plane's frame")
        .def_readonly("closed", &SectionPolyline::closed);
    m.def(
        "cut_mesh",
        [](const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis, const cv::Vec3d& v_axis,
           const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return cut_mesh(mesh, origin, u_axis, v_axis, callback);
        },
        py::arg("mesh"), py::arg("origin"), py::arg("u_axis"), py::arg("v_axis"), py::arg("progress") = py::none(),
        "The polylines where the plane through origin spanned by u and v cuts the mesh");
    py::class_<MeshSection>(m, "MeshSection")
        .def_readonly("polylines", &MeshSection::polylines, "The plane's own cut ([SectionPolyline])")
        .def_readonly("parallel_cuts", &MeshSection::parallel_cuts, "The Band's cuts ([ParallelCut]), for fit_section_polylines");
    m.def("section_band_offsets", &section_band_offsets, py::arg("band_mm"),
          "The offsets (mm) of the Band's SECTION_BAND_CUTS cuts over +- band_mm (none for 0)");
    m.def(
        "cut_mesh_section",
        [](const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis, const cv::Vec3d& v_axis, double band_mm,
           const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return cut_mesh_section(mesh, origin, u_axis, v_axis, band_mm, callback);
        },
        py::arg("mesh"), py::arg("origin"), py::arg("u_axis"), py::arg("v_axis"),
        py::arg("band_mm") = kDefaultSectionBandMm, py::arg("progress") = py::none(),
        "The section of the mesh at the plane through origin spanned by u and v, and its Band's parallel cuts "
        "(band_mm = 0: none); refuses a plane that misses the mesh");
    m.def(
        "fit_section",
        [](const py::array& polyline, bool closed, const SectionFitOptions& options) {
            const std::vector<cv::Vec2d> points = array_to_vector<cv::Vec2d>(polyline, "polyline");
            py::gil_scoped_release release;
            return fit_section(points, closed, options);
        },
        py::arg("polyline"), py::arg("closed"), py::arg("options") = SectionFitOptions(),
        "Lines, arcs and circles fitted to an N x 2 polyline (mm), with their joints and snapped constraints");
    m.def(
        "fit_extruded_section",
        [](const py::array& polyline, bool closed, const std::vector<ParallelCut>& parallel_cuts,
           const SectionFitOptions& options) {
            const std::vector<cv::Vec2d> points = array_to_vector<cv::Vec2d>(polyline, "polyline");
            py::gil_scoped_release release;
            return fit_extruded_section(points, closed, parallel_cuts, options);
        },
        py::arg("polyline"), py::arg("closed"), py::arg("parallel_cuts"), py::arg("options") = SectionFitOptions(),
        "fit_section of a prismatic outline, each element refitted with the points of parallel cuts ([ParallelCut]) "
        "unless their offsets trend with the height (then band_note says why)");
    m.def(
        "fit_section_polylines",
        [](const std::vector<SectionPolyline>& polylines, const std::vector<ParallelCut>& parallel_cuts,
           const SectionFitOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return fit_section_polylines(polylines, parallel_cuts, options, callback);
        },
        py::arg("polylines"), py::arg("parallel_cuts") = std::vector<ParallelCut>(), py::arg("options") = SectionFitOptions(),
        py::arg("progress") = py::none(),
        "A section's polylines ([SectionPolyline], e.g. cut_mesh_section's) fitted with one noise and tolerance; too small or too noisy "
        "ones left out with the reason (left_out)");
    py::class_<SectionPlane>(m, "SectionPlane")
        .def_readonly("origin", &SectionPlane::origin)
        .def_readonly("normal", &SectionPlane::normal, "Unit normal, towards the viewer")
        .def_readonly("u", &SectionPlane::u, "The drawing's x")
        .def_readonly("v", &SectionPlane::v, "The drawing's y");
    m.def("section_plane", &section_plane, py::arg("origin"), py::arg("normal"),
          "The plane through origin with this normal and its drawing's frame (x square to Z, or to Y for a plane "
          "nearly across Z), as picoscan section draws it");
    m.def("section_plane_across", &section_plane_across, py::arg("axis"), py::arg("at"),
          "The plane across axis 0, 1, 2 (x, y, z) at `at` mm, as the right, front or top view");
    py::enum_<SectionToleranceSource>(m, "SectionToleranceSource")
        .value("Given", SectionToleranceSource::Given)
        .value("ScanNoise", SectionToleranceSource::ScanNoise)
        .value("CutNoise", SectionToleranceSource::CutNoise);
    py::class_<MeshSectionFit>(m, "MeshSectionFit")
        .def_readonly("section", &MeshSectionFit::section, "The cut and its Band (MeshSection)")
        .def_readonly("fits", &MeshSectionFit::fits, "The polylines fitted together (SectionFits)")
        .def_readonly("scan_noise_mm", &MeshSectionFit::scan_noise_mm, "The scan's noise (sigma) measured on its points; 0 without a scan")
        .def_readonly("tolerance_source", &MeshSectionFit::tolerance_source, "Where the tolerance came from (SectionToleranceSource)")
        .def_readonly("tolerance_from", &MeshSectionFit::tolerance_from, "The tolerance and where it came from, one line")
        .def_readonly("report", &MeshSectionFit::report, "The report, one string per line");
    m.def(
        "section_mesh",
        [](const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis, const cv::Vec3d& v_axis, double band_mm,
           const SectionFitOptions& options, const py::object& progress, const PointCloud* scan) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return section_mesh(mesh, origin, u_axis, v_axis, band_mm, options, callback, scan);
        },
        py::arg("mesh"), py::arg("origin"), py::arg("u_axis"), py::arg("v_axis"),
        py::arg("band_mm") = kDefaultSectionBandMm, py::arg("options") = SectionFitOptions(), py::arg("progress") = py::none(),
        py::arg("scan") = py::none(),
        "The Cross-section in one call: the default tolerance from the noise of the scan (a PointCloud) the mesh was "
        "made from when given, else from the cut, the mesh cut at the plane through origin spanned by u and v with its "
        "Band, the polylines fitted together, and the report (MeshSectionFit); progress hears the noise, the cut and the "
        "fit, Cancel raises Error('cancelled: ...')");
    py::class_<ScanOfMeshCheck>(m, "ScanOfMeshCheck")
        .def_readonly("checked", &ScanOfMeshCheck::checked, "Points measured against the mesh")
        .def_readonly("outside_box", &ScanOfMeshCheck::outside_box, "Finite points beyond the mesh's grown box, not judged")
        .def_readonly("share", &ScanOfMeshCheck::share, "Of those checked, the share within limit_mm of the mesh")
        .def_readonly("limit_mm", &ScanOfMeshCheck::limit_mm, "How near the mesh a point must lie")
        .def_readonly("margin_mm", &ScanOfMeshCheck::margin_mm, "How far the mesh's box was grown");
    m.def(
        "check_scan_of_mesh",
        [](const PointCloud& scan, const Mesh& mesh, double scan_noise_mm) {
            py::gil_scoped_release release;
            return check_scan_of_mesh(scan, mesh, scan_noise_mm);
        },
        py::arg("scan"), py::arg("mesh"), py::arg("scan_noise_mm"),
        "Checks that the scan is the mesh's (ScanOfMeshCheck); raises Error naming the scan when too few of its points "
        "near the mesh's box lie on the mesh");
    m.def("section_element_text", &section_element_text, py::arg("element"), "One element's line of the report");
    m.def("left_out_text", &left_out_text, py::arg("left"), "One left-out polyline's line of the report (loop or chain, why)");
}

}  // namespace picoscan::python
