#include "bindings.h"

#include "picoscan/decode.h"

namespace picoscan::python {

void bind_decode(py::module_& m) {
    // The numbers CorrespondenceMap.status holds per pixel.
    py::enum_<PixelStatus>(m, "PixelStatus", py::arithmetic())
        .value("kValid", kValid)
        .value("kDark", kDark)
        .value("kSaturated", kSaturated)
        .value("kUndecidedBit", kUndecidedBit)
        .value("kLowModulation", kLowModulation);
    py::class_<DecodeOptions>(m, "DecodeOptions")
        .def(py::init<>())
        .def_readwrite("min_contrast", &DecodeOptions::min_contrast)
        .def_readwrite("min_bit_margin", &DecodeOptions::min_bit_margin)
        .def_readwrite("saturation_level", &DecodeOptions::saturation_level)
        .def_readwrite("min_modulation", &DecodeOptions::min_modulation)
        .def_readwrite("binary_only", &DecodeOptions::binary_only);
    py::class_<CorrespondenceMap>(m, "CorrespondenceMap", "Projector (u, v) per camera pixel; arrays share its buffers.")
        .def(py::init<>())
        .def_readonly("projector_u", &CorrespondenceMap::projector_u)
        .def_readonly("projector_v", &CorrespondenceMap::projector_v)
        .def_readonly("quality", &CorrespondenceMap::quality)
        .def_readonly("mask", &CorrespondenceMap::mask)
        .def_readonly("status", &CorrespondenceMap::status)
        .def_readonly("order_corrections", &CorrespondenceMap::order_corrections);
    m.def(
        "decode",
        [](const CaptureSet& captures, const DecodeOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return decode(captures, options, callback);
        },
        py::arg("captures"), py::arg("options") = DecodeOptions(), py::arg("progress") = py::none());
}

}  // namespace picoscan::python
