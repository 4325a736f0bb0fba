#include "bindings.h"

#include "picoscan/clean.h"

namespace picoscan::python {

void bind_clean(py::module_& m) {
    py::class_<CleanOptions>(m, "CleanOptions")
        .def(py::init<>())
        .def_readwrite("min_quality", &CleanOptions::min_quality)
        .def_readwrite("max_grazing_deg", &CleanOptions::max_grazing_deg)
        .def_readwrite("use_working_volume", &CleanOptions::use_working_volume)
        .def_readwrite("volume_min", &CleanOptions::volume_min)
        .def_readwrite("volume_max", &CleanOptions::volume_max)
        .def_readwrite("window_px", &CleanOptions::window_px)
        .def_readwrite("outlier_sigma", &CleanOptions::outlier_sigma)
        .def_readwrite("radius_footprints", &CleanOptions::radius_footprints)
        .def_readwrite("min_neighbours", &CleanOptions::min_neighbours)
        .def_readwrite("min_cluster_points", &CleanOptions::min_cluster_points);
    py::class_<CleanReport>(m, "CleanReport")
        .def_readonly("by_quality", &CleanReport::by_quality)
        .def_readonly("by_grazing", &CleanReport::by_grazing)
        .def_readonly("by_working_volume", &CleanReport::by_working_volume)
        .def_readonly("by_statistics", &CleanReport::by_statistics)
        .def_readonly("by_radius", &CleanReport::by_radius)
        .def_readonly("by_cluster", &CleanReport::by_cluster)
        .def_readonly("remaining", &CleanReport::remaining)
        .def("removed", &CleanReport::removed);
    m.def("clean_view", &clean_view, py::arg("view"), py::arg("options") = CleanOptions(),
          "Sets removed points to NaN in place.", py::call_guard<py::gil_scoped_release>());
    m.def("remove_background", &remove_background, py::arg("view"), py::arg("background"),
          py::arg("tolerance_mm") = 1.0, py::call_guard<py::gil_scoped_release>(),
          "Removes in place the view's points within tolerance_mm of the background view's; returns how many");
}

}  // namespace picoscan::python
