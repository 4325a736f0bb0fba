#include "bindings.h"

#include "picoscan/multi_camera.h"

namespace picoscan::python {

void bind_multi_camera(py::module_& m) {
    m.def("camera_to_camera", &camera_to_camera, py::arg("from_calibration"), py::arg("to_calibration"),
          "Pose of camera `to` relative to camera `from` (X_to = M X_from), through their shared projector");
    py::class_<CameraPairOptions>(m, "CameraPairOptions")
        .def(py::init<>())
        .def_readwrite("max_code_difference_px", &CameraPairOptions::max_code_difference_px);
    m.def("triangulate_camera_pair", &triangulate_camera_pair, py::arg("map_a"), py::arg("calibration_a"),
          py::arg("map_b"), py::arg("calibration_b"), py::arg("options") = CameraPairOptions(),
          py::call_guard<py::gil_scoped_release>());
    // The core edits the view in place; Python gets the number removed and sees the same view.
    m.def("reject_unconfirmed_points", &reject_unconfirmed_points, py::arg("view"), py::arg("calibration_a"),
          py::arg("map_b"), py::arg("calibration_b"), py::arg("options") = CameraPairOptions(),
          py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
