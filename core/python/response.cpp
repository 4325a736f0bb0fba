#include "bindings.h"

#include "picoscan/response.h"

namespace picoscan::python {

void bind_response(py::module_& m) {
    m.def("response_levels", &response_levels, py::arg("count") = 17);
    m.def("flat_level_file", &flat_level_file, py::arg("level"));
    py::class_<ProjectorResponse>(m, "ProjectorResponse")
        .def(py::init<>())
        .def_readwrite("levels", &ProjectorResponse::levels)
        .def_readwrite("relative_light", &ProjectorResponse::relative_light)
        .def_readwrite("gamma", &ProjectorResponse::gamma)
        .def_readwrite("inverse_lut", &ProjectorResponse::inverse_lut);
    m.def("measure_projector_response", &measure_projector_response, py::arg("levels"), py::arg("images"),
          py::arg("mask") = cv::Mat(), py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
