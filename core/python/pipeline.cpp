#include "bindings.h"

#include "picoscan/error.h"
#include "picoscan/pipeline.h"

#include <pybind11/functional.h>

#include <memory>

namespace picoscan::python {

namespace {

// A Python callable view_at(index) -> ScanView as the core's ViewSource, called with the GIL
// held; an answer that is not a ScanView is refused with what it was.
ViewSource view_source_from(const py::object& callable) {
    if (!PyCallable_Check(callable.ptr())) throw Error("view_at", "must be a callable taking a view index, got " +
                                                                   std::string(py::str(py::type::of(callable).attr("__name__"))));
    // Copies of the core's std::function share this holder; it is released with the GIL held.
    std::shared_ptr<py::object> holder(new py::object(callable), [](py::object* object) {
        py::gil_scoped_acquire gil;
        delete object;
    });
    return [holder](size_t index) {
        py::gil_scoped_acquire gil;
        const py::object view = (*holder)(index);
        if (!py::isinstance<ScanView>(view))
            throw Error("view_at", "must return a picoscan.ScanView, returned " +
                                       std::string(py::str(py::type::of(view).attr("__name__"))) + " for view " +
                                       std::to_string(index));
        return view.cast<ScanView>();
    };
}

}  // namespace

void bind_pipeline(py::module_& m) {
    py::class_<SecondCamera>(m, "SecondCamera", "A second camera on the same projector, calibrated with it.")
        .def(py::init<>())
        .def_readwrite("calibration", &SecondCamera::calibration)
        .def_readwrite("calibration_name", &SecondCamera::calibration_name)
        .def_readwrite("captures_folder", &SecondCamera::captures_folder);
    py::class_<ReconstructOptions>(m, "ReconstructOptions")
        .def(py::init<>())
        .def_readwrite("manifest_path", &ReconstructOptions::manifest_path)
        .def_readwrite("decode", &ReconstructOptions::decode)
        .def_readwrite("triangulate", &ReconstructOptions::triangulate)
        .def_readwrite("second_camera", &ReconstructOptions::second_camera)
        .def_readwrite("clean", &ReconstructOptions::clean)
        .def_readwrite("cleaning", &ReconstructOptions::cleaning);
    py::class_<ReconstructResult>(m, "ReconstructResult")
        .def_readonly("view", &ReconstructResult::view)
        .def_readonly("order_corrections", &ReconstructResult::order_corrections)
        .def_readonly("unconfirmed_removed", &ReconstructResult::unconfirmed_removed)
        .def_readonly("cleaning", &ReconstructResult::cleaning)
        .def_readonly("point_count", &ReconstructResult::point_count);
    m.def(
        "reconstruct_view",
        [](const std::string& captures_folder, const Calibration& calibration, const std::string& calibration_name,
           const ReconstructOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return reconstruct_view(captures_folder, calibration, calibration_name, options, callback);
        },
        py::arg("captures_folder"), py::arg("calibration"), py::arg("calibration_name"),
        py::arg("options") = ReconstructOptions(), py::arg("progress") = py::none(),
        "Size check, decode, triangulate, second camera, clean: one view from a capture folder.");

    py::class_<StereoReconstructOptions>(m, "StereoReconstructOptions")
        .def(py::init<>())
        .def_readwrite("manifest_path", &StereoReconstructOptions::manifest_path)
        .def_readwrite("second_manifest_path", &StereoReconstructOptions::second_manifest_path)
        .def_readwrite("decode", &StereoReconstructOptions::decode)
        .def_readwrite("stereo", &StereoReconstructOptions::stereo)
        .def_readwrite("refine_pose", &StereoReconstructOptions::refine_pose)
        .def_readwrite("projector", &StereoReconstructOptions::projector)
        .def_readwrite("clean", &StereoReconstructOptions::clean)
        .def_readwrite("cleaning", &StereoReconstructOptions::cleaning);
    py::class_<StereoReconstructResult>(m, "StereoReconstructResult")
        .def_readonly("view", &StereoReconstructResult::view)
        .def_readonly("statistics", &StereoReconstructResult::statistics)
        .def_readonly("refinement", &StereoReconstructResult::refinement)
        .def_readonly("cleaning", &StereoReconstructResult::cleaning)
        .def_readonly("point_count", &StereoReconstructResult::point_count);
    m.def(
        "reconstruct_stereo_view",
        [](const std::string& first_folder, const std::string& second_folder, const StereoCalibration& calibration,
           const std::string& calibration_name, const StereoReconstructOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return reconstruct_stereo_view(first_folder, second_folder, calibration, calibration_name, options, callback);
        },
        py::arg("first_folder"), py::arg("second_folder"), py::arg("calibration"), py::arg("calibration_name"),
        py::arg("options") = StereoReconstructOptions(), py::arg("progress") = py::none());

    py::class_<FuseResult>(m, "FuseResult")
        .def_readonly("merged", &FuseResult::merged)
        .def_readonly("mesh", &FuseResult::mesh)
        .def_readonly("check", &FuseResult::check);
    m.def(
        "fuse_views",
        [](const std::vector<ScanView>& views, const MeshOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return fuse_views(views, options, callback);
        },
        py::arg("views"), py::arg("options") = MeshOptions(), py::arg("progress") = py::none(),
        "Posed views merged (each through its pose) and meshed, with the mesh's check.");
    m.def(
        "fuse_views",
        [](size_t view_count, const py::object& view_at, const MeshOptions& options, const py::object& progress) {
            const ViewSource source = view_source_from(view_at);
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return fuse_views(view_count, source, options, callback);
        },
        py::arg("view_count"), py::arg("view_at"), py::arg("options") = MeshOptions(), py::arg("progress") = py::none(),
        "The same, the views asked for one at a time: view_at(i) returns view i (e.g. read from its file), "
        "and each is let go before the next is asked for, so 16-32 full views need not fit in memory at once.");
    m.def(
        "fuse_view_files",
        [](const std::vector<std::string>& paths, const MeshOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return fuse_view_files(paths, options, callback);
        },
        py::arg("paths"), py::arg("options") = MeshOptions(), py::arg("progress") = py::none(),
        "fuse_views over view PLY files (write_view_ply, each with its pose), read one at a time.");

    py::class_<CleanScanOptions>(m, "CleanScanOptions")
        .def(py::init<>())
        .def_readwrite("cleaning", &CleanScanOptions::cleaning)
        .def_readwrite("background_tolerance_mm", &CleanScanOptions::background_tolerance_mm);
    py::class_<CleanScanResult>(m, "CleanScanResult")
        .def_readonly("background_removed", &CleanScanResult::background_removed)
        .def_readonly("report", &CleanScanResult::report);
    m.def(
        "clean_scan",
        [](ScanView& view, const std::string& view_name, const CleanScanOptions& options, const ScanView* background) {
            py::gil_scoped_release release;
            return clean_scan(view, view_name, options, background);
        },
        py::arg("view"), py::arg("view_name"), py::arg("options") = CleanScanOptions(), py::arg("background") = nullptr,
        "Background removal (with a view of the empty scene), then clean_view, in place.");

    py::class_<SimulateOptions>(m, "SimulateOptions")
        .def(py::init<>())
        .def_readwrite("patterns", &SimulateOptions::patterns)
        .def_readwrite("camera", &SimulateOptions::camera);
    m.def(
        "simulate_captures",
        [](const Scene& scene, const Calibration& calibration, const SimulateOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return simulate_captures(scene, calibration, options, callback);
        },
        py::arg("scene"), py::arg("calibration"), py::arg("options") = SimulateOptions(), py::arg("progress") = py::none());
    py::class_<TurntableScanOptions>(m, "TurntableScanOptions")
        .def(py::init<>())
        .def_readwrite("plan", &TurntableScanOptions::plan)
        .def_readwrite("patterns", &TurntableScanOptions::patterns)
        .def_readwrite("camera", &TurntableScanOptions::camera)
        .def_readwrite("decode", &TurntableScanOptions::decode)
        .def_readwrite("part_albedo", &TurntableScanOptions::part_albedo);
    py::class_<SimulatedView>(m, "SimulatedView")
        .def_readonly("name", &SimulatedView::name)
        .def_readonly("captures", &SimulatedView::captures)
        .def_readonly("view", &SimulatedView::view)
        .def_readonly("cleaning", &SimulatedView::cleaning)
        .def_readonly("part_to_camera", &SimulatedView::part_to_camera);
    m.def(
        "simulate_turntable_scan",
        [](const Mesh& part, const Calibration& calibration, const TurntableScanOptions& options,
           const std::function<void(const SimulatedView&)>& on_view, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return simulate_turntable_scan(part, calibration, options, on_view, callback);
        },
        py::arg("part"), py::arg("calibration"), py::arg("options"), py::arg("on_view"), py::arg("progress") = py::none(),
        "Simulates each turntable view and hands it to on_view; returns the true part->camera poses.");

    py::class_<ForeignPresetOptions>(m, "ForeignPresetOptions")
        .def(py::init<>())
        .def_readwrite("preset", &ForeignPresetOptions::preset)
        .def_readwrite("projector_size", &ForeignPresetOptions::projector_size)
        .def_readwrite("file_prefix", &ForeignPresetOptions::file_prefix)
        .def_readwrite("file_suffix", &ForeignPresetOptions::file_suffix)
        .def_readwrite("first_index", &ForeignPresetOptions::first_index)
        .def_readwrite("gray_bits", &ForeignPresetOptions::gray_bits)
        .def_readwrite("periods", &ForeignPresetOptions::periods)
        .def_readwrite("shifts", &ForeignPresetOptions::shifts);
    m.def("foreign_preset_names", &foreign_preset_names);
    m.def("foreign_preset_sequence", &foreign_preset_sequence, py::arg("options"));

    py::class_<StitchOptions>(m, "StitchOptions")
        .def(py::init<>())
        .def_readwrite("registration", &StitchOptions::registration)
        .def_readwrite("turntable", &StitchOptions::turntable)
        .def_readwrite("placement_of_view", &StitchOptions::placement_of_view)
        .def_readwrite("automatic", &StitchOptions::automatic);
    py::class_<StitchAttempt>(m, "StitchAttempt")
        .def_readonly("placement", &StitchAttempt::placement)
        .def_readonly("method", &StitchAttempt::method)
        .def_readonly("aligned_views", &StitchAttempt::aligned_views)
        .def_readonly("views", &StitchAttempt::views)
        .def_readonly("problem", &StitchAttempt::problem)
        .def_readonly("kept", &StitchAttempt::kept);
    py::class_<StitchResult>(m, "StitchResult")
        .def_readonly("alignment", &StitchResult::alignment)
        .def_readonly("merged", &StitchResult::merged)
        .def_readonly("merged_views", &StitchResult::merged_views)
        .def_readonly("axis", &StitchResult::axis)
        .def_readonly("attempts", &StitchResult::attempts)
        .def_readonly("method_of_view", &StitchResult::method_of_view);
    m.def(
        "stitch_views",
        [](const std::vector<ScanView>& views, const std::vector<std::string>& names, const StitchOptions& options,
           const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return stitch_views(views, names, options, callback);
        },
        py::arg("views"), py::arg("names"), py::arg("options") = StitchOptions(), py::arg("progress") = py::none());
    m.def(
        "mesh_view",
        [](const ScanView& view, const MeshOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return mesh_view(view, options, callback);
        },
        py::arg("view"), py::arg("options") = MeshOptions(), py::arg("progress") = py::none());

    m.def(
        "mesh_points",
        [](const PointCloud& cloud, const MeshOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return mesh_points(cloud, options, callback);
        },
        py::arg("cloud"), py::arg("options") = MeshOptions(), py::arg("progress") = py::none());

    py::class_<PartFrameOptions>(m, "PartFrameOptions")
        .def(py::init<>())
        .def_readwrite("max_points", &PartFrameOptions::max_points)
        .def_readwrite("plane_epsilon_mm", &PartFrameOptions::plane_epsilon_mm)
        .def_readwrite("min_plane_share", &PartFrameOptions::min_plane_share);
    py::class_<PartFrame>(m, "PartFrame")
        .def_readonly("frame", &PartFrame::frame)
        .def_readonly("basis", &PartFrame::basis);
    m.def(
        "part_frame",
        [](const PointCloud& cloud, const std::optional<TurntableAxis>& turntable, const PartFrameOptions& options,
           const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return part_frame(cloud, turntable, options, callback);
        },
        py::arg("cloud"), py::arg("turntable") = py::none(), py::arg("options") = PartFrameOptions(),
        py::arg("progress") = py::none(), "The scan's part frame, Z up: on the turntable's axis, else on its base plane");

    m.def("grown_face_selection", &grown_face_selection, "The default region: the face under the point, within 30 mm");
    py::class_<PickedFitOptions>(m, "PickedFitOptions")
        .def(py::init<>())
        .def_readwrite("selection", &PickedFitOptions::selection)
        .def_readwrite("fit", &PickedFitOptions::fit);
    py::class_<PickedFit>(m, "PickedFit")
        .def_readonly("region", &PickedFit::region)
        .def_readonly("fit", &PickedFit::fit);
    m.def(
        "fit_at_point",
        [](const PointCloud& cloud, const cv::Vec3d& seed, const PickedFitOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return fit_at_point(cloud, seed, options, callback);
        },
        py::arg("cloud"), py::arg("seed"), py::arg("options") = PickedFitOptions(), py::arg("progress") = py::none(),
        "The region around a picked point (grown, a ball or a box) fitted with a plane, cylinder, sphere or cone");
    m.def(
        "fit_in_lasso",
        [](const PointCloud& cloud, const cv::Matx44d& cloud_to_screen, const std::vector<cv::Vec2d>& polygon,
           const PickedFitOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return fit_in_lasso(cloud, cloud_to_screen, polygon, options, callback);
        },
        py::arg("cloud"), py::arg("cloud_to_screen"), py::arg("polygon"), py::arg("options") = PickedFitOptions(),
        py::arg("progress") = py::none(), "The points under a lasso drawn on the screen, fitted");

    // validate(options) for every options struct: raises picoscan.Error naming the field.
    m.def("validate", py::overload_cast<const PatternOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const DecodeOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const PartFrameOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const SimulationOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const CleanOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const RegistrationOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const MeshOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const ReconstructOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const SimulateOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const StitchOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const CleanScanOptions&>(&validate), py::arg("options"));
    m.def("validate", py::overload_cast<const PickedFitOptions&>(&validate), py::arg("options"));
}

}  // namespace picoscan::python
