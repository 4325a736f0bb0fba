#include "bindings.h"

#include "picoscan/simulate.h"

namespace picoscan::python {

void bind_simulate(py::module_& m) {
    py::class_<Sphere>(m, "Sphere")
        .def(py::init<>())
        .def_readwrite("centre", &Sphere::centre)
        .def_readwrite("radius_mm", &Sphere::radius_mm)
        .def_readwrite("albedo", &Sphere::albedo);
    py::class_<Plane>(m, "Plane")
        .def(py::init<>())
        .def_readwrite("point", &Plane::point)
        .def_readwrite("normal", &Plane::normal)
        .def_readwrite("albedo", &Plane::albedo);
    py::class_<Box>(m, "Box")
        .def(py::init<>())
        .def_readwrite("centre", &Box::centre)
        .def_readwrite("half_size_mm", &Box::half_size_mm)
        .def_readwrite("rotation", &Box::rotation)
        .def_readwrite("albedo", &Box::albedo);
    py::class_<Cylinder>(m, "Cylinder", "A capped cylinder")
        .def(py::init<>())
        .def_readwrite("base_centre", &Cylinder::base_centre)
        .def_readwrite("axis", &Cylinder::axis)
        .def_readwrite("radius_mm", &Cylinder::radius_mm)
        .def_readwrite("height_mm", &Cylinder::height_mm)
        .def_readwrite("albedo", &Cylinder::albedo);
    py::class_<TriangleMesh>(m, "TriangleMesh", "A mesh in the scene; vertex colours paint it")
        .def(py::init<>())
        .def_readwrite("mesh", &TriangleMesh::mesh)
        .def_readwrite("albedo", &TriangleMesh::albedo);
    py::class_<CalibrationBoard>(m, "CalibrationBoard", "A chessboard: camera point = rotation * board point + translation")
        .def(py::init<>())
        .def_readwrite("rotation", &CalibrationBoard::rotation)
        .def_readwrite("translation", &CalibrationBoard::translation)
        .def_readwrite("inner_corners", &CalibrationBoard::inner_corners)
        .def_readwrite("square_mm", &CalibrationBoard::square_mm)
        .def_readwrite("margin_mm", &CalibrationBoard::margin_mm)
        .def_readwrite("dark_albedo", &CalibrationBoard::dark_albedo)
        .def_readwrite("light_albedo", &CalibrationBoard::light_albedo);
    m.def("chessboard_corners", &chessboard_corners, py::arg("board"));

    // The lists are copied on access (scene.spheres = [...] works; scene.spheres.append does not):
    // the add_* methods append.
    py::class_<Scene>(m, "Scene", "Analytic shapes in camera coordinates (mm) for the simulator.")
        .def(py::init<>())
        .def_readwrite("spheres", &Scene::spheres)
        .def_readwrite("planes", &Scene::planes)
        .def_readwrite("boxes", &Scene::boxes)
        .def_readwrite("cylinders", &Scene::cylinders)
        .def_readwrite("meshes", &Scene::meshes)
        .def_readwrite("boards", &Scene::boards)
        .def(
            "add_sphere",
            [](Scene& s, const cv::Vec3d& centre, double radius_mm, double albedo) {
                s.spheres.push_back({centre, radius_mm, albedo});
            },
            py::arg("centre"), py::arg("radius_mm"), py::arg("albedo") = 0.8)
        .def(
            "add_plane",
            [](Scene& s, const cv::Vec3d& point, const cv::Vec3d& normal, double albedo) {
                s.planes.push_back({point, normal, albedo});
            },
            py::arg("point"), py::arg("normal"), py::arg("albedo") = 0.8)
        .def(
            "add_box",
            [](Scene& s, const cv::Vec3d& centre, const cv::Vec3d& half_size_mm, const cv::Matx33d& rotation,
               double albedo) { s.boxes.push_back({centre, half_size_mm, rotation, albedo}); },
            py::arg("centre"), py::arg("half_size_mm"), py::arg("rotation") = cv::Matx33d::eye(), py::arg("albedo") = 0.8)
        .def(
            "add_cylinder",
            [](Scene& s, const cv::Vec3d& base_centre, const cv::Vec3d& axis, double radius_mm, double height_mm,
               double albedo) { s.cylinders.push_back({base_centre, axis, radius_mm, height_mm, albedo}); },
            py::arg("base_centre"), py::arg("axis"), py::arg("radius_mm"), py::arg("height_mm"), py::arg("albedo") = 0.8)
        .def(
            "add_board",
            [](Scene& s, const cv::Matx33d& rotation, const cv::Vec3d& translation, const cv::Size& inner_corners,
               double square_mm, double margin_mm) {
                CalibrationBoard board;
                board.rotation = rotation;
                board.translation = translation;
                board.inner_corners = inner_corners;
                board.square_mm = square_mm;
                board.margin_mm = margin_mm;
                s.boards.push_back(board);
            },
            py::arg("rotation"), py::arg("translation"), py::arg("inner_corners") = cv::Size(9, 6),
            py::arg("square_mm") = 10.0, py::arg("margin_mm") = 10.0,
            "A chessboard: camera point = rotation * board point + translation (board z = 0 on its face)")
        .def(
            "add_mesh", [](Scene& s, const Mesh& mesh, double albedo) { s.meshes.push_back({mesh, albedo}); },
            py::arg("mesh"), py::arg("albedo") = 0.8, "A triangle mesh (vertex colours paint it), camera frame")
        .def_property_readonly("shape_count", [](const Scene& s) {
            return s.spheres.size() + s.planes.size() + s.boxes.size() + s.cylinders.size() + s.meshes.size() + s.boards.size();
        });
    m.def("demo_scene", &demo_scene);
    py::class_<MechanicalPartShape>(m, "MechanicalPartShape", "Dimensions of the built-in test part (mm)")
        .def(py::init<>())
        .def_readwrite("length_mm", &MechanicalPartShape::length_mm)
        .def_readwrite("width_mm", &MechanicalPartShape::width_mm)
        .def_readwrite("height_mm", &MechanicalPartShape::height_mm)
        .def_readwrite("chamfer_mm", &MechanicalPartShape::chamfer_mm)
        .def_readwrite("hole_centre_mm", &MechanicalPartShape::hole_centre_mm)
        .def_readwrite("hole_diameter_mm", &MechanicalPartShape::hole_diameter_mm)
        .def_readwrite("boss_centre_mm", &MechanicalPartShape::boss_centre_mm)
        .def_readwrite("boss_diameter_mm", &MechanicalPartShape::boss_diameter_mm)
        .def_readwrite("boss_height_mm", &MechanicalPartShape::boss_height_mm)
        .def_readwrite("paint_seed", &MechanicalPartShape::paint_seed);
    m.def("mechanical_part", &mechanical_part, py::arg("shape") = MechanicalPartShape(),
          "The built-in speckle-painted test part (block, chamfer, hole, boss), part frame, z up");
    py::enum_<PartPlacement>(m, "PartPlacement")
        .value("Standing", PartPlacement::Standing)
        .value("UpsideDown", PartPlacement::UpsideDown)
        .value("OnItsSide", PartPlacement::OnItsSide);
    py::class_<TurntablePlan>(m, "TurntablePlan")
        .def(py::init<>())
        .def_readwrite("placement", &TurntablePlan::placement)
        .def_readwrite("placement_turn_deg", &TurntablePlan::placement_turn_deg)
        .def_readwrite("turntable_views", &TurntablePlan::turntable_views)
        .def_readwrite("elevation_deg", &TurntablePlan::elevation_deg)
        .def_readwrite("top_view", &TurntablePlan::top_view)
        .def_readwrite("top_elevation_deg", &TurntablePlan::top_elevation_deg)
        .def_readwrite("max_disturbance_deg", &TurntablePlan::max_disturbance_deg)
        .def_readwrite("max_disturbance_mm", &TurntablePlan::max_disturbance_mm)
        .def_readwrite("part_centre_mm", &TurntablePlan::part_centre_mm)
        .def_readwrite("part_middle_height_mm", &TurntablePlan::part_middle_height_mm)
        .def_readwrite("seed", &TurntablePlan::seed);
    m.def("turntable_part_poses", &turntable_part_poses, py::arg("plan"), "Part -> camera transform of each view");
    m.def("transformed", py::overload_cast<const Scene&, const cv::Matx44d&>(&transformed), py::arg("scene"),
          py::arg("transform"));
    m.def("read_scene", &read_scene, py::arg("path"));
    m.def("seed_rig_calibration", &seed_rig_calibration);
    py::class_<SeedStereoRig>(m, "SeedStereoRig", "Two seed-like cameras with the seed projector between them.")
        .def(py::init<>())
        .def_readwrite("left", &SeedStereoRig::left)
        .def_readwrite("right", &SeedStereoRig::right)
        .def_readwrite("stereo", &SeedStereoRig::stereo);
    m.def("seed_stereo_rig", &seed_stereo_rig, py::arg("baseline_mm") = 200.0);

    py::class_<SimulationOptions>(m, "SimulationOptions")
        .def(py::init<>())
        .def_readwrite("full_scale_dn", &SimulationOptions::full_scale_dn)
        .def_readwrite("ambient_dn", &SimulationOptions::ambient_dn)
        .def_readwrite("projector_black", &SimulationOptions::projector_black)
        .def_readwrite("projector_gamma", &SimulationOptions::projector_gamma)
        .def_readwrite("noise_sigma_dn", &SimulationOptions::noise_sigma_dn)
        .def_readwrite("blur_sigma_px", &SimulationOptions::blur_sigma_px)
        .def_readwrite("bit_depth", &SimulationOptions::bit_depth)
        .def_readwrite("seed", &SimulationOptions::seed);
    py::class_<SimulatedGeometry>(m, "SimulatedGeometry", "Ground truth per camera pixel")
        .def_readonly("points", &SimulatedGeometry::points)
        .def_readonly("normals", &SimulatedGeometry::normals)
        .def_readonly("projector", &SimulatedGeometry::projector)
        .def_readonly("lit", &SimulatedGeometry::lit)
        .def_readonly("shading", &SimulatedGeometry::shading)
        .def_readonly("albedo", &SimulatedGeometry::albedo);
    py::class_<Simulator>(m, "Simulator", "Ray-casts the scene once; render() then samples each pattern")
        .def(py::init<const Calibration&, const Scene&, const SimulationOptions&>(), py::arg("calibration"),
             py::arg("scene"), py::arg("options") = SimulationOptions(), py::call_guard<py::gil_scoped_release>())
        .def("geometry", &Simulator::geometry, py::return_value_policy::reference_internal)
        .def("render", &Simulator::render, py::arg("pattern"), py::arg("frame_index"),
             py::call_guard<py::gil_scoped_release>());
    m.def(
        "simulate_capture",
        [](const PatternSequence& sequence, const Calibration& calibration, const Scene& scene,
           const SimulationOptions& options, const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return simulate_capture(sequence, calibration, scene, options, callback);
        },
        py::arg("sequence"), py::arg("calibration"), py::arg("scene"), py::arg("options") = SimulationOptions(),
        py::arg("progress") = py::none());
    m.def(
        "simulate_stereo_capture",
        [](const PatternSequence& sequence, const SeedStereoRig& rig, const Scene& scene, const SimulationOptions& options,
           const py::object& progress) {
            const ProgressCallback callback = progress_from(progress);
            py::gil_scoped_release release;
            return simulate_stereo_capture(sequence, rig, scene, options, callback);
        },
        py::arg("sequence"), py::arg("rig"), py::arg("scene"), py::arg("options") = SimulationOptions(),
        py::arg("progress") = py::none());
}

}  // namespace picoscan::python
