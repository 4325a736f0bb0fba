// Shared helpers of the pybind11 bindings: cv::Mat <-> NumPy without copies, progress callbacks
// that re-acquire the GIL, and one registration function per stage (one file each).
#pragma once

#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>
#include <vector>

namespace picoscan::python {

namespace py = pybind11;

// A NumPy array over the Mat's pixels (rows x cols [x channels]); the array holds a reference
// to the Mat's buffer, so no pixel is copied and the buffer lives as long as either does.
py::array mat_to_array(const cv::Mat& mat);
// A Mat header over the array's buffer (copied only when the array is not C-contiguous).
// The Mat does not own the pixels: use it during the call, or clone() it to keep it.
cv::Mat array_to_mat(const py::array& array, const char* name);

// An N x 3 array over a vector's elements; `owner` (the Python object holding the vector) is
// kept alive by the array. The view is valid while the vector is not resized.
template <typename Element>
py::array vector_view(std::vector<Element>& values, py::handle owner) {
    using Scalar = typename Element::value_type;
    const py::ssize_t channels = Element::channels;
    return py::array_t<Scalar>({py::ssize_t(values.size()), channels},
                               {py::ssize_t(sizeof(Element)), py::ssize_t(sizeof(Scalar))},
                               reinterpret_cast<Scalar*>(values.data()), owner);
}
// Copies an N x channels array into a vector of cv::Vec.
template <typename Element>
std::vector<Element> array_to_vector(const py::array& array, const char* name) {
    using Scalar = typename Element::value_type;
    const auto values = py::array_t<Scalar, py::array::c_style | py::array::forcecast>::ensure(array);
    if (!values || values.ndim() != 2 || values.shape(1) != Element::channels)
        throw py::value_error(std::string(name) + ": expected an N x " + std::to_string(Element::channels) + " array");
    std::vector<Element> result(size_t(values.shape(0)));
    std::memcpy(static_cast<void*>(result.data()), values.data(), result.size() * sizeof(Element));
    return result;
}

// A core progress callback calling `callable(fraction, stage)` with the GIL held; a falsy return
// cancels. None gives no callback. Safe to copy and destroy without the GIL.
ProgressCallback progress_from(const py::object& callable);

void bind_patterns(py::module_& m);
void bind_capture_set(py::module_& m);
void bind_decode(py::module_& m);
void bind_calibration(py::module_& m);
void bind_board(py::module_& m);
void bind_calibrate(py::module_& m);
void bind_calibration_report(py::module_& m);
void bind_response(py::module_& m);
void bind_triangulate(py::module_& m);
void bind_stereo(py::module_& m);
void bind_cloud(py::module_& m);
void bind_clean(py::module_& m);
void bind_simulate(py::module_& m);
void bind_io(py::module_& m);
void bind_preview(py::module_& m);
void bind_fit(py::module_& m);
void bind_register(py::module_& m);
void bind_mesh(py::module_& m);
void bind_shapes(py::module_& m);
void bind_deviation(py::module_& m);
void bind_section_fit(py::module_& m);
void bind_capture(py::module_& m);
void bind_virtual_camera(py::module_& m);
void bind_multi_camera(py::module_& m);
void bind_file_output(py::module_& m);
void bind_error(py::module_& m);
void bind_pipeline(py::module_& m);

}  // namespace picoscan::python

// Type casters: cv::Mat <-> NumPy (out: shares the buffer; in: copied, since the core keeps
// what it is given), cv::Size <-> (width, height), fixed vectors and matrices <-> NumPy (copied).
namespace pybind11::detail {

template <>
struct type_caster<cv::Mat> {
    PYBIND11_TYPE_CASTER(cv::Mat, const_name("numpy.ndarray"));
    bool load(handle source, bool) {
        if (source.is_none()) {
            value = cv::Mat();
            return true;
        }
        if (!isinstance<array>(source)) return false;
        value = picoscan::python::array_to_mat(reinterpret_borrow<array>(source), "array").clone();
        return true;
    }
    static handle cast(const cv::Mat& mat, return_value_policy, handle) {
        return picoscan::python::mat_to_array(mat).release();
    }
};

template <>
struct type_caster<cv::Size> {
    PYBIND11_TYPE_CASTER(cv::Size, const_name("tuple[int, int]"));
    bool load(handle source, bool) {
        if (!isinstance<sequence>(source)) return false;
        const auto items = reinterpret_borrow<sequence>(source);
        if (items.size() != 2) return false;
        value = cv::Size(items[0].cast<int>(), items[1].cast<int>());
        return true;
    }
    static handle cast(const cv::Size& size, return_value_policy, handle) {
        return make_tuple(size.width, size.height).release();
    }
};

template <typename Scalar, int Rows, int Cols>
struct type_caster<cv::Matx<Scalar, Rows, Cols>> {
    using Type = cv::Matx<Scalar, Rows, Cols>;
    PYBIND11_TYPE_CASTER(Type, const_name("numpy.ndarray"));
    bool load(handle source, bool convert) {
        if (!convert && !isinstance<array>(source)) return false;
        const auto values = array_t<double, array::c_style | array::forcecast>::ensure(source);
        if (!values || values.size() != Rows * Cols) return false;
        for (int i = 0; i < Rows * Cols; ++i) value.val[i] = Scalar(values.data()[i]);
        return true;
    }
    static handle cast(const Type& matrix, return_value_policy, handle) {
        std::vector<ssize_t> shape{Rows, Cols};
        if (Cols == 1) shape = {Rows};
        array_t<double> result(shape);
        for (int i = 0; i < Rows * Cols; ++i) result.mutable_data()[i] = double(matrix.val[i]);
        return result.release();
    }
};

// Points <-> tuples (x, y) and (x, y, z); lists of them come with pybind11/stl.h.
template <typename Scalar>
struct type_caster<cv::Point_<Scalar>> {
    using Type = cv::Point_<Scalar>;
    PYBIND11_TYPE_CASTER(Type, const_name("tuple[float, float]"));
    bool load(handle source, bool) {
        if (!isinstance<sequence>(source)) return false;
        const auto items = reinterpret_borrow<sequence>(source);
        if (items.size() != 2) return false;
        value = Type(items[0].cast<Scalar>(), items[1].cast<Scalar>());
        return true;
    }
    static handle cast(const Type& point, return_value_policy, handle) { return make_tuple(point.x, point.y).release(); }
};

template <typename Scalar>
struct type_caster<cv::Point3_<Scalar>> {
    using Type = cv::Point3_<Scalar>;
    PYBIND11_TYPE_CASTER(Type, const_name("tuple[float, float, float]"));
    bool load(handle source, bool) {
        if (!isinstance<sequence>(source)) return false;
        const auto items = reinterpret_borrow<sequence>(source);
        if (items.size() != 3) return false;
        value = Type(items[0].cast<Scalar>(), items[1].cast<Scalar>(), items[2].cast<Scalar>());
        return true;
    }
    static handle cast(const Type& point, return_value_policy, handle) {
        return make_tuple(point.x, point.y, point.z).release();
    }
};

template <typename Scalar, int Count>
struct type_caster<cv::Vec<Scalar, Count>> {
    using Type = cv::Vec<Scalar, Count>;
    PYBIND11_TYPE_CASTER(Type, const_name("numpy.ndarray"));
    bool load(handle source, bool convert) {
        if (!convert && !isinstance<array>(source)) return false;
        const auto values = array_t<double, array::c_style | array::forcecast>::ensure(source);
        if (!values || values.size() != Count) return false;
        for (int i = 0; i < Count; ++i) value[i] = Scalar(values.data()[i]);
        return true;
    }
    static handle cast(const Type& vector, return_value_policy, handle) {
        array_t<double> result(std::vector<ssize_t>{Count});
        for (int i = 0; i < Count; ++i) result.mutable_data()[i] = double(vector[i]);
        return result.release();
    }
};

}  // namespace pybind11::detail
