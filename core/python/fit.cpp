#include "bindings.h"

#include "picoscan/fit.h"

namespace picoscan::python {

void bind_fit(py::module_& m) {
    py::class_<PlaneFit>(m, "PlaneFit")
        .def(py::init([](const cv::Vec3d& normal, double offset_mm, double rms_mm, size_t point_count) {
                 PlaneFit plane;
                 plane.normal = normal;
                 plane.offset_mm = offset_mm;
                 plane.rms_mm = rms_mm;
                 plane.point_count = point_count;
                 return plane;
             }),
             py::arg("normal"), py::arg("offset_mm"), py::arg("rms_mm") = 0.0, py::arg("point_count") = 0,
             "A plane normal . X = offset_mm (a model's face, or a fit with its normal turned)")
        .def_readonly("normal", &PlaneFit::normal)
        .def_readonly("offset_mm", &PlaneFit::offset_mm)
        .def_readonly("rms_mm", &PlaneFit::rms_mm)
        .def_readonly("point_count", &PlaneFit::point_count);
    py::class_<SphereFit>(m, "SphereFit")
        .def_readonly("centre", &SphereFit::centre)
        .def_readonly("radius_mm", &SphereFit::radius_mm)
        .def_readonly("rms_mm", &SphereFit::rms_mm)
        .def_readonly("point_count", &SphereFit::point_count);
    m.def("fit_plane", [](const py::array& points) { return fit_plane(array_to_vector<cv::Vec3f>(points, "points")); },
          py::arg("points"));
    m.def("fit_sphere", [](const py::array& points) { return fit_sphere(array_to_vector<cv::Vec3f>(points, "points")); },
          py::arg("points"));
    py::class_<DatumOptions>(m, "DatumOptions")
        .def(py::init<>())
        .def_readwrite("min_angle_deg", &DatumOptions::min_angle_deg);
    py::class_<DatumFrame>(m, "DatumFrame")
        .def_readonly("part_from_scan", &DatumFrame::part_from_scan, "4 x 4: takes scan coordinates into the part frame")
        .def_readonly("origin", &DatumFrame::origin)
        .def_readonly("x_axis", &DatumFrame::x_axis)
        .def_readonly("y_axis", &DatumFrame::y_axis)
        .def_readonly("z_axis", &DatumFrame::z_axis)
        .def_readonly("primary_secondary_deg", &DatumFrame::primary_secondary_deg)
        .def_readonly("primary_tertiary_deg", &DatumFrame::primary_tertiary_deg)
        .def_readonly("secondary_tertiary_deg", &DatumFrame::secondary_tertiary_deg);
    m.def("datum_frame", py::overload_cast<const PlaneFit&, const PlaneFit&, const PlaneFit&, const DatumOptions&>(&datum_frame),
          py::arg("primary"), py::arg("secondary"), py::arg("tertiary"), py::arg("options") = DatumOptions(),
          "3-2-1 datum frame: Z from the primary plane, X along its line with the secondary, origin on the tertiary");
    m.def("datum_frame", py::overload_cast<const PlaneFit&, const PlaneFit&, const cv::Vec3d&, const DatumOptions&>(&datum_frame),
          py::arg("primary"), py::arg("secondary"), py::arg("origin_point"), py::arg("options") = DatumOptions(),
          "3-2-1 datum frame with the origin at the point of the primary/secondary line nearest to origin_point");
    m.def("frame_from_axis", &frame_from_axis, py::arg("origin"), py::arg("up"), py::arg("x_hint"),
          "A frame with Z along up, X along x_hint made square to Z, origin at origin");
}

}  // namespace picoscan::python
