"""The `picoscan` module from plain Python (Debian's /usr/bin/python3): NumPy in and out without
copies where the core owns the data, errors as picoscan.Error, progress callbacks, GIL released."""
import os
import tempfile
import threading
import time
import unittest

import numpy

import picoscan


def small_rig():
    """The seed rig with a 400 x 300 camera: a quick simulated scan."""
    calibration = picoscan.seed_rig_calibration()
    scale = 0.25
    calibration.camera_size = (400, 300)
    matrix = calibration.camera_matrix
    matrix[:2, :2] *= scale
    matrix[:2, 2] = (matrix[:2, 2] + 0.5) * scale - 0.5
    calibration.camera_matrix = matrix
    return calibration


class ModuleTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.calibration = small_rig()
        cls.scene = picoscan.Scene()
        cls.scene.add_plane((0, 0, 450), (0, 0, -1))
        cls.scene.add_sphere((0, 0, 400), 20)
        options = picoscan.PatternOptions()
        options.shifts = 8
        cls.stages = []
        cls.captures = picoscan.simulate_capture(picoscan.make_pattern_sequence(options), cls.calibration, cls.scene,
                                                 progress=lambda fraction, stage: cls.stages.append(stage) or True)
        cls.view = picoscan.triangulate(picoscan.decode(cls.captures), cls.calibration, cls.captures.white_colour)

    def test_images_are_numpy_arrays(self):
        image = self.captures.images[0]
        self.assertEqual(image.shape, (300, 400))
        self.assertEqual(image.dtype, numpy.uint8)
        self.assertEqual(self.captures.white_colour.shape, (300, 400, 3))
        self.assertGreater(len(self.stages), 0)

    def test_view_arrays_share_the_core_buffers(self):
        points = self.view.points
        self.assertEqual(points.shape, (300, 400, 3))
        self.assertEqual(points.dtype, numpy.float32)
        again = self.view.points
        self.assertEqual(points.__array_interface__["data"][0], again.__array_interface__["data"][0])
        valid = numpy.isfinite(points).all(axis=2)
        self.assertEqual(int(valid.sum()), self.view.valid_count())
        self.assertGreater(self.view.valid_count(), 100000)

    def test_sphere_measured_within_a_tenth_of_a_millimetre(self):
        cloud = picoscan.to_point_cloud(self.view)
        points = cloud.points
        near = points[points[:, 2] < 440]
        fit = picoscan.fit_sphere(near)
        self.assertAlmostEqual(fit.radius_mm, 20.0, delta=0.1)
        self.assertLess(numpy.linalg.norm(fit.centre - numpy.array([0, 0, 400])), 0.1)

    def test_cloud_arrays_are_views_and_settable(self):
        cloud = picoscan.PointCloud()
        cloud.points = numpy.array([[1, 2, 3], [4, 5, 6]], numpy.float64)  # converted to float32
        self.assertEqual(len(cloud), 2)
        view = cloud.points
        view[0, 0] = 10
        self.assertEqual(cloud.points[0, 0], 10)  # the array writes into the cloud

    def test_detect_shapes_finds_sphere_and_plane(self):
        shapes = picoscan.detect_shapes(picoscan.to_point_cloud(self.view))
        kinds = sorted(str(shape.kind).split(".")[-1] for shape in shapes)
        self.assertEqual(kinds, ["Plane", "Sphere"])
        sphere = [s for s in shapes if s.kind == picoscan.ShapeKind.Sphere][0]
        self.assertAlmostEqual(sphere.radius_mm, 20.0, delta=0.05)

    def test_grid_mesh_and_stl_round_trip(self):
        mesh = picoscan.grid_mesh(self.view)
        self.assertEqual(mesh.faces.shape[1], 3)
        self.assertGreater(len(mesh.faces), 100000)
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "scan.stl")
            picoscan.write_stl(mesh, path)
            self.assertEqual(len(picoscan.read_mesh(path).faces), len(mesh.faces))

    def test_errors_name_the_input(self):
        with self.assertRaisesRegex(picoscan.Error, "no_such_folder"):
            picoscan.load_capture_set("/no_such_folder")
        with self.assertRaisesRegex(picoscan.Error, "--board"):
            picoscan.parse_board_spec("square")
        with self.assertRaisesRegex(picoscan.Error, "cloud"):
            picoscan.detect_shapes(picoscan.PointCloud())

    def test_progress_can_cancel(self):
        with self.assertRaisesRegex(picoscan.Error, "cancel"):
            picoscan.decode(self.captures, progress=lambda fraction, stage: False)

    def test_cancel_points_inside_region_fit_cutting_and_thinning(self):
        """The cancel points added for the workbench's Cancel: within a kind's least-squares fit (not
        only between kinds), within cutting a mesh, and within Poisson's thinning of the points."""
        cloud = picoscan.to_point_cloud(self.view)
        region = list(range(len(cloud.points)))
        seen = []

        def stop_inside_a_kind(fraction, stage):
            seen.append((round(fraction, 3), stage))
            return round(fraction * 5, 6) == round(fraction * 5)  # kinds start at multiples of 0.2
        with self.assertRaisesRegex(picoscan.Error, "cancelled"):
            picoscan.fit_region(cloud, region, picoscan.RegionFitOptions(), stop_inside_a_kind)
        # The plane is fitted in one step; the sphere is refined iteratively and stopped in its first step.
        self.assertEqual(seen, [(0.0, "fitting a plane"), (0.2, "fitting a sphere"), (0.3, "fitting a sphere")])

        options = picoscan.MeshOptions()
        options.method = picoscan.MeshMethod.Grid
        options.grid.pixel_step = 1
        mesh = picoscan.mesh_view(self.view, options)
        self.assertGreater(len(mesh.vertices), 65536)
        cuts = []
        with self.assertRaisesRegex(picoscan.Error, "cancelled"):
            picoscan.cut_mesh(mesh, (0, 0, 400), (1, 0, 0), (0, 0, 1), lambda f, s: cuts.append((f, s)) or False)
        self.assertEqual(cuts, [(0.0, "cutting the mesh")])
        self.assertGreater(len(picoscan.cut_mesh(mesh, (0, 0, 400), (1, 0, 0), (0, 0, 1), lambda f, s: True)), 0)
        # The section with its Band in one call: stopped within the parallel cuts too; the cuts it
        # gives are those of cut_mesh at section_band_offsets (as the Cross-section fits them).
        stages = []
        with self.assertRaisesRegex(picoscan.Error, "cancelled"):
            picoscan.cut_mesh_section(mesh, (0, 0, 400), (1, 0, 0), (0, 0, 1), 2.0,
                                      lambda f, s: stages.append(s) or s != "parallel cuts")
        self.assertEqual((stages[0], stages[-1]), ("cutting the mesh", "parallel cuts"))
        section = picoscan.cut_mesh_section(mesh, (0, 0, 400), (1, 0, 0), (0, 0, 1), 2.0)
        offsets = picoscan.section_band_offsets(2.0)
        self.assertEqual(len(offsets), picoscan.SECTION_BAND_CUTS)
        self.assertEqual(sorted({cut.offset_mm for cut in section.parallel_cuts}), offsets)
        first = picoscan.cut_mesh(mesh, (0, -offsets[0], 400), (1, 0, 0), (0, 0, 1))  # the normal is -y
        self.assertTrue(numpy.array_equal(section.parallel_cuts[0].points, first[0].points))
        self.assertEqual(len(section.polylines), len(picoscan.cut_mesh(mesh, (0, 0, 400), (1, 0, 0), (0, 0, 1))))
        with self.assertRaisesRegex(picoscan.Error, "plane: does not cut the mesh"):
            picoscan.cut_mesh_section(mesh, (0, 0, 900), (1, 0, 0), (0, 1, 0))
        # The whole Cross-section in one call (section_mesh, as FreeCAD's Cross-section and picoscan
        # section run it): its progress runs through the cuts (up to 0.5), then the fit; Cancel stops either.
        for stop in ("parallel cuts", "fitting lines and arcs"):
            told = []
            with self.assertRaisesRegex(picoscan.Error, "cancelled"):
                picoscan.section_mesh(mesh, (0, 0, 400), (1, 0, 0), (0, 0, 1), 2.0, picoscan.SectionFitOptions(),
                                      lambda f, s: told.append((f, s)) or s != stop)
            self.assertEqual((told[0][1], told[-1][1]), ("cutting the mesh", stop))
            self.assertEqual(told, sorted(told, key=lambda t: t[0]))
            self.assertTrue(all(f <= 0.5 for f, s in told if s != "fitting lines and arcs"))
            self.assertTrue(all(f >= 0.5 for f, s in told if s == "fitting lines and arcs"))
        with self.assertRaisesRegex(picoscan.Error, "plane: does not cut the mesh"):
            picoscan.section_mesh(mesh, (0, 0, 900), (1, 0, 0), (0, 1, 0))
        # With the scan behind the mesh (here the cloud it was made from) the noise is measured on its
        # points, the tolerance is 5 x it, and tolerance_from says so; too few points are refused.
        with_scan = picoscan.section_mesh(mesh, (0, 0, 400), (1, 0, 0), (0, 0, 1), 0.0, scan=cloud)
        self.assertEqual(with_scan.tolerance_source, picoscan.SectionToleranceSource.ScanNoise)
        self.assertEqual(with_scan.scan_noise_mm, picoscan.estimate_scan_noise(cloud))
        self.assertAlmostEqual(with_scan.fits.tolerance_mm, max(0.005, 5 * with_scan.scan_noise_mm), delta=1e-12)
        self.assertIn("5 x the noise of the scan the mesh was made from", with_scan.tolerance_from)
        few = picoscan.PointCloud()
        few.points = numpy.zeros((10, 3), dtype=numpy.float32)
        with self.assertRaisesRegex(picoscan.Error, "^scan: "):
            picoscan.section_mesh(mesh, (0, 0, 400), (1, 0, 0), (0, 0, 1), 0.0, scan=few)

        self.assertGreater(len(cloud.points), 65536)
        selecting = []
        with self.assertRaisesRegex(picoscan.Error, "cancelled"):
            picoscan.select_region(cloud, tuple(cloud.points[0]), picoscan.grown_face_selection(),
                                   lambda f, s: selecting.append(s) or False)
        self.assertEqual(selecting, ["selecting the region"])

        thinning = []

        def stop_while_thinning(fraction, stage):
            thinning.append((round(fraction, 3), stage))
            return not (stage == "thinning the points" and fraction > 0)  # the first report comes before it
        poisson = picoscan.MeshOptions()
        poisson.sample_spacing_mm = 0.5
        with self.assertRaisesRegex(picoscan.Error, "cancelled"):
            picoscan.mesh_points(cloud, poisson, stop_while_thinning)
        self.assertEqual(thinning, [(0.0, "thinning the points"), (0.05, "thinning the points")])

    def test_long_calls_release_the_gil(self):
        # A Python thread keeps counting while the core decodes.
        ticks = []
        stop = threading.Event()

        def count():
            while not stop.is_set():
                ticks.append(1)
                time.sleep(0.001)

        thread = threading.Thread(target=count)
        thread.start()
        started = time.time()
        for _ in range(3):
            picoscan.detect_shapes(picoscan.to_point_cloud(self.view))
        elapsed = time.time() - started
        stop.set()
        thread.join()
        self.assertGreater(len(ticks), 0.1 * elapsed / 0.001)  # held GIL: next to no ticks


if __name__ == "__main__":
    unittest.main()


class CadBindingsTest(unittest.TestCase):
    """Deviation maps, section fitting, the pixel status enum and the camera-size check from Python."""

    def test_deviation_of_a_measured_sphere_to_its_true_surface(self):
        # The simulated sphere scan against a finely tessellated true sphere: the scan's own error.
        calibration, scene = small_rig(), picoscan.Scene()
        scene.add_sphere((0, 0, 400), 20)
        captures = picoscan.simulate_capture(picoscan.make_pattern_sequence(picoscan.PatternOptions()), calibration, scene)
        view = picoscan.triangulate(picoscan.decode(captures), calibration, captures.white_colour)
        points = picoscan.to_point_cloud(view).points
        rings, segments = 200, 400
        polar, azimuth = numpy.meshgrid(numpy.linspace(0, numpy.pi, rings + 1), numpy.linspace(0, 2 * numpy.pi, segments, endpoint=False), indexing="ij")
        vertices = numpy.stack([20 * numpy.sin(polar) * numpy.cos(azimuth), 20 * numpy.cos(polar),
                                400 + 20 * numpy.sin(polar) * numpy.sin(azimuth)], axis=-1).reshape(-1, 3)
        faces = []
        for ring in range(rings):
            for segment in range(segments):
                a, b = ring * segments + segment, ring * segments + (segment + 1) % segments
                faces += [(a, b, a + segments), (b, b + segments, a + segments)]
        sphere = picoscan.Mesh()
        sphere.vertices = vertices.astype(numpy.float32)
        sphere.faces = numpy.array(faces, dtype=numpy.int32)
        options = picoscan.DeviationOptions()
        options.tolerance_mm = 0.1
        result = picoscan.measure_deviation(points, sphere, options)
        statistics = result.statistics
        self.assertEqual(result.distances_mm.shape, (len(points),))
        self.assertEqual(statistics.count, len(points))
        self.assertLess(abs(statistics.mean_mm), 0.05)
        self.assertLess(statistics.p95_abs_mm, 0.2)
        self.assertGreater(statistics.within_tolerance, 0.8)
        self.assertEqual(result.colours().shape, (len(points), 3))
        # A reference 0.1 mm larger has the whole scan 0.1 mm inside it: negative.
        sphere.vertices = ((vertices - (0, 0, 400)) * (20.1 / 20) + (0, 0, 400)).astype(numpy.float32)
        larger = picoscan.measure_deviation(points, sphere, options)
        self.assertAlmostEqual(larger.statistics.mean_mm, statistics.mean_mm - 0.1, delta=0.005)
        with tempfile.TemporaryDirectory() as folder:
            picoscan.write_deviation_report(result, "sphere", os.path.join(folder, "report.html"))
            picoscan.write_deviation_ply(points, result, os.path.join(folder, "map.ply"))
            self.assertGreater(os.path.getsize(os.path.join(folder, "report.html.png")), 5000)
        with self.assertRaisesRegex(picoscan.Error, "reference: has no triangles"):
            picoscan.measure_deviation(points, picoscan.Mesh())
        with self.assertRaisesRegex(ValueError, "points: expected an N x 3 array"):
            picoscan.measure_deviation(numpy.zeros((4, 2)), sphere)

    def test_fit_section_of_a_slot(self):
        theta = numpy.linspace(-numpy.pi / 2, numpy.pi / 2, 60, endpoint=False)
        right = numpy.stack([30 + 5 * numpy.cos(theta), 5 * numpy.sin(theta)], axis=1)
        top = numpy.stack([numpy.linspace(30, 0, 100, endpoint=False), numpy.full(100, 5.0)], axis=1)
        left = numpy.stack([-5 * numpy.cos(theta), -5 * numpy.sin(theta)], axis=1)
        bottom = numpy.stack([numpy.linspace(0, 30, 100, endpoint=False), numpy.full(100, -5.0)], axis=1)
        fit = picoscan.fit_section(numpy.concatenate([right, top, left, bottom]), True)
        kinds = sorted(str(e.kind) for e in fit.elements)
        self.assertEqual(kinds, ["SectionElementKind.Arc"] * 2 + ["SectionElementKind.Line"] * 2)
        for element in fit.elements:
            self.assertTrue(element.tangent_to_next)
            if element.kind == picoscan.SectionElementKind.Arc:
                self.assertAlmostEqual(element.radius_mm, 5.0, delta=1e-6)
        self.assertIn(picoscan.SectionConstraintKind.EqualRadius, [c.kind for c in fit.constraints])
        with self.assertRaisesRegex(picoscan.Error, "polyline: needs at least 4"):
            picoscan.fit_section(numpy.zeros((3, 2)), True)

    def test_pixel_status_and_camera_size_check(self):
        self.assertEqual(int(picoscan.PixelStatus.kValid), 0)
        self.assertEqual(int(picoscan.PixelStatus.kLowModulation), 4)
        calibration = small_rig()
        scene = picoscan.Scene()
        scene.add_plane((0, 0, 450), (0, 0, -1))
        captures = picoscan.simulate_capture(picoscan.make_pattern_sequence(picoscan.PatternOptions()), calibration, scene)
        picoscan.check_camera_size(calibration, captures, "small.yml")
        with self.assertRaisesRegex(picoscan.Error, "full.yml: camera_size 1600x1200 differs"):
            picoscan.check_camera_size(picoscan.seed_rig_calibration(), captures, "full.yml")
