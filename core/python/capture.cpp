#include "bindings.h"

#include "picoscan/capture.h"

namespace picoscan::python {

void bind_capture(py::module_& m) {
    py::class_<PatternDisplay>(m, "PatternDisplay", "Something that puts patterns on the projector.")
        .def("size", &PatternDisplay::size)
        .def("show", &PatternDisplay::show, py::arg("pattern"))
        .def("visible", &PatternDisplay::visible)
        .def("wait", &PatternDisplay::wait, py::arg("milliseconds"), py::call_guard<py::gil_scoped_release>());
    py::class_<SimulatedDisplay, PatternDisplay>(m, "SimulatedDisplay", "A windowless display: patterns are visible at once.")
        .def(py::init<cv::Size>(), py::arg("size"));
    py::class_<DelayedDisplay, PatternDisplay>(m, "DelayedDisplay", "Passes patterns on to `display` latency_ms late.")
        .def(py::init<PatternDisplay&, double>(), py::arg("display"), py::arg("latency_ms"), py::keep_alive<1, 2>());

    py::class_<Camera>(m, "Camera", "A camera that delivers single frames.")
        .def("name", &Camera::name)
        .def("flush", &Camera::flush, py::call_guard<py::gil_scoped_release>())
        .def("grab", &Camera::grab, py::call_guard<py::gil_scoped_release>());
    m.def("grab_average", &grab_average, py::arg("camera"), py::arg("count"), py::call_guard<py::gil_scoped_release>());
    py::class_<CameraSettings>(m, "CameraSettings", "Driver settings; NaN keeps the driver's automatic setting.")
        .def(py::init<>())
        .def_readwrite("resolution", &CameraSettings::resolution)
        .def_readwrite("exposure", &CameraSettings::exposure)
        .def_readwrite("gain", &CameraSettings::gain)
        .def_readwrite("focus", &CameraSettings::focus)
        .def_readwrite("white_balance_k", &CameraSettings::white_balance_k)
        .def_readwrite("flush_frames", &CameraSettings::flush_frames);
    py::class_<VideoCaptureCamera, Camera>(m, "VideoCaptureCamera",
                                           "OpenCV VideoCapture: a V4L2 index or path, a video file or an image sequence.")
        .def(py::init<const std::string&, const CameraSettings&>(), py::arg("source"),
             py::arg("settings") = CameraSettings(), py::call_guard<py::gil_scoped_release>())
        .def("frame_size", &VideoCaptureCamera::frame_size)
        .def("warnings", &VideoCaptureCamera::warnings);

    py::class_<CaptureOptions>(m, "CaptureOptions")
        .def(py::init<>())
        .def_readwrite("frames_per_pattern", &CaptureOptions::frames_per_pattern)
        .def_readwrite("wait_ms", &CaptureOptions::wait_ms)
        .def_readwrite("resume", &CaptureOptions::resume)
        .def_readwrite("projector_inverse_response", &CaptureOptions::projector_inverse_response);
    py::class_<CaptureReport>(m, "CaptureReport")
        .def_readonly("captured", &CaptureReport::captured)
        .def_readonly("already_present", &CaptureReport::already_present);
    m.def(
        "capture_sequence",
        [](const PatternSequence& sequence, PatternDisplay& display, const std::vector<Camera*>& cameras,
           const std::vector<std::string>& directories, const CaptureOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return capture_sequence(sequence, display, cameras, directories, options, callback);
        },
        py::arg("sequence"), py::arg("display"), py::arg("cameras"), py::arg("directories"),
        py::arg("options") = CaptureOptions(), py::arg("progress") = py::none(),
        "Shows every frame and stores camera k's grab in directories[k]; progress returning False cancels.");
    m.def("frames_present", &frames_present, py::arg("sequence"), py::arg("directory"));
    m.def("check_capture_folders", &check_capture_folders, py::arg("sequence"), py::arg("directories"),
          py::arg("resume") = false);

    py::class_<LatencyOptions>(m, "LatencyOptions")
        .def(py::init<>())
        .def_readwrite("trials", &LatencyOptions::trials)
        .def_readwrite("settle_ms", &LatencyOptions::settle_ms)
        .def_readwrite("timeout_ms", &LatencyOptions::timeout_ms)
        .def_readwrite("min_contrast_dn", &LatencyOptions::min_contrast_dn);
    py::class_<LatencyMeasurement>(m, "LatencyMeasurement")
        .def_readonly("trials_ms", &LatencyMeasurement::trials_ms)
        .def_readonly("latency_ms", &LatencyMeasurement::latency_ms)
        .def_readonly("black_level_dn", &LatencyMeasurement::black_level_dn)
        .def_readonly("white_level_dn", &LatencyMeasurement::white_level_dn)
        .def("recommended_wait_ms", &LatencyMeasurement::recommended_wait_ms);
    m.def("measure_latency", &measure_latency, py::arg("display"), py::arg("camera"),
          py::arg("options") = LatencyOptions(), py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
