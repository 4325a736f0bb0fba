#include "bindings.h"

#include "picoscan/progress.h"

#include <memory>

namespace picoscan::python {

ProgressCallback progress_from(const py::object& callable) {
    if (callable.is_none()) return nullptr;
    // Copies of the core's std::function share this holder; it is released with the GIL held.
    std::shared_ptr<py::object> holder(new py::object(callable), [](py::object* object) {
        py::gil_scoped_acquire gil;
        delete object;
    });
    return [holder](double fraction, const std::string& stage) {
        py::gil_scoped_acquire gil;
        const py::object answer = (*holder)(fraction, stage);
        return answer.is_none() || answer.cast<bool>();
    };
}

}  // namespace picoscan::python
