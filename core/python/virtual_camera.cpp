#include "bindings.h"

#include "picoscan/virtual_camera.h"

namespace picoscan::python {

void bind_virtual_camera(py::module_& m) {
    py::class_<VirtualCamera, Camera>(m, "VirtualCamera",
                                      "The simulator as a camera: renders the scene lit by what `display` shows.")
        .def(py::init<const Calibration&, const Scene&, const SimulationOptions&, const PatternDisplay&>(),
             py::arg("calibration"), py::arg("scene"), py::arg("options"), py::arg("display"), py::keep_alive<1, 5>());
}

}  // namespace picoscan::python
