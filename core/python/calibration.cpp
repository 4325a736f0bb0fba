#include "bindings.h"

#include "picoscan/calibration.h"

namespace picoscan::python {

void bind_calibration(py::module_& m) {
    py::class_<Calibration>(m, "Calibration", "Camera + projector; X_projector = R X_camera + T (mm).")
        .def(py::init<>())
        .def_readwrite("camera_size", &Calibration::camera_size)
        .def_readwrite("camera_matrix", &Calibration::camera_matrix)
        .def_readwrite("camera_distortion", &Calibration::camera_distortion)
        .def_readwrite("projector_size", &Calibration::projector_size)
        .def_readwrite("projector_matrix", &Calibration::projector_matrix)
        .def_readwrite("projector_distortion", &Calibration::projector_distortion)
        .def_readwrite("R", &Calibration::R)
        .def_readwrite("T", &Calibration::T)
        .def_readwrite("projector_inverse_response", &Calibration::projector_inverse_response,
                       "256-entry uint8 gamma correction for patterns, or empty");
    m.def("read_calibration", &read_calibration, py::arg("path"));
    m.def("write_calibration", &write_calibration, py::arg("calibration"), py::arg("path"));
    m.def("validate_calibration", &validate_calibration, py::arg("calibration"), py::arg("source"));
}

}  // namespace picoscan::python
