#include "bindings.h"

#include "picoscan/io.h"

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
    m.def("write_3mf", &write_3mf, py::arg("mesh"), py::arg("path"), py::call_guard<py::gil_scoped_release>());
    m.def("read_3mf", &read_3mf, py::arg("path"), py::call_guard<py::gil_scoped_release>());
    m.def(
        "write_view_ply",
        [=](const ScanView& view, const std::string& path, bool ascii) { write_view_ply(view, path, encoding(ascii)); },
        py::arg("view"), py::arg("path"), py::arg("ascii") = false, py::call_guard<py::gil_scoped_release>());
    m.def("read_view_ply", &read_view_ply, py::arg("path"), py::call_guard<py::gil_scoped_release>());
    // The mesh readers hear Cancel through progress(fraction, stage) -> bool, like the core's long calls.
    auto bind_reader = [&m](const char* name, Mesh (*reader)(const std::string&, const ProgressCallback&)) {
        m.def(
            name,
            [reader](const std::string& path, const py::object& progress) {
                const ProgressCallback callback = progress_from(progress);
                py::gil_scoped_release release;
                return reader(path, callback);
            },
            py::arg("path"), py::arg("progress") = py::none());
    };
    bind_reader("read_mesh", &read_mesh);
    bind_reader("read_ply", &read_ply);
    bind_reader("read_stl", &read_stl);
    py::class_<ViewPose>(m, "ViewPose", "One entry of a poses file: a view's name and view -> model pose.")
        .def(py::init<>())
        .def(py::init([](const std::string& name, const cv::Matx44d& pose, bool aligned) { return ViewPose{name, pose, aligned, 0}; }),
             py::arg("name"), py::arg("pose"), py::arg("aligned") = true)
        .def_readwrite("name", &ViewPose::name)
        .def_readwrite("pose", &ViewPose::pose)
        .def_readwrite("aligned", &ViewPose::aligned)
        .def_readwrite("placement", &ViewPose::placement);
    m.def("write_poses", &write_poses, py::arg("poses"), py::arg("path"));
    m.def("read_poses", &read_poses, py::arg("path"));
}

}  // namespace picoscan::python
