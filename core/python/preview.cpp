#include "bindings.h"

#include "picoscan/preview.h"

namespace picoscan::python {

void bind_preview(py::module_& m) {
    m.def("render_preview", &render_preview, py::arg("view"), "Shaded, depth-coloured BGR image of a view.",
          py::call_guard<py::gil_scoped_release>());
    m.def("write_preview_png", &write_preview_png, py::arg("view"), py::arg("path"),
          py::call_guard<py::gil_scoped_release>());
    py::class_<ContactSheetAxes>(m, "ContactSheetAxes")
        .def_readonly("centre", &ContactSheetAxes::centre)
        .def_readonly("up", &ContactSheetAxes::up)
        .def_readonly("front", &ContactSheetAxes::front);
    m.def("contact_sheet_axes", &contact_sheet_axes, py::arg("mesh"), py::arg("up_hint") = cv::Vec3d(0, 0, 0),
          py::call_guard<py::gil_scoped_release>());
    m.def("render_contact_sheet", &render_contact_sheet, py::arg("mesh"), py::arg("up_hint") = cv::Vec3d(0, 0, 0),
          py::arg("tile_size") = 320, py::call_guard<py::gil_scoped_release>());
    m.def("write_contact_sheet_png", &write_contact_sheet_png, py::arg("mesh"), py::arg("path"),
          py::arg("up_hint") = cv::Vec3d(0, 0, 0), py::call_guard<py::gil_scoped_release>());
    m.def("write_mesh_preview_png", &write_mesh_preview_png, py::arg("mesh"), py::arg("camera"), py::arg("path"),
          py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
