#include "bindings.h"

#include "picoscan/shapes.h"

namespace picoscan::python {

void bind_shapes(py::module_& m) {
    py::enum_<ShapeKind>(m, "ShapeKind")
        .value("Plane", ShapeKind::Plane)
        .value("Cylinder", ShapeKind::Cylinder)
        .value("Sphere", ShapeKind::Sphere)
        .value("Cone", ShapeKind::Cone);
    py::class_<ShapeDetectionOptions>(m, "ShapeDetectionOptions")
        .def(py::init<>())
        .def_readwrite("planes", &ShapeDetectionOptions::planes)
        .def_readwrite("cylinders", &ShapeDetectionOptions::cylinders)
        .def_readwrite("spheres", &ShapeDetectionOptions::spheres)
        .def_readwrite("cones", &ShapeDetectionOptions::cones)
        .def_readwrite("epsilon_mm", &ShapeDetectionOptions::epsilon_mm)
        .def_readwrite("cluster_epsilon_mm", &ShapeDetectionOptions::cluster_epsilon_mm)
        .def_readwrite("normal_threshold_deg", &ShapeDetectionOptions::normal_threshold_deg)
        .def_readwrite("min_points", &ShapeDetectionOptions::min_points)
        .def_readwrite("probability", &ShapeDetectionOptions::probability)
        .def_readwrite("refine", &ShapeDetectionOptions::refine)
        .def_readwrite("min_cone_half_angle_deg", &ShapeDetectionOptions::min_cone_half_angle_deg);
    py::class_<DetectedShape>(m, "DetectedShape")
        .def_readonly("kind", &DetectedShape::kind)
        .def_readonly("point", &DetectedShape::point)
        .def_readonly("direction", &DetectedShape::direction)
        .def_readonly("radius_mm", &DetectedShape::radius_mm)
        .def_readonly("half_angle_deg", &DetectedShape::half_angle_deg)
        .def_readonly("length_mm", &DetectedShape::length_mm)
        .def_readonly("rms_mm", &DetectedShape::rms_mm)
        .def_property_readonly("inlier_count", [](const DetectedShape& s) { return s.inliers.size(); })
        .def_property_readonly("inliers", [](py::object self) {
            auto& inliers = self.cast<DetectedShape&>().inliers;
            return py::array_t<int>({py::ssize_t(inliers.size())}, {py::ssize_t(sizeof(int))}, inliers.data(), self);
        })
        .def("__repr__", [](const DetectedShape& s) {
            return "<DetectedShape " + to_string(s.kind) + " radius " + std::to_string(s.radius_mm) + " mm, rms " +
                   std::to_string(s.rms_mm) + " mm, " + std::to_string(s.inliers.size()) + " inliers>";
        });
    m.def(
        "detect_shapes",
        [](const PointCloud& cloud, const ShapeDetectionOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return detect_shapes(cloud, options, callback);
        },
        py::arg("cloud"), py::arg("options") = ShapeDetectionOptions(), py::arg("progress") = py::none());
    m.def("shape_distance", &shape_distance, py::arg("shape"), py::arg("point"));
}

}  // namespace picoscan::python
