#include "bindings.h"

#include "picoscan/region_fit.h"

namespace picoscan::python {

void bind_region_fit(py::module_& m) {
    py::class_<RegionSelection>(m, "RegionSelection")
        .def(py::init<>())
        .def_readwrite("radius_mm", &RegionSelection::radius_mm)
        .def_readwrite("seed_radius_mm", &RegionSelection::seed_radius_mm)
        .def_readwrite("box_half_size_mm", &RegionSelection::box_half_size_mm)
        .def_readwrite("box_axes", &RegionSelection::box_axes)
        .def_readwrite("grow", &RegionSelection::grow)
        .def_readwrite("max_gap_mm", &RegionSelection::max_gap_mm)
        .def_readwrite("max_normal_step_deg", &RegionSelection::max_normal_step_deg);
    py::enum_<FitConstraint>(m, "FitConstraint")
        .value("Free", FitConstraint::Free)
        .value("Parallel", FitConstraint::Parallel)
        .value("Perpendicular", FitConstraint::Perpendicular)
        .value("Coaxial", FitConstraint::Coaxial);
    py::class_<RegionFitOptions>(m, "RegionFitOptions")
        .def(py::init<>())
        .def_readwrite("automatic", &RegionFitOptions::automatic)
        .def_readwrite("kind", &RegionFitOptions::kind)
        .def_readwrite("planes", &RegionFitOptions::planes)
        .def_readwrite("cylinders", &RegionFitOptions::cylinders)
        .def_readwrite("spheres", &RegionFitOptions::spheres)
        .def_readwrite("cones", &RegionFitOptions::cones)
        .def_readwrite("noise_mm", &RegionFitOptions::noise_mm)
        .def_readwrite("accept_factor", &RegionFitOptions::accept_factor)
        .def_readwrite("margin", &RegionFitOptions::margin)
        .def_readwrite("reject_factor", &RegionFitOptions::reject_factor)
        .def_readwrite("min_cone_half_angle_deg", &RegionFitOptions::min_cone_half_angle_deg)
        .def_readwrite("constraint", &RegionFitOptions::constraint)
        .def_readwrite("reference_point", &RegionFitOptions::reference_point)
        .def_readwrite("reference_direction", &RegionFitOptions::reference_direction)
        .def_readwrite("snap_step_mm", &RegionFitOptions::snap_step_mm)
        .def_readwrite("snap_tolerance_mm", &RegionFitOptions::snap_tolerance_mm);
    py::class_<RegionFit>(m, "RegionFit")
        .def_readonly("shape", &RegionFit::shape)
        .def_readonly("noise_mm", &RegionFit::noise_mm)
        .def_readonly("plane_rms_mm", &RegionFit::plane_rms_mm)
        .def_readonly("sphere_rms_mm", &RegionFit::sphere_rms_mm)
        .def_readonly("cylinder_rms_mm", &RegionFit::cylinder_rms_mm)
        .def_readonly("cone_rms_mm", &RegionFit::cone_rms_mm)
        .def_readonly("snapped", &RegionFit::snapped)
        .def_readonly("fitted_radius_mm", &RegionFit::fitted_radius_mm)
        .def_readonly("report", &RegionFit::report);
    m.def(
        "select_region",
        [](const PointCloud& cloud, const cv::Vec3d& seed, const RegionSelection& selection, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return select_region(cloud, seed, selection, callback);
        },
        py::arg("cloud"), py::arg("seed"), py::arg("selection") = RegionSelection(), py::arg("progress") = py::none());
    py::class_<GrownFace>(m, "GrownFace")
        .def_readonly("region", &GrownFace::region)
        .def_readonly("kind", &GrownFace::kind)
        .def_readonly("noise_mm", &GrownFace::noise_mm)
        .def_readonly("seed_radius_mm", &GrownFace::seed_radius_mm)
        .def_readonly("report", &GrownFace::report);
    m.def(
        "grow_face",
        [](const PointCloud& cloud, const cv::Vec3d& seed, const RegionSelection& selection, const RegionFitOptions& fit,
           const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return grow_face(cloud, seed, selection, fit, callback);
        },
        py::arg("cloud"), py::arg("seed"), py::arg("selection") = RegionSelection(), py::arg("fit") = RegionFitOptions(),
        py::arg("progress") = py::none());
    m.def("estimate_noise", &estimate_noise, py::arg("cloud"), py::arg("centre"), py::arg("radius_mm"),
          py::call_guard<py::gil_scoped_release>());
    m.def("estimate_scan_noise", &estimate_scan_noise, py::arg("cloud"), py::call_guard<py::gil_scoped_release>(),
          "The scan's noise (sigma, mm) over the whole cloud");
    m.def("select_in_polygon", &select_in_polygon, py::arg("cloud"), py::arg("cloud_to_screen"), py::arg("polygon"),
          py::call_guard<py::gil_scoped_release>());
    m.def(
        "fit_region",
        [](const PointCloud& cloud, const std::vector<int>& region, const RegionFitOptions& options,
           const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return fit_region(cloud, region, options, callback);
        },
        py::arg("cloud"), py::arg("region"), py::arg("options") = RegionFitOptions(), py::arg("progress") = py::none());
}

}  // namespace picoscan::python
