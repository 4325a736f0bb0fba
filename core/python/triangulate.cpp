#include "bindings.h"

#include "picoscan/triangulate.h"

namespace picoscan::python {

void bind_triangulate(py::module_& m) {
    py::class_<TriangulateOptions>(m, "TriangulateOptions")
        .def(py::init<>())
        .def_readwrite("use_rows", &TriangulateOptions::use_rows)
        .def_readwrite("min_depth_mm", &TriangulateOptions::min_depth_mm)
        .def_readwrite("max_depth_mm", &TriangulateOptions::max_depth_mm);
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
    m.def("check_camera_size", &check_camera_size, py::arg("calibration"), py::arg("captures"),
          py::arg("calibration_name"), "Raises picoscan.Error naming the calibration when its camera size is not the captures'");
}

}  // namespace picoscan::python
