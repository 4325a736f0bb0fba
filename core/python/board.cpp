#include "bindings.h"

#include "picoscan/board.h"

namespace picoscan::python {

void bind_board(py::module_& m) {
    py::enum_<BoardKind>(m, "BoardKind")
        .value("Chessboard", BoardKind::Chessboard)
        .value("Circles", BoardKind::Circles)
        .value("AsymmetricCircles", BoardKind::AsymmetricCircles)
        .value("Charuco", BoardKind::Charuco);
    py::class_<BoardSpec>(m, "BoardSpec")
        .def(py::init<>())
        .def_readwrite("kind", &BoardSpec::kind)
        .def_readwrite("size", &BoardSpec::size)
        .def_readwrite("square_mm", &BoardSpec::square_mm)
        .def_readwrite("marker_mm", &BoardSpec::marker_mm)
        .def_readwrite("dictionary", &BoardSpec::dictionary);
    m.def("parse_board_spec", &parse_board_spec, py::arg("text"));
    m.def("board_points", &board_points, py::arg("board"), "The board's feature points (x, y, 0) in mm, detection order");
    py::class_<BoardDetection>(m, "BoardDetection")
        .def(py::init<>())
        .def_readwrite("image_points", &BoardDetection::image_points)
        .def_readwrite("point_ids", &BoardDetection::point_ids);
    m.def(
        "detect_board",
        [](const cv::Mat& grey, const BoardSpec& board) -> std::optional<BoardDetection> {
            BoardDetection detection;
            if (!detect_board(grey, board, detection)) return std::nullopt;
            return detection;
        },
        py::arg("grey"), py::arg("board"), py::call_guard<py::gil_scoped_release>(),
        "The board's features in a grey image, or None when the board is not found");
}

}  // namespace picoscan::python
