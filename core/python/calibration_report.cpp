#include "bindings.h"

#include "picoscan/calibration_report.h"

namespace picoscan::python {

void bind_calibration_report(py::module_& m) {
    m.def("plot_calibration_residuals", &plot_calibration_residuals, py::arg("report"),
          py::call_guard<py::gil_scoped_release>());
    m.def("plot_calibration_coverage", &plot_calibration_coverage, py::arg("report"),
          py::call_guard<py::gil_scoped_release>());
    m.def("draw_calibration_rig", &draw_calibration_rig, py::arg("report"), py::arg("board"),
          py::call_guard<py::gil_scoped_release>());
    m.def("write_calibration_report", &write_calibration_report, py::arg("report"), py::arg("board"), py::arg("path"),
          py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
