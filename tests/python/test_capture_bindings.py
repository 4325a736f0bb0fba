"""The capture, virtual camera, multi-camera and file-output bindings used as a Python host
would: a virtual rig captures into real folders through the same sequencer as a webcam, the
folder is then reconstructed through the pipeline, and the refusals reach Python as
picoscan.Error with the core's message."""
import os
import tempfile
import unittest

import numpy

import picoscan


def small_rig():
    """The seed rig with a 400 x 300 camera: a quick simulated capture."""
    calibration = picoscan.seed_rig_calibration()
    scale = 0.25
    calibration.camera_size = (400, 300)
    matrix = calibration.camera_matrix
    matrix[:2, :2] *= scale
    matrix[:2, 2] = (matrix[:2, 2] + 0.5) * scale - 0.5
    calibration.camera_matrix = matrix
    return calibration


def sphere_scene(radius_mm=25.0):
    scene = picoscan.Scene()
    scene.add_plane((0, 0, 450), (0, 0, -1))
    scene.add_sphere((0, 0, 400), radius_mm)
    return scene


class CaptureTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.calibration = small_rig()
        options = picoscan.PatternOptions()
        options.shifts = 8
        cls.sequence = picoscan.make_pattern_sequence(options)
        cls.root = tempfile.mkdtemp(prefix="picoscan-capture-bindings-")

    def capture(self, folder, camera_options=None, progress=None, resume=False):
        display = picoscan.SimulatedDisplay(self.calibration.projector_size)
        camera = picoscan.VirtualCamera(self.calibration, sphere_scene(), camera_options or picoscan.SimulationOptions(),
                                        display)
        options = picoscan.CaptureOptions()
        options.resume = resume
        return picoscan.capture_sequence(self.sequence, display, [camera], [folder], options, progress)

    def test_virtual_capture_reconstructs_the_sphere(self):
        folder = os.path.join(self.root, "sphere")
        fractions = []
        report = self.capture(folder, progress=lambda fraction, stage: fractions.append(fraction) or True)
        frame_count = len(self.sequence.frames)
        self.assertEqual(report.captured, frame_count)
        self.assertEqual(report.already_present, 0)
        self.assertEqual(len(fractions), frame_count)
        self.assertAlmostEqual(fractions[-1], 1.0)
        self.assertEqual(picoscan.frames_present(self.sequence, folder), [True] * frame_count)
        # A finished capture is refused unless resumed, and resuming finds every frame there.
        with self.assertRaises(picoscan.Error):
            picoscan.check_capture_folders(self.sequence, [folder], False)
        picoscan.check_capture_folders(self.sequence, [folder], True)
        self.assertEqual(self.capture(folder, resume=True).already_present, frame_count)

        result = picoscan.reconstruct_view(folder, self.calibration, "small rig")
        self.assertGreater(result.point_count, 20000)
        points = result.view.points.reshape(-1, 3)
        points = points[numpy.isfinite(points).all(axis=1)]
        on_sphere = points[points[:, 2] < 440]  # in front of the background plane
        self.assertGreater(len(on_sphere), 3000)
        fit = picoscan.fit_sphere(on_sphere)
        self.assertAlmostEqual(fit.radius_mm, 25.0, delta=0.1)
        self.assertLess(numpy.linalg.norm(fit.centre - numpy.array([0, 0, 400])), 0.1)

    def test_cancelling_keeps_the_frames_taken(self):
        folder = os.path.join(self.root, "cancelled")
        with self.assertRaisesRegex(picoscan.Error, "cancelled"):
            self.capture(folder, progress=lambda fraction, stage: fraction < 0.3)
        present = picoscan.frames_present(self.sequence, folder)
        self.assertTrue(0 < sum(present) < len(present), present)

    def test_a_foreign_folder_is_refused_before_anything_is_shown(self):
        folder = os.path.join(self.root, "foreign")
        os.makedirs(folder)
        with open(os.path.join(folder, "notes.txt"), "w") as notes:
            notes.write("not a capture")
        with self.assertRaisesRegex(picoscan.Error, "holds files but no capture"):
            self.capture(folder)
        self.assertEqual(os.listdir(folder), ["notes.txt"])

    def test_delayed_display_shows_the_pattern_only_after_its_latency(self):
        display = picoscan.SimulatedDisplay((64, 48))
        delayed = picoscan.DelayedDisplay(display, 150.0)
        white = numpy.full((48, 64), 255, numpy.uint8)
        delayed.show(white)
        self.assertEqual(int(delayed.visible().max()), 0)
        delayed.wait(250.0)
        self.assertEqual(int(delayed.visible().min()), 255)

    def test_latency_is_measured_through_the_virtual_camera(self):
        display = picoscan.SimulatedDisplay(self.calibration.projector_size)
        delayed = picoscan.DelayedDisplay(display, 120.0)
        camera = picoscan.VirtualCamera(self.calibration, sphere_scene(), picoscan.SimulationOptions(), display)
        options = picoscan.LatencyOptions()
        options.trials = 2
        options.settle_ms = 200.0
        measured = picoscan.measure_latency(delayed, camera, options)
        self.assertEqual(len(measured.trials_ms), 2)
        self.assertGreaterEqual(measured.latency_ms, 120.0)
        self.assertLess(measured.latency_ms, 1000.0)
        self.assertGreater(measured.white_level_dn - measured.black_level_dn, 10.0)
        self.assertAlmostEqual(measured.recommended_wait_ms(), measured.latency_ms * 1.2 + 10.0)


class MultiCameraAndFilesTest(unittest.TestCase):
    def test_camera_to_camera_goes_through_the_projector(self):
        a = picoscan.seed_rig_calibration()
        b = picoscan.seed_rig_calibration()
        self.assertTrue(numpy.allclose(picoscan.camera_to_camera(a, b), numpy.eye(4), atol=1e-9))
        # Camera b 40 mm to the right of a: X_b = X_a - (40, 0, 0).
        b.T = numpy.asarray(a.T) + numpy.asarray(a.R) @ numpy.array([40.0, 0, 0])
        pose = picoscan.camera_to_camera(a, b)
        self.assertTrue(numpy.allclose(pose[:3, 3], [-40.0, 0, 0], atol=1e-6), pose)

    def test_images_are_written_atomically_and_refused_with_the_file_named(self):
        folder = tempfile.mkdtemp(prefix="picoscan-file-output-")
        path = os.path.join(folder, "ramp.png")
        ramp = numpy.tile(numpy.arange(256, dtype=numpy.uint8), (8, 1))
        picoscan.write_image_file(ramp, path)
        self.assertEqual(picoscan.flat_level_file(7), "level_007.png")
        self.assertEqual(sorted(os.listdir(folder)), ["ramp.png"])  # no temporary left behind
        with self.assertRaisesRegex(picoscan.Error, "ramp.unknown"):
            picoscan.write_image_file(ramp, os.path.join(folder, "ramp.unknown"))
        self.assertEqual(sorted(os.listdir(folder)), ["ramp.png"])


if __name__ == "__main__":
    unittest.main()
