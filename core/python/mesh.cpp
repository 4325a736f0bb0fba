#include "bindings.h"

#include "picoscan/mesh.h"

namespace picoscan::python {

void bind_mesh(py::module_& m) {
    py::enum_<MeshMethod>(m, "MeshMethod")
        .value("Poisson", MeshMethod::Poisson)
        .value("AdvancingFront", MeshMethod::AdvancingFront)
        .value("Grid", MeshMethod::Grid);
    py::enum_<MeshFill>(m, "MeshFill")
        .value("Open", MeshFill::Open)
        .value("Table", MeshFill::Table)
        .value("Poisson", MeshFill::Poisson);
    py::class_<MeshOptions>(m, "MeshOptions")
        .def(py::init<>())
        .def_readwrite("method", &MeshOptions::method)
        .def_readwrite("sample_spacing_mm", &MeshOptions::sample_spacing_mm)
        .def_readwrite("poisson_triangle_size", &MeshOptions::poisson_triangle_size)
        .def_readwrite("poisson_distance", &MeshOptions::poisson_distance)
        .def_readwrite("advancing_front_max_radius", &MeshOptions::advancing_front_max_radius)
        .def_readwrite("fill", &MeshOptions::fill)
        .def_readwrite("table_axis", &MeshOptions::table_axis)
        .def_readwrite("max_points", &MeshOptions::max_points)
        .def_readwrite("max_faces", &MeshOptions::max_faces)
        .def_readwrite("max_hole_diameter_mm", &MeshOptions::max_hole_diameter_mm)
        .def_readwrite("target_faces", &MeshOptions::target_faces)
        .def_readwrite("grid", &MeshOptions::grid);
    py::class_<MeshCheck>(m, "MeshCheck")
        .def_readonly("vertices", &MeshCheck::vertices)
        .def_readonly("faces", &MeshCheck::faces)
        .def_readonly("filled_fraction", &MeshCheck::filled_fraction)
        .def_readonly("border_edges", &MeshCheck::border_edges)
        .def_readonly("non_manifold_edges", &MeshCheck::non_manifold_edges)
        .def_readonly("non_manifold_vertices", &MeshCheck::non_manifold_vertices)
        .def_readonly("components", &MeshCheck::components)
        .def_readonly("self_intersecting", &MeshCheck::self_intersecting)
        .def_readonly("closed_volume", &MeshCheck::closed_volume)
        .def_readonly("volume_mm3", &MeshCheck::volume_mm3)
        .def("watertight", &MeshCheck::watertight)
        .def("summary", &MeshCheck::summary);
    m.def("check_mesh", &check_mesh, py::arg("mesh"), py::call_guard<py::gil_scoped_release>());
    m.def(
        "mesh_cloud",
        [](const PointCloud& cloud, const MeshOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return mesh_cloud(cloud, options, callback);
        },
        py::arg("cloud"), py::arg("options") = MeshOptions(), py::arg("progress") = py::none());
}

}  // namespace picoscan::python
