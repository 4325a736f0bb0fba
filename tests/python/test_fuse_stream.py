"""Fusing posed views one at a time from Python: picoscan.fuse_views(count, view_at) and
picoscan.fuse_view_files(paths) against the same views held whole (picoscan.fuse_views(list)):
the same merged cloud to the bit, the same mesh within the meshing's own tolerance, and the
refusals a host meets (a missing file, a file that is no view, a callable that returns no view,
cancelling while the views are read).

Run by CTest with PYTHONPATH at the built module."""
import os
import shutil
import sys
import tempfile
import unittest

import numpy

import picoscan

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import turntable_view_files  # noqa: E402

VIEW_COUNT = 4


def quick_options():
    """Advancing front on a 1 mm thinning: seconds for the four small views."""
    options = picoscan.MeshOptions()
    options.method = picoscan.MeshMethod.AdvancingFront
    options.sample_spacing_mm = 1.0
    return options


class FuseStreamTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        # Four views 90 degrees apart with a 400 x 300 camera (a quarter of the seed camera).
        cls.folder = tempfile.mkdtemp(prefix="picoscan-fuse-stream-")
        cls.paths = turntable_view_files.make_view_files(cls.folder, VIEW_COUNT, scale=0.25)
        cls.views = [picoscan.read_view_ply(path) for path in cls.paths]
        cls.whole = picoscan.fuse_views(cls.views, quick_options())

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder, ignore_errors=True)

    def assert_same_fusion(self, fused, how):
        merged, expected = fused.merged, self.whole.merged
        self.assertEqual(len(merged), len(expected), how)
        self.assertTrue(numpy.array_equal(merged.points, expected.points), how)
        self.assertTrue(numpy.array_equal(merged.normals, expected.normals), how)
        self.assertTrue(numpy.array_equal(merged.colours, expected.colours), how)
        # The advancing front does not repeat itself exactly on the same cloud (a vertex or two).
        faces, expected_faces = len(fused.mesh.faces), len(self.whole.mesh.faces)
        print("%s: %d points, %d faces (views held whole: %d faces)" % (how, len(merged), faces, expected_faces))
        self.assertAlmostEqual(faces, expected_faces, delta=0.01 * expected_faces, msg=how)
        self.assertEqual(fused.check.faces, faces, how)

    def test_whole_views_fuse_every_valid_point_in_view_zero_frame(self):
        valid = sum(view.valid_count() for view in self.views)
        self.assertEqual(len(self.whole.merged), valid)
        self.assertGreater(valid, 4 * 10000)
        self.assertGreater(self.whole.check.faces, 5000)
        # Posed into view 0's frame: the part (within 45 mm of its axis) seen from every side, so
        # its points surround the axis; unposed, every view would lie in front of its camera.
        points = numpy.asarray(self.whole.merged.points, dtype=numpy.float64)
        pose = numpy.asarray(picoscan.turntable_part_poses(self.plan())[0])
        in_part = (points - pose[:3, 3]) @ pose[:3, :3]
        on_part = in_part[numpy.hypot(in_part[:, 0], in_part[:, 1]) < 45]
        self.assertLess(numpy.abs(numpy.median(on_part[:, :2], axis=0)).max(), 5.0)

    @staticmethod
    def plan():
        plan = picoscan.TurntablePlan()
        plan.turntable_views = VIEW_COUNT
        plan.top_view = False
        return plan

    def test_views_read_one_at_a_time_fuse_as_views_held_whole(self):
        asked = []

        def view_at(index):
            asked.append(index)
            return picoscan.read_view_ply(self.paths[index])

        self.assert_same_fusion(picoscan.fuse_views(VIEW_COUNT, view_at, quick_options()), "fuse_views(count, view_at)")
        self.assertEqual(asked, list(range(VIEW_COUNT)))
        self.assert_same_fusion(picoscan.fuse_view_files(self.paths, quick_options()), "fuse_view_files(paths)")

    def test_progress_reports_each_view_read_and_cancelling_stops_reading(self):
        reports = []
        picoscan.fuse_view_files(self.paths, quick_options(),
                                 lambda fraction, stage: reports.append((fraction, stage)) or True)
        self.assertEqual([stage for _, stage in reports[:VIEW_COUNT]], ["merging the views"] * VIEW_COUNT)
        self.assertNotEqual(reports[VIEW_COUNT][1], "merging the views")
        self.assertEqual(reports[-1], (1.0, "checking the mesh"))
        asked = []
        with self.assertRaisesRegex(picoscan.Error, "cancelled"):
            picoscan.fuse_views(VIEW_COUNT, lambda index: asked.append(index) or self.views[index], quick_options(),
                                lambda fraction, stage: len(asked) < 2)
        self.assertEqual(asked, [0, 1])

    def test_refusals_name_the_file_or_the_callable(self):
        missing = os.path.join(self.folder, "no_such_view.ply")
        with self.assertRaisesRegex(picoscan.Error, "no_such_view.ply"):
            picoscan.fuse_view_files(self.paths[:2] + [missing], quick_options())
        not_a_view = os.path.join(self.folder, "mesh.ply")
        picoscan.write_ply(self.whole.mesh, not_a_view)
        with self.assertRaisesRegex(picoscan.Error, "mesh.ply"):
            picoscan.fuse_view_files([not_a_view], quick_options())
        with self.assertRaisesRegex(picoscan.Error, "at least one view"):
            picoscan.fuse_view_files([], quick_options())
        with self.assertRaisesRegex(picoscan.Error, "view_at.*ScanView.*NoneType.*view 1"):
            picoscan.fuse_views(2, lambda index: self.views[0] if index == 0 else None, quick_options())
        with self.assertRaisesRegex(picoscan.Error, "view_at.*callable"):
            picoscan.fuse_views(2, self.views[0], quick_options())
        with self.assertRaisesRegex(KeyError, "gone"):  # the host's own error comes through as it was
            picoscan.fuse_views(2, lambda index: {}["gone"], quick_options())


if __name__ == "__main__":
    unittest.main()
