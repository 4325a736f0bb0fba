#include "bindings.h"

#include "picoscan/fit.h"

namespace picoscan::python {

void bind_fit(py::module_& m) {
    py::class_<PlaneFit>(m, "PlaneFit")
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
}

}  // namespace picoscan::python
