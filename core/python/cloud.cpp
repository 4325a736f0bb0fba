#include "bindings.h"

#include "picoscan/cloud.h"

namespace picoscan::python {

void bind_cloud(py::module_& m) {
    py::class_<ScanView>(m, "ScanView", "An organised scan: arrays of the camera's size, NaN where nothing was measured.")
        .def(py::init<>())
        .def_readwrite("points", &ScanView::points, "rows x cols x 3 float32, mm, camera frame")
        .def_readwrite("normals", &ScanView::normals)
        .def_readwrite("colours", &ScanView::colours, "rows x cols x 3 uint8, BGR")
        .def_readwrite("quality", &ScanView::quality)
        .def_readwrite("pose", &ScanView::pose, "4 x 4 view -> model transform")
        .def_readwrite("camera_matrix", &ScanView::camera_matrix, "3 x 3 intrinsics of the camera that saw it")
        .def_readwrite("camera_distortion", &ScanView::camera_distortion)
        .def("valid_count", &ScanView::valid_count)
        .def("focal_px", &ScanView::focal_px)
        .def(
            "with_pose",
            [](const ScanView& view, const cv::Matx44d& pose) {
                ScanView moved = view;  // the arrays are shared, not copied
                moved.pose = pose;
                return moved;
            },
            py::arg("pose"), "The same view (arrays shared) with another pose");

    py::class_<PointCloud>(m, "PointCloud", "Unorganised points; the arrays are views into the cloud.")
        .def(py::init<>())
        .def_property(
            "points", [](py::object self) { return vector_view(self.cast<PointCloud&>().points, self); },
            [](PointCloud& c, const py::array& a) { c.points = array_to_vector<cv::Vec3f>(a, "points"); })
        .def_property(
            "normals", [](py::object self) { return vector_view(self.cast<PointCloud&>().normals, self); },
            [](PointCloud& c, const py::array& a) { c.normals = array_to_vector<cv::Vec3f>(a, "normals"); })
        .def_property(
            "colours", [](py::object self) { return vector_view(self.cast<PointCloud&>().colours, self); },
            [](PointCloud& c, const py::array& a) { c.colours = array_to_vector<cv::Vec3b>(a, "colours"); })
        .def_readwrite("quality", &PointCloud::quality, "empty or one per point (list of float)")
        .def("__len__", [](const PointCloud& c) { return c.points.size(); });

    py::class_<Mesh>(m, "Mesh", "Triangle mesh; the arrays are views into the mesh.")
        .def(py::init<>())
        .def_property(
            "vertices", [](py::object self) { return vector_view(self.cast<Mesh&>().vertices, self); },
            [](Mesh& mesh, const py::array& a) { mesh.vertices = array_to_vector<cv::Vec3f>(a, "vertices"); })
        .def_property(
            "faces", [](py::object self) { return vector_view(self.cast<Mesh&>().faces, self); },
            [](Mesh& mesh, const py::array& a) { mesh.faces = array_to_vector<cv::Vec3i>(a, "faces"); })
        .def_property(
            "normals", [](py::object self) { return vector_view(self.cast<Mesh&>().normals, self); },
            [](Mesh& mesh, const py::array& a) { mesh.normals = array_to_vector<cv::Vec3f>(a, "normals"); })
        .def_readwrite("measured", &Mesh::measured, "per vertex: 1 measured, 0 filled (empty when unknown)")
        .def_property(
            "colours", [](py::object self) { return vector_view(self.cast<Mesh&>().colours, self); },
            [](Mesh& mesh, const py::array& a) { mesh.colours = array_to_vector<cv::Vec3b>(a, "colours"); });

    m.def("to_point_cloud", &to_point_cloud, py::arg("view"), py::call_guard<py::gil_scoped_release>());
    m.def("merge_views", &merge_views, py::arg("views"), "Views moved by their poses into one cloud",
          py::call_guard<py::gil_scoped_release>());
    m.def("transformed", &transformed, py::arg("mesh"), py::arg("transform"));
    py::class_<GridMeshOptions>(m, "GridMeshOptions")
        .def(py::init<>())
        .def_readwrite("max_edge_factor", &GridMeshOptions::max_edge_factor)
        .def_readwrite("pixel_step", &GridMeshOptions::pixel_step);
    m.def("grid_mesh", &grid_mesh, py::arg("view"), py::arg("options") = GridMeshOptions(),
          py::call_guard<py::gil_scoped_release>());
    m.def("estimate_normals", &estimate_normals, py::arg("view"),
          "Replaces view.normals with normals from the pixel grid, turned towards the camera");
}

}  // namespace picoscan::python
