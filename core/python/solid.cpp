#include "bindings.h"

#include "picoscan/solid.h"

namespace picoscan::python {

void bind_solid(py::module_& m) {
    py::class_<PlanarFaceOptions>(m, "PlanarFaceOptions")
        .def(py::init<>())
        .def_readwrite("noise_mm", &PlanarFaceOptions::noise_mm)
        .def_readwrite("distance_factor", &PlanarFaceOptions::distance_factor)
        .def_readwrite("max_normal_deg", &PlanarFaceOptions::max_normal_deg)
        .def_readwrite("max_rms_factor", &PlanarFaceOptions::max_rms_factor)
        .def_readwrite("min_facets", &PlanarFaceOptions::min_facets)
        .def_readwrite("merge", &PlanarFaceOptions::merge)
        .def_readwrite("simplify", &PlanarFaceOptions::simplify)
        .def_readwrite("simplify_mm", &PlanarFaceOptions::simplify_mm)
        .def_readwrite("simplify_max_volume_change", &PlanarFaceOptions::simplify_max_volume_change)
        .def_readwrite("check_faces", &PlanarFaceOptions::check_faces)
        .def_readwrite("cylinders", &PlanarFaceOptions::cylinders);
    py::class_<BrepEdge>(m, "BrepEdge")
        .def_readonly("start", &BrepEdge::start)
        .def_readonly("end", &BrepEdge::end)
        .def_readonly("tolerance_mm", &BrepEdge::tolerance_mm)
        .def_readonly("chain", &BrepEdge::chain)
        .def_readonly("radius_mm", &BrepEdge::radius_mm)
        .def_readonly("center", &BrepEdge::center)
        .def_readonly("axis", &BrepEdge::axis)
        .def_readonly("x_axis", &BrepEdge::x_axis);
    py::class_<BrepFace>(m, "BrepFace")
        .def_readonly("origin", &BrepFace::origin)
        .def_readonly("normal", &BrepFace::normal)
        .def_readonly("merged", &BrepFace::merged)
        .def_readonly("facet_count", &BrepFace::facet_count)
        .def_readonly("rms_mm", &BrepFace::rms_mm)
        .def_readonly("wires", &BrepFace::wires)
        .def_readonly("triangles", &BrepFace::triangles)
        .def_readonly("radius_mm", &BrepFace::radius_mm)
        .def_readonly("x_axis", &BrepFace::x_axis)
        .def_readonly("reversed", &BrepFace::reversed)
        .def_readonly("semi_angle_rad", &BrepFace::semi_angle_rad);
    py::class_<PlanarFaceModel>(m, "PlanarFaceModel")
        .def_readonly("vertices", &PlanarFaceModel::vertices)
        .def_readonly("mesh_vertices", &PlanarFaceModel::mesh_vertices)
        .def_readonly("vertex_tolerance_mm", &PlanarFaceModel::vertex_tolerance_mm)
        .def_readonly("edges", &PlanarFaceModel::edges)
        .def_readonly("faces", &PlanarFaceModel::faces)
        .def_readonly("noise_mm", &PlanarFaceModel::noise_mm)
        .def_readonly("mesh_volume_mm3", &PlanarFaceModel::mesh_volume_mm3)
        .def_readonly("facet_count", &PlanarFaceModel::facet_count)
        .def_readonly("merged_faces", &PlanarFaceModel::merged_faces)
        .def_readonly("merged_facets", &PlanarFaceModel::merged_facets)
        .def_readonly("refused_merges", &PlanarFaceModel::refused_merges)
        .def_readonly("cylinder_faces", &PlanarFaceModel::cylinder_faces)
        .def_readonly("cylinder_facets", &PlanarFaceModel::cylinder_facets)
        .def_readonly("cone_faces", &PlanarFaceModel::cone_faces)
        .def_readonly("cone_facets", &PlanarFaceModel::cone_facets)
        .def_readonly("cylinder_notes", &PlanarFaceModel::cylinder_notes)
        .def_readonly("cylinder_end_facets", &PlanarFaceModel::cylinder_end_facets)
        .def_readonly("cylinder_end_mm", &PlanarFaceModel::cylinder_end_mm)
        .def_readonly("cylinder_end_volume_mm3", &PlanarFaceModel::cylinder_end_volume_mm3)
        .def_readonly("curved_facets_before", &PlanarFaceModel::curved_facets_before)
        .def_readonly("curved_facets_after", &PlanarFaceModel::curved_facets_after)
        .def_readonly("simplify_mm", &PlanarFaceModel::simplify_mm)
        .def_readonly("simplify_deviation_mm", &PlanarFaceModel::simplify_deviation_mm)
        .def_readonly("simplified_volume_mm3", &PlanarFaceModel::simplified_volume_mm3)
        .def_readonly("simplify_note", &PlanarFaceModel::simplify_note)
        .def("summary", &PlanarFaceModel::summary);
    m.def(
        "planar_face_model",
        [](const Mesh& mesh, const PlanarFaceOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return planar_face_model(mesh, options, callback);
        },
        py::arg("mesh"), py::arg("options") = PlanarFaceOptions(), py::arg("progress") = py::none());
    m.def("merged_face_defects", &merged_face_defects, py::arg("model"), py::arg("options") = PlanarFaceOptions());
    m.def(
        "write_brep",
        [](const PlanarFaceModel& model, const std::string& path, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            write_brep(model, path, callback);
        },
        py::arg("model"), py::arg("path"), py::arg("progress") = py::none());
}

}  // namespace picoscan::python
