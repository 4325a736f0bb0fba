#include "bindings.h"

#include "picoscan/capture_set.h"

namespace picoscan::python {

void bind_capture_set(py::module_& m) {
    py::class_<CaptureSet>(m, "CaptureSet", "One camera image per frame of a pattern sequence.")
        .def(py::init<>())
        .def_readwrite("directory", &CaptureSet::directory)
        .def_readwrite("sequence", &CaptureSet::sequence)
        .def_readwrite("images", &CaptureSet::images, "list of arrays (shared with the core when read)")
        .def_readwrite("white_colour", &CaptureSet::white_colour)
        .def_property_readonly("image_size", [](const CaptureSet& c) {
            return c.images.empty() ? cv::Size() : c.images.front().size();
        });
    m.def(
        "load_capture_set",
        [](const std::string& directory, const std::string& manifest, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return load_capture_set(directory, manifest, callback);
        },
        py::arg("directory"), py::arg("manifest") = "", py::arg("progress") = py::none());
    m.def("write_capture_set", &write_capture_set, py::arg("captures"), py::arg("directory"),
          py::call_guard<py::gil_scoped_release>());
    m.def("require_empty_directory", &require_empty_directory, py::arg("directory"));
    m.def("write_capture_frame", &write_capture_frame, py::arg("frame"), py::arg("image"), py::arg("directory"),
          py::call_guard<py::gil_scoped_release>());
    m.def("read_image_file", &read_image_file, py::arg("path"), py::arg("flags") = -1,
          py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
