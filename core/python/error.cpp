#include "bindings.h"

#include "picoscan/error.h"

namespace picoscan::python {

// picoscan.Error (a RuntimeError) carries the core's one-line message; OpenCV's exceptions
// arrive as the same type, prefixed "OpenCV: ".
void bind_error(py::module_& m) {
    static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
    py::register_exception_translator([](std::exception_ptr pointer) {
        try {
            if (pointer) std::rethrow_exception(pointer);
        } catch (const Error& caught) {
            error(caught.what());
        } catch (const cv::Exception& caught) {
            PyErr_SetString(error.ptr(), (std::string("OpenCV: ") + caught.err).c_str());
        }
    });
}

}  // namespace picoscan::python
