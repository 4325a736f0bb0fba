#include "bindings.h"

#include "picoscan/stereo.h"

namespace picoscan::python {

void bind_stereo(py::module_& m) {
    py::class_<StereoCalibration>(m, "StereoCalibration", "Two cameras; X_camera2 = R X_camera1 + T (mm).")
        .def(py::init<>())
        .def_readwrite("left_size", &StereoCalibration::left_size)
        .def_readwrite("right_size", &StereoCalibration::right_size)
        .def_readwrite("left_matrix", &StereoCalibration::left_matrix)
        .def_readwrite("right_matrix", &StereoCalibration::right_matrix)
        .def_readwrite("left_distortion", &StereoCalibration::left_distortion)
        .def_readwrite("right_distortion", &StereoCalibration::right_distortion)
        .def_readwrite("R", &StereoCalibration::R)
        .def_readwrite("T", &StereoCalibration::T)
        .def("baseline_mm", &StereoCalibration::baseline_mm);
    py::enum_<CalibrationKind>(m, "CalibrationKind")
        .value("CameraProjector", CalibrationKind::CameraProjector)
        .value("Stereo", CalibrationKind::Stereo);
    m.def("calibration_kind", &calibration_kind, py::arg("path"));
    m.def("read_stereo_calibration", &read_stereo_calibration, py::arg("path"));
    m.def("write_stereo_calibration", &write_stereo_calibration, py::arg("calibration"), py::arg("path"));
    m.def("validate_stereo_calibration", &validate_stereo_calibration, py::arg("calibration"), py::arg("source"));
    m.def("stereo_from_projector_calibrations", &stereo_from_projector_calibrations, py::arg("left"), py::arg("right"));

    py::class_<StereoCalibrateOptions>(m, "StereoCalibrateOptions")
        .def(py::init<>())
        .def_readwrite("max_view_rms_px", &StereoCalibrateOptions::max_view_rms_px)
        .def_readwrite("min_views", &StereoCalibrateOptions::min_views)
        .def_readwrite("recommended_views", &StereoCalibrateOptions::recommended_views)
        .def_readwrite("min_pose_spread_deg", &StereoCalibrateOptions::min_pose_spread_deg)
        .def_readwrite("radial_k3", &StereoCalibrateOptions::radial_k3);
    py::class_<StereoBoardView>(m, "StereoBoardView", "One board pose: each camera's image of the board.")
        .def(py::init<>())
        .def_readwrite("name", &StereoBoardView::name)
        .def_readwrite("left", &StereoBoardView::left)
        .def_readwrite("right", &StereoBoardView::right);
    m.def("load_board_image", &load_board_image, py::arg("directory"), py::arg("manifest") = "");
    py::class_<StereoPoseReport>(m, "StereoPoseReport")
        .def_readonly("name", &StereoPoseReport::name)
        .def_readonly("used", &StereoPoseReport::used)
        .def_readonly("reason", &StereoPoseReport::reason)
        .def_readonly("corners", &StereoPoseReport::corners)
        .def_readonly("left_rms_px", &StereoPoseReport::left_rms_px)
        .def_readonly("right_rms_px", &StereoPoseReport::right_rms_px)
        .def_readonly("epipolar_rms_px", &StereoPoseReport::epipolar_rms_px);
    py::class_<StereoCalibrationReport>(m, "StereoCalibrationReport")
        .def_readonly("calibration", &StereoCalibrationReport::calibration)
        .def_readonly("left_rms_px", &StereoCalibrationReport::left_rms_px)
        .def_readonly("right_rms_px", &StereoCalibrationReport::right_rms_px)
        .def_readonly("stereo_rms_px", &StereoCalibrationReport::stereo_rms_px)
        .def_readonly("epipolar_rms_px", &StereoCalibrationReport::epipolar_rms_px)
        .def_readonly("poses", &StereoCalibrationReport::poses)
        .def_readonly("warnings", &StereoCalibrationReport::warnings);
    m.def(
        "calibrate_stereo",
        [](const std::vector<StereoBoardView>& views, const BoardSpec& board, const StereoCalibrateOptions& options,
           const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return calibrate_stereo(views, board, options, callback);
        },
        py::arg("views"), py::arg("board"), py::arg("options") = StereoCalibrateOptions(), py::arg("progress") = py::none());
    m.def("write_stereo_calibration_report", &write_stereo_calibration_report, py::arg("report"), py::arg("path"));

    py::class_<StereoOptions>(m, "StereoOptions")
        .def(py::init<>())
        .def_readwrite("max_left_right_difference_px", &StereoOptions::max_left_right_difference_px)
        .def_readwrite("max_code_step_px", &StereoOptions::max_code_step_px)
        .def_readwrite("max_epipolar_error_px", &StereoOptions::max_epipolar_error_px)
        .def_readwrite("min_depth_mm", &StereoOptions::min_depth_mm)
        .def_readwrite("max_depth_mm", &StereoOptions::max_depth_mm);
    py::class_<StereoStatistics>(m, "StereoStatistics")
        .def_readonly("left_decoded", &StereoStatistics::left_decoded)
        .def_readonly("matched", &StereoStatistics::matched)
        .def_readonly("ambiguous", &StereoStatistics::ambiguous)
        .def_readonly("left_right_consistent", &StereoStatistics::left_right_consistent)
        .def_readonly("epipolar_rejected", &StereoStatistics::epipolar_rejected)
        .def_readonly("behind", &StereoStatistics::behind)
        .def_readonly("valid", &StereoStatistics::valid)
        .def_readonly("median_epipolar_error_px", &StereoStatistics::median_epipolar_error_px)
        .def_readonly("three_view", &StereoStatistics::three_view)
        .def_readonly("median_projector_residual_px", &StereoStatistics::median_projector_residual_px)
        .def("left_right_consistency", &StereoStatistics::left_right_consistency);
    py::class_<ExtrinsicsRefinement>(m, "ExtrinsicsRefinement")
        .def_readonly("calibration", &ExtrinsicsRefinement::calibration)
        .def_readonly("pairs", &ExtrinsicsRefinement::pairs)
        .def_readonly("inliers", &ExtrinsicsRefinement::inliers)
        .def_readonly("median_epipolar_before_px", &ExtrinsicsRefinement::median_epipolar_before_px)
        .def_readonly("median_epipolar_after_px", &ExtrinsicsRefinement::median_epipolar_after_px)
        .def_readonly("rotation_change_deg", &ExtrinsicsRefinement::rotation_change_deg);
    py::class_<StereoReconstruction>(m, "StereoReconstruction")
        .def_readonly("view", &StereoReconstruction::view)
        .def_readonly("statistics", &StereoReconstruction::statistics);
    py::class_<StereoMatcher>(m, "StereoMatcher", "Rectifies once per calibration, then reconstructs decoded pairs.")
        .def(py::init<const StereoCalibration&>(), py::arg("calibration"))
        .def(py::init<const StereoCalibration&, const Calibration&>(), py::arg("calibration"), py::arg("projector"),
             "Three views: the projector calibrated with the first camera refines each point.")
        .def(
            "reconstruct",
            [](const StereoMatcher& matcher, const CorrespondenceMap& left, const CorrespondenceMap& right,
               const cv::Mat& colour, const StereoOptions& options, const py::object& progress) {
                const ProgressCallback callback = progress_from(progress);
                py::gil_scoped_release release;
                return matcher.reconstruct(left, right, colour, options, callback);
            },
            py::arg("left"), py::arg("right"), py::arg("colour") = cv::Mat(), py::arg("options") = StereoOptions(),
            py::arg("progress") = py::none());
    m.def(
        "reconstruct_stereo",
        [](const CaptureSet& left, const CaptureSet& right, const StereoCalibration& calibration,
           const DecodeOptions& decode_options, const StereoOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return reconstruct_stereo(left, right, calibration, decode_options, options, callback);
        },
        py::arg("left"), py::arg("right"), py::arg("calibration"), py::arg("decode_options") = DecodeOptions(),
        py::arg("options") = StereoOptions(), py::arg("progress") = py::none());
}

}  // namespace picoscan::python
