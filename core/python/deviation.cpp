#include "bindings.h"

#include "picoscan/deviation.h"

namespace picoscan::python {

void bind_deviation(py::module_& m) {
    py::class_<DeviationOptions>(m, "DeviationOptions")
        .def(py::init<>())
        .def_readwrite("tolerance_mm", &DeviationOptions::tolerance_mm)
        .def_readwrite("max_distance_mm", &DeviationOptions::max_distance_mm)
        .def_readwrite("histogram_bins", &DeviationOptions::histogram_bins)
        .def_readwrite("range_mm", &DeviationOptions::range_mm);
    py::class_<DeviationStatistics>(m, "DeviationStatistics")
        .def_readonly("count", &DeviationStatistics::count)
        .def_readonly("ignored", &DeviationStatistics::ignored)
        .def_readonly("mean_mm", &DeviationStatistics::mean_mm)
        .def_readonly("mean_abs_mm", &DeviationStatistics::mean_abs_mm)
        .def_readonly("sigma_mm", &DeviationStatistics::sigma_mm)
        .def_readonly("p95_abs_mm", &DeviationStatistics::p95_abs_mm)
        .def_readonly("max_abs_mm", &DeviationStatistics::max_abs_mm)
        .def_readonly("min_mm", &DeviationStatistics::min_mm)
        .def_readonly("max_mm", &DeviationStatistics::max_mm)
        .def_readonly("within_tolerance", &DeviationStatistics::within_tolerance, "fraction 0..1");
    py::class_<DeviationMap>(m, "DeviationMap", "Signed distances (mm) of points to a reference; NaN = ignored.")
        .def_property_readonly("distances_mm",
                               [](py::object self) {
                                   auto& d = self.cast<DeviationMap&>().distances_mm;
                                   return py::array_t<float>({py::ssize_t(d.size())}, {py::ssize_t(sizeof(float))}, d.data(), self);
                               })
        .def_readonly("statistics", &DeviationMap::statistics)
        .def_readonly("tolerance_mm", &DeviationMap::tolerance_mm)
        .def_readonly("range_mm", &DeviationMap::range_mm)
        .def_readonly("histogram", &DeviationMap::histogram)
        .def_readonly("below_range", &DeviationMap::below_range)
        .def_readonly("above_range", &DeviationMap::above_range)
        .def("colours", [](const DeviationMap& map) {
            std::vector<cv::Vec3b> colours = deviation_colours(map);
            py::array_t<uint8_t> result({py::ssize_t(colours.size()), py::ssize_t(3)});
            std::memcpy(result.mutable_data(), colours.data(), colours.size() * 3);
            return result;
        }, "N x 3 uint8 RGB colours of the map's scale")
        .def("histogram_image", &plot_deviation_histogram, py::arg("title"), "BGR picture of the histogram with the legend");
    m.def(
        "deviation_colour",
        [](double distance_mm, double tolerance_mm, double range_mm) {
            const cv::Vec3b colour = deviation_colour(distance_mm, tolerance_mm, range_mm);
            return py::make_tuple(int(colour[0]), int(colour[1]), int(colour[2]));
        },
        py::arg("distance_mm"), py::arg("tolerance_mm"), py::arg("range_mm"),
        "(r, g, b) 0..255 of a signed distance on a map's colour scale (as DeviationMap.colours)");
    m.def(
        "measure_deviation",
        [](const py::array& points, const Mesh& reference, const DeviationOptions& options, const py::object& progress) {
            const std::vector<cv::Vec3f> values = array_to_vector<cv::Vec3f>(points, "points");
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return measure_deviation(values, reference, options, callback);
        },
        py::arg("points"), py::arg("reference"), py::arg("options") = DeviationOptions(), py::arg("progress") = py::none(),
        "Signed distance of every point (N x 3) to the reference mesh's triangles");
    py::class_<BestFitOptions>(m, "BestFitOptions")
        .def(py::init<>())
        .def_readwrite("max_iterations", &BestFitOptions::max_iterations)
        .def_readwrite("keep_fraction", &BestFitOptions::keep_fraction)
        .def_readwrite("max_distance_mm", &BestFitOptions::max_distance_mm)
        .def_readwrite("max_points", &BestFitOptions::max_points)
        .def_readwrite("converged_deg", &BestFitOptions::converged_deg)
        .def_readwrite("converged_mm", &BestFitOptions::converged_mm);
    py::class_<BestFit>(m, "BestFit")
        .def_readonly("transform", &BestFit::transform, "4 x 4: moves the points onto the reference")
        .def_readonly("rms_mm", &BestFit::rms_mm)
        .def_readonly("pairs", &BestFit::pairs)
        .def_readonly("iterations", &BestFit::iterations)
        .def_readonly("converged", &BestFit::converged);
    m.def(
        "best_fit_to_reference",
        [](const py::array& points, const Mesh& reference, const BestFitOptions& options, const py::object& progress) {
            const std::vector<cv::Vec3f> values = array_to_vector<cv::Vec3f>(points, "points");
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return best_fit_to_reference(values, reference, options, callback);
        },
        py::arg("points"), py::arg("reference"), py::arg("options") = BestFitOptions(), py::arg("progress") = py::none(),
        "Trimmed point-to-plane ICP of the points (N x 3) onto the reference mesh");
    m.def(
        "write_deviation_ply",
        [](const py::array& points, const DeviationMap& map, const std::string& path) {
            const std::vector<cv::Vec3f> values = array_to_vector<cv::Vec3f>(points, "points");
            py::gil_scoped_release release;
            write_deviation_ply(values, map, path);
        },
        py::arg("points"), py::arg("map"), py::arg("path"));
    m.def("write_deviation_report", &write_deviation_report, py::arg("map"), py::arg("title"), py::arg("html_path"),
          py::call_guard<py::gil_scoped_release>(), "HTML report and <html_path>.png histogram");
}

}  // namespace picoscan::python
