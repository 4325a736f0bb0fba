#include "bindings.h"

#include "picoscan/patterns.h"

namespace picoscan::python {

void bind_patterns(py::module_& m) {
    py::enum_<FrameKind>(m, "FrameKind")
        .value("White", FrameKind::White)
        .value("Black", FrameKind::Black)
        .value("Gray", FrameKind::Gray)
        .value("GrayInverse", FrameKind::GrayInverse)
        .value("Phase", FrameKind::Phase)
        .value("Cue", FrameKind::Cue);
    py::enum_<Axis>(m, "Axis").value("Columns", Axis::Columns).value("Rows", Axis::Rows);
    py::class_<Frame>(m, "Frame", "One projected frame: its image file and what it encodes.")
        .def(py::init<>())
        .def_readwrite("file", &Frame::file)
        .def_readwrite("kind", &Frame::kind)
        .def_readwrite("axis", &Frame::axis)
        .def_readwrite("bit", &Frame::bit)
        .def_readwrite("shift", &Frame::shift);
    py::class_<AxisCode>(m, "AxisCode", "How one projector axis is encoded (Gray bits, phase shifts, cue).")
        .def(py::init<>())
        .def_readwrite("gray_bits", &AxisCode::gray_bits)
        .def_readwrite("gray_unit_px", &AxisCode::gray_unit_px)
        .def_readwrite("shifts", &AxisCode::shifts)
        .def_readwrite("period_px", &AxisCode::period_px)
        .def_readwrite("phase_offset_rad", &AxisCode::phase_offset_rad)
        .def_readwrite("shift_sign", &AxisCode::shift_sign)
        .def_readwrite("cue_shifts", &AxisCode::cue_shifts)
        .def_readwrite("cue_period_px", &AxisCode::cue_period_px)
        .def("used", &AxisCode::used);
    py::class_<PatternOptions>(m, "PatternOptions", "Options of PicoScan's own pattern sequence.")
        .def(py::init<>())
        .def_readwrite("projector_size", &PatternOptions::projector_size)
        .def_readwrite("shifts", &PatternOptions::shifts)
        .def_readwrite("period_bits", &PatternOptions::period_bits)
        .def_readwrite("rows", &PatternOptions::rows);
    py::class_<PatternSequence>(m, "PatternSequence", "Every frame of a scan in projection order.")
        .def(py::init<>())
        .def_readwrite("projector_size", &PatternSequence::projector_size)
        .def_readwrite("origin", &PatternSequence::origin)
        .def_readwrite("columns", &PatternSequence::columns)
        .def_readwrite("rows", &PatternSequence::rows)
        .def_readwrite("frames", &PatternSequence::frames)
        .def("code", &PatternSequence::code, py::arg("axis"))
        .def_property_readonly("frame_count", [](const PatternSequence& s) { return s.frames.size(); })
        .def_property_readonly("frame_files", [](const PatternSequence& s) {
            std::vector<std::string> files;
            for (const Frame& frame : s.frames) files.push_back(frame.file);
            return files;
        })
        .def_property_readonly("encodes_rows", [](const PatternSequence& s) { return s.rows.used(); });
    m.def("gray_bits_for", &gray_bits_for, py::arg("pixels"));
    m.def("make_pattern_sequence", &make_pattern_sequence, py::arg("options") = PatternOptions());
    m.def("make_opencv_graycode_sequence", &make_opencv_graycode_sequence, py::arg("projector_size"), py::arg("prefix"),
          py::arg("suffix"), py::arg("first_index"));
    m.def("make_slstudio_gray_sequence", &make_slstudio_gray_sequence, py::arg("projector_size"), py::arg("bits"));
    m.def("make_slstudio_phase_cue_sequence", &make_slstudio_phase_cue_sequence, py::arg("projector_size"),
          py::arg("periods"));
    m.def("make_slmaster_cgc_sequence", &make_slmaster_cgc_sequence, py::arg("projector_size"), py::arg("shifts"),
          py::arg("periods"));
    m.def("render_pattern", &render_pattern, py::arg("sequence"), py::arg("frame"), py::arg("response_lut") = cv::Mat());
    m.def("read_manifest", &read_manifest, py::arg("path"));
    m.def("write_manifest", &write_manifest, py::arg("sequence"), py::arg("path"));
    m.def("write_pattern_images", &write_pattern_images, py::arg("sequence"), py::arg("directory"),
          py::arg("response_lut") = cv::Mat(), py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
