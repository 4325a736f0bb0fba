#include "bindings.h"

#include "picoscan/calibrate.h"

namespace picoscan::python {

void bind_calibrate(py::module_& m) {
    py::class_<CalibrateOptions>(m, "CalibrateOptions")
        .def(py::init<>())
        .def_readwrite("decode", &CalibrateOptions::decode)
        .def_readwrite("homography_half_window_px", &CalibrateOptions::homography_half_window_px)
        .def_readwrite("min_homography_pixels", &CalibrateOptions::min_homography_pixels)
        .def_readwrite("min_corner_fraction", &CalibrateOptions::min_corner_fraction)
        .def_readwrite("max_view_rms_px", &CalibrateOptions::max_view_rms_px)
        .def_readwrite("min_views", &CalibrateOptions::min_views)
        .def_readwrite("recommended_views", &CalibrateOptions::recommended_views)
        .def_readwrite("min_pose_spread_deg", &CalibrateOptions::min_pose_spread_deg)
        .def_readwrite("radial_k1_only", &CalibrateOptions::radial_k1_only)
        .def_readwrite("camera_principal_point_at_centre", &CalibrateOptions::camera_principal_point_at_centre);
    py::class_<PoseObservation>(m, "PoseObservation", "The board's corners seen in one pose.")
        .def(py::init<>())
        .def_readwrite("name", &PoseObservation::name)
        .def_readwrite("camera_size", &PoseObservation::camera_size)
        .def_readwrite("projector_size", &PoseObservation::projector_size)
        .def_readwrite("problem", &PoseObservation::problem)
        .def_readwrite("board_points", &PoseObservation::board_points)
        .def_readwrite("camera_points", &PoseObservation::camera_points)
        .def_readwrite("projector_corner", &PoseObservation::projector_corner)
        .def_readwrite("projector_points", &PoseObservation::projector_points)
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
        .def_readonly("warnings", &CalibrationReport::warnings)
        .def_readonly("camera_residuals", &CalibrationReport::camera_residuals)
        .def_readonly("projector_residuals", &CalibrationReport::projector_residuals)
        .def_readonly("camera_corners", &CalibrationReport::camera_corners)
        .def_readonly("board_poses", &CalibrationReport::board_poses);
    m.def(
        "calibrate_rig",
        [](const std::vector<PoseObservation>& poses, const CalibrateOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return calibrate_rig(poses, options, callback);
        },
        py::arg("poses"), py::arg("options") = CalibrateOptions(), py::arg("progress") = py::none());
}

}  // namespace picoscan::python
