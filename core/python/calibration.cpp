#include "bindings.h"

#include "picoscan/board.h"
#include "picoscan/calibrate.h"
#include "picoscan/calibration_report.h"
#include "picoscan/calibration.h"

namespace picoscan::python {

void bind_calibration(py::module_& m) {
    py::class_<Calibration>(m, "Calibration", "Camera + projector; X_projector = R X_camera + T (mm).")
        .def(py::init<>())
        .def_readwrite("camera_size", &Calibration::camera_size)
        .def_readwrite("camera_matrix", &Calibration::camera_matrix)
        .def_readwrite("camera_distortion", &Calibration::camera_distortion)
        .def_readwrite("projector_size", &Calibration::projector_size)
        .def_readwrite("projector_matrix", &Calibration::projector_matrix)
        .def_readwrite("projector_distortion", &Calibration::projector_distortion)
        .def_readwrite("R", &Calibration::R)
        .def_readwrite("T", &Calibration::T);
    m.def("read_calibration", &read_calibration, py::arg("path"));
    m.def("write_calibration", &write_calibration, py::arg("calibration"), py::arg("path"));
    m.def("validate_calibration", &validate_calibration, py::arg("calibration"), py::arg("source"));

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

    py::class_<CalibrateOptions>(m, "CalibrateOptions")
        .def(py::init<>())
        .def_readwrite("decode", &CalibrateOptions::decode)
        .def_readwrite("max_view_rms_px", &CalibrateOptions::max_view_rms_px)
        .def_readwrite("min_views", &CalibrateOptions::min_views)
        .def_readwrite("radial_k1_only", &CalibrateOptions::radial_k1_only);
    py::class_<PoseObservation>(m, "PoseObservation", "The board's corners seen in one pose.")
        .def(py::init<>())
        .def_readonly("name", &PoseObservation::name)
        .def_readonly("problem", &PoseObservation::problem)
        .def_property_readonly("corner_count", [](const PoseObservation& p) { return p.camera_points.size(); })
        .def_property_readonly("projector_corner_count", [](const PoseObservation& p) { return p.projector_points.size(); });
    m.def("observe_pose", &observe_pose, py::arg("pose"), py::arg("board"), py::arg("options") = CalibrateOptions(),
          py::call_guard<py::gil_scoped_release>());

    py::class_<CalibrationPoseReport>(m, "CalibrationPoseReport")
        .def_readonly("name", &CalibrationPoseReport::name)
        .def_readonly("used", &CalibrationPoseReport::used)
        .def_readonly("reason", &CalibrationPoseReport::reason)
        .def_readonly("corners", &CalibrationPoseReport::corners)
        .def_readonly("projector_corners", &CalibrationPoseReport::projector_corners)
        .def_readonly("camera_rms_px", &CalibrationPoseReport::camera_rms_px)
        .def_readonly("projector_rms_px", &CalibrationPoseReport::projector_rms_px);
    py::class_<CalibrationReport>(m, "CalibrationReport")
        .def_readonly("calibration", &CalibrationReport::calibration)
        .def_readonly("camera_rms_px", &CalibrationReport::camera_rms_px)
        .def_readonly("projector_rms_px", &CalibrationReport::projector_rms_px)
        .def_readonly("stereo_rms_px", &CalibrationReport::stereo_rms_px)
        .def_readonly("poses", &CalibrationReport::poses)
        .def_readonly("warnings", &CalibrationReport::warnings);
    m.def(
        "calibrate_rig",
        [](const std::vector<PoseObservation>& poses, const CalibrateOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return calibrate_rig(poses, options, callback);
        },
        py::arg("poses"), py::arg("options") = CalibrateOptions(), py::arg("progress") = py::none());
    m.def("write_calibration_report", &write_calibration_report, py::arg("report"), py::arg("board"), py::arg("path"),
          py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
