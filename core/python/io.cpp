#include "bindings.h"

#include "picoscan/error.h"
#include "picoscan/file_output.h"
#include "picoscan/io.h"

#include <opencv2/imgcodecs.hpp>

namespace picoscan::python {

void bind_io(py::module_& m) {
    auto encoding = [](bool ascii) { return ascii ? Encoding::Ascii : Encoding::Binary; };
    m.def(
        "write_ply", [=](const PointCloud& cloud, const std::string& path, bool ascii) { write_ply(cloud, path, encoding(ascii)); },
        py::arg("cloud"), py::arg("path"), py::arg("ascii") = false, py::call_guard<py::gil_scoped_release>());
    m.def(
        "write_ply", [=](const Mesh& mesh, const std::string& path, bool ascii) { write_ply(mesh, path, encoding(ascii)); },
        py::arg("mesh"), py::arg("path"), py::arg("ascii") = false, py::call_guard<py::gil_scoped_release>());
    m.def(
        "write_stl", [=](const Mesh& mesh, const std::string& path, bool ascii) { write_stl(mesh, path, encoding(ascii)); },
        py::arg("mesh"), py::arg("path"), py::arg("ascii") = false, py::call_guard<py::gil_scoped_release>());
    m.def("write_obj", &write_obj, py::arg("mesh"), py::arg("path"), py::call_guard<py::gil_scoped_release>());
    m.def("read_mesh", &read_mesh, py::arg("path"), py::call_guard<py::gil_scoped_release>());
    m.def(
        "write_view_ply",
        [=](const ScanView& view, const std::string& path, bool ascii) { write_view_ply(view, path, encoding(ascii)); },
        py::arg("view"), py::arg("path"), py::arg("ascii") = false, py::call_guard<py::gil_scoped_release>());
    m.def("read_view_ply", &read_view_ply, py::arg("path"), py::call_guard<py::gil_scoped_release>());
    m.def("write_file_atomically", &write_file_atomically, py::arg("path"), py::arg("bytes"));
    // An image (grey, BGR or BGRA array) encoded by its extension and written atomically.
    m.def(
        "write_image",
        [](const std::string& path, const cv::Mat& image) {
            const auto dot = path.rfind('.');
            std::vector<uchar> bytes;
            if (dot == std::string::npos || !cv::imencode(path.substr(dot), image, bytes))
                throw Error(path, "cannot encode the image in this format (use .png or .jpg)");
            write_file_atomically(path, std::string(bytes.begin(), bytes.end()));
        },
        py::arg("path"), py::arg("image"));
}

}  // namespace picoscan::python
