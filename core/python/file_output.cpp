#include "bindings.h"

#include "picoscan/file_output.h"

namespace picoscan::python {

void bind_file_output(py::module_& m) {
    py::class_<OutputBatch>(m, "OutputBatch",
                            "While alive, every atomic write waits in its temporary file; commit() renames them all.")
        .def(py::init<>())
        .def("commit", &OutputBatch::commit);
    m.def("write_file_atomically", &write_file_atomically, py::arg("path"), py::arg("bytes"),
          py::call_guard<py::gil_scoped_release>());
    m.def("write_image_file", &write_image_file, py::arg("image"), py::arg("path"),
          py::call_guard<py::gil_scoped_release>(), "Encoded by the extension (.png, .jpg, ...), written atomically");
    // The FreeCAD workbench's spelling (path first), until it calls write_image_file.
    m.def(
        "write_image", [](const std::string& path, const cv::Mat& image) { write_image_file(image, path); },
        py::arg("path"), py::arg("image"), py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
