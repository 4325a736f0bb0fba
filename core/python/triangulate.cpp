#include "bindings.h"

#include "picoscan/triangulate.h"

namespace picoscan::python {

void bind_triangulate(py::module_& m) {
    py::class_<TriangulateOptions>(m, "TriangulateOptions")
        .def(py::init<>())
        .def_readwrite("use_rows", &TriangulateOptions::use_rows)
        .def_readwrite("distortion_iterations", &TriangulateOptions::distortion_iterations)
        .def_readwrite("min_depth_mm", &TriangulateOptions::min_depth_mm)
        .def_readwrite("max_depth_mm", &TriangulateOptions::max_depth_mm);
    py::class_<Triangulator>(m, "Triangulator", "Triangulates many maps with one calibration (rays computed once).")
        .def(py::init<const Calibration&>(), py::arg("calibration"), py::call_guard<py::gil_scoped_release>())
        .def(
            "triangulate",
            [](const Triangulator& triangulator, const CorrespondenceMap& map, const cv::Mat& colour,
               const TriangulateOptions& options, const py::object& progress) {
                const ProgressCallback callback = progress_from(progress);
                py::gil_scoped_release release;
                return triangulator.triangulate(map, colour, options, callback);
            },
            py::arg("correspondences"), py::arg("colour") = cv::Mat(), py::arg("options") = TriangulateOptions(),
            py::arg("progress") = py::none());
    m.def("check_camera_size", &check_camera_size, py::arg("calibration"), py::arg("captures"),
          py::arg("calibration_name"));
    m.def("check_projector_size", &check_projector_size, py::arg("calibration"), py::arg("sequence"),
          py::arg("calibration_name"), py::arg("manifest_name"));
    m.def(
        "triangulate",
        [](const CorrespondenceMap& map, const Calibration& calibration, const cv::Mat& colour,
           const TriangulateOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return triangulate(map, calibration, colour, options, callback);
        },
        py::arg("correspondences"), py::arg("calibration"), py::arg("colour") = cv::Mat(),
        py::arg("options") = TriangulateOptions(), py::arg("progress") = py::none());
}

}  // namespace picoscan::python
