#include "bindings.h"

#include "picoscan/patterns.h"

namespace picoscan::python {

void bind_patterns(py::module_& m) {
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
        .def_property_readonly("frame_count", [](const PatternSequence& s) { return s.frames.size(); })
        .def_property_readonly("frame_files", [](const PatternSequence& s) {
            std::vector<std::string> files;
            for (const Frame& frame : s.frames) files.push_back(frame.file);
            return files;
        })
        .def_property_readonly("encodes_rows", [](const PatternSequence& s) { return s.rows.used(); });
    m.def("make_pattern_sequence", &make_pattern_sequence, py::arg("options") = PatternOptions());
    m.def("read_manifest", &read_manifest, py::arg("path"));
    m.def("write_manifest", &write_manifest, py::arg("sequence"), py::arg("path"));
    m.def("write_pattern_images", &write_pattern_images, py::arg("sequence"), py::arg("directory"),
          py::arg("response_lut") = cv::Mat(), py::call_guard<py::gil_scoped_release>());
}

}  // namespace picoscan::python
