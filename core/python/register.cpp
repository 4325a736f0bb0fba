#include "bindings.h"

#include "picoscan/register.h"

namespace picoscan::python {

void bind_register(py::module_& m) {
    py::class_<RegistrationOptions>(m, "RegistrationOptions")
        .def(py::init<>())
        .def_readwrite("orb_features", &RegistrationOptions::orb_features)
        .def_readwrite("ransac_inlier_mm", &RegistrationOptions::ransac_inlier_mm)
        .def_readwrite("ransac_iterations", &RegistrationOptions::ransac_iterations)
        .def_readwrite("min_ransac_inliers", &RegistrationOptions::min_ransac_inliers)
        .def_readwrite("icp_iterations", &RegistrationOptions::icp_iterations)
        .def_readwrite("icp_trim_fraction", &RegistrationOptions::icp_trim_fraction)
        .def_readwrite("icp_max_distance_mm", &RegistrationOptions::icp_max_distance_mm)
        .def_readwrite("sample_spacing_mm", &RegistrationOptions::sample_spacing_mm)
        .def_readwrite("min_overlap", &RegistrationOptions::min_overlap)
        .def_readwrite("global_sweeps", &RegistrationOptions::global_sweeps)
        .def_readwrite("initial_poses", &RegistrationOptions::initial_poses)
        .def_readwrite("turntable_round", &RegistrationOptions::turntable_round);
    py::class_<PairRegistration>(m, "PairRegistration")
        .def_readonly("transform", &PairRegistration::transform)
        .def_readonly("feature_matches", &PairRegistration::feature_matches)
        .def_readonly("ransac_inliers", &PairRegistration::ransac_inliers)
        .def_readonly("overlap", &PairRegistration::overlap)
        .def_readonly("rms_mm", &PairRegistration::rms_mm)
        .def_readonly("texture_agreement", &PairRegistration::texture_agreement)
        .def_readonly("converged", &PairRegistration::converged)
        .def_readonly("free_space_conflict", &PairRegistration::free_space_conflict)
        .def_readonly("stability", &PairRegistration::stability)
        .def_readonly("alternatives", &PairRegistration::alternatives)
        .def_readonly("problem", &PairRegistration::problem);
    m.def("register_pair", &register_pair, py::arg("fixed"), py::arg("moving"), py::arg("options") = RegistrationOptions(),
          py::arg("initial_guess") = py::none(), py::call_guard<py::gil_scoped_release>());
    py::class_<TurntableAxis>(m, "TurntableAxis")
        .def(py::init<>())
        .def_readwrite("point_mm", &TurntableAxis::point_mm)
        .def_readwrite("direction", &TurntableAxis::direction)
        .def_readwrite("step_deg", &TurntableAxis::step_deg);
    m.def("turntable_pose", &turntable_pose, py::arg("axis"), py::arg("step"));
    m.def("fit_turntable_axis", &fit_turntable_axis, py::arg("poses"), py::arg("max_axis_spread_deg") = 1.0);
    py::class_<ViewAlignment>(m, "ViewAlignment")
        .def_readonly("name", &ViewAlignment::name)
        .def_readonly("pose", &ViewAlignment::pose)
        .def_readonly("aligned", &ViewAlignment::aligned)
        .def_readonly("overlap", &ViewAlignment::overlap)
        .def_readonly("rms_mm", &ViewAlignment::rms_mm)
        .def_readonly("problem", &ViewAlignment::problem)
        .def_readonly("placement", &ViewAlignment::placement);
    py::class_<PlacementAlignment>(m, "PlacementAlignment")
        .def_readonly("name", &PlacementAlignment::name)
        .def_readonly("aligned", &PlacementAlignment::aligned)
        .def_readonly("pose", &PlacementAlignment::pose)
        .def_readonly("aligned_views", &PlacementAlignment::aligned_views)
        .def_readonly("overlap", &PlacementAlignment::overlap)
        .def_readonly("rms_mm", &PlacementAlignment::rms_mm)
        .def_readonly("noise_mm", &PlacementAlignment::noise_mm)
        .def_readonly("free_space_conflict", &PlacementAlignment::free_space_conflict)
        .def_readonly("stability", &PlacementAlignment::stability)
        .def_readonly("alternatives", &PlacementAlignment::alternatives)
        .def_readonly("problem", &PlacementAlignment::problem);
    py::class_<PlacementPlan>(m, "PlacementPlan")
        .def(py::init<>())
        .def_readwrite("views", &PlacementPlan::views)
        .def_readwrite("turntable", &PlacementPlan::turntable)
        .def_readwrite("turntable_round", &PlacementPlan::turntable_round);
    py::class_<Alignment>(m, "Alignment")
        .def_readonly("views", &Alignment::views)
        .def_readonly("turntable_step", &Alignment::turntable_step)
        .def_readonly("turntable_supporting_pairs", &Alignment::turntable_supporting_pairs)
        .def_readonly("placements", &Alignment::placements)
        .def("aligned_count", &Alignment::aligned_count);
    m.def(
        "align_views",
        [](const std::vector<ScanView>& views, const std::vector<std::string>& names, const RegistrationOptions& options,
           const std::optional<TurntableAxis>& turntable, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return align_views(views, names, options, turntable, callback);
        },
        py::arg("views"), py::arg("names"), py::arg("options") = RegistrationOptions(), py::arg("turntable") = py::none(),
        py::arg("progress") = py::none());
    m.def(
        "align_placements",
        [](const std::vector<ScanView>& views, const std::vector<std::string>& names,
           const std::vector<PlacementPlan>& placements, const RegistrationOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return align_placements(views, names, placements, options, callback);
        },
        py::arg("views"), py::arg("names"), py::arg("placements"), py::arg("options") = RegistrationOptions(),
        py::arg("progress") = py::none());
    py::class_<PoseDifference>(m, "PoseDifference")
        .def_readonly("rotation_deg", &PoseDifference::rotation_deg)
        .def_readonly("translation_mm", &PoseDifference::translation_mm);
    m.def("pose_difference", &pose_difference, py::arg("a"), py::arg("b"), py::arg("at") = cv::Vec3d(0, 0, 0));
}

}  // namespace picoscan::python
