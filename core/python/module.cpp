// The `picoscan` Python module: the core's stages for Python and FreeCAD. One binding file per
// public header (core/include/picoscan/NAME.h -> core/python/NAME.cpp); this one holds the
// cv::Mat <-> NumPy conversion and the module's table of contents.
#include "bindings.h"

namespace picoscan::python {

namespace {

int depth_of(const py::dtype& type, const char* name) {
    const char kind = type.kind();
    const auto size = type.itemsize();
    if (kind == 'u' && size == 1) return CV_8U;
    if (kind == 'i' && size == 1) return CV_8S;
    if (kind == 'u' && size == 2) return CV_16U;
    if (kind == 'i' && size == 2) return CV_16S;
    if (kind == 'i' && size == 4) return CV_32S;
    if (kind == 'f' && size == 4) return CV_32F;
    if (kind == 'f' && size == 8) return CV_64F;
    throw py::type_error(std::string(name) + ": unsupported dtype " + py::str(py::handle(type)).cast<std::string>());
}

py::dtype dtype_of(int depth) {
    switch (depth) {
        case CV_8U: return py::dtype::of<uint8_t>();
        case CV_8S: return py::dtype::of<int8_t>();
        case CV_16U: return py::dtype::of<uint16_t>();
        case CV_16S: return py::dtype::of<int16_t>();
        case CV_32S: return py::dtype::of<int32_t>();
        case CV_32F: return py::dtype::of<float>();
        case CV_64F: return py::dtype::of<double>();
    }
    throw py::type_error("image depth " + std::to_string(depth) + " has no NumPy type");
}

}  // namespace

py::array mat_to_array(const cv::Mat& mat) {
    if (mat.empty()) return py::array(py::dtype::of<float>(), std::vector<py::ssize_t>{0});
    // The capsule owns a Mat header sharing the buffer: its reference count keeps the pixels alive.
    auto* owner = new cv::Mat(mat);
    py::capsule release(owner, [](void* pointer) { delete static_cast<cv::Mat*>(pointer); });
    std::vector<py::ssize_t> shape{mat.rows, mat.cols}, strides{py::ssize_t(mat.step[0]), py::ssize_t(mat.elemSize())};
    if (mat.channels() > 1) {
        shape.push_back(mat.channels());
        strides.push_back(py::ssize_t(mat.elemSize1()));
    }
    return py::array(dtype_of(mat.depth()), shape, strides, owner->data, release);
}

cv::Mat array_to_mat(const py::array& input, const char* name) {
    py::array array = input;
    if (!(array.flags() & py::array::c_style)) array = py::module_::import("numpy").attr("ascontiguousarray")(array);
    if (array.ndim() != 2 && array.ndim() != 3)
        throw py::value_error(std::string(name) + ": expected a rows x cols [x channels] array, got " +
                              std::to_string(array.ndim()) + " dimensions");
    const int channels = array.ndim() == 3 ? int(array.shape(2)) : 1;
    if (channels < 1 || channels > 4) throw py::value_error(std::string(name) + ": 1 to 4 channels expected");
    const int type = CV_MAKETYPE(depth_of(array.dtype(), name), channels);
    return cv::Mat(int(array.shape(0)), int(array.shape(1)), type, const_cast<void*>(array.data()));
}

// Bound in their own files; declared here rather than in bindings.h so that adding them does not
// recompile every binding file.
void bind_solid(py::module_& m);
void bind_region_fit(py::module_& m);

}  // namespace picoscan::python

PYBIND11_MODULE(picoscan, m) {
    using namespace picoscan::python;
    m.doc() = "PicoScan structured-light scanning core: patterns, capture sets, decoding, calibration, "
              "triangulation, cleaning, meshing, shape detection. Images and clouds are NumPy arrays.";
    bind_error(m);
    bind_patterns(m);
    bind_capture_set(m);
    bind_decode(m);
    bind_calibration(m);
    bind_board(m);
    bind_calibrate(m);
    bind_calibration_report(m);
    bind_response(m);
    bind_triangulate(m);
    bind_stereo(m);
    bind_cloud(m);
    bind_clean(m);
    bind_simulate(m);
    bind_io(m);
    bind_preview(m);
    bind_fit(m);
    bind_register(m);
    bind_mesh(m);
    bind_shapes(m);
    bind_deviation(m);
    bind_section_fit(m);
    bind_solid(m);
    bind_region_fit(m);
    bind_capture(m);
    bind_virtual_camera(m);
    bind_multi_camera(m);
    bind_file_output(m);
    bind_pipeline(m);
}
