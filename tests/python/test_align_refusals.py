"""Views made in memory and handed to the registration from Python: a point beyond 1 km from
the origin (or a float64 array) is refused by the core with one line naming the view, as
read_view_ply refuses it in a file. Before, align_views ran on them (integer cell keys
overflowed).

Run by CTest with PYTHONPATH at the built module."""
import unittest

import numpy

import picoscan


def plane_view():
    """A 40 x 40 pixel patch of a plane 400 mm in front of the camera, 1 mm apart."""
    view = picoscan.ScanView()
    ys, xs = numpy.mgrid[0:40, 0:40].astype(numpy.float32)
    view.points = numpy.dstack([xs, ys, numpy.full_like(xs, 400)])
    normals = numpy.zeros((40, 40, 3), numpy.float32)
    normals[:, :, 2] = -1
    view.normals = normals
    return view


class AlignRefusalsTest(unittest.TestCase):
    def test_a_point_beyond_a_kilometre_is_refused_naming_the_view(self):
        far = plane_view()
        points = far.points
        points[3, 7] = (1e15, 0, 400)
        far.points = points
        with self.assertRaises(picoscan.Error) as caught:
            picoscan.align_views([plane_view(), far], ["near.ply", "far.ply"])
        message = str(caught.exception)
        self.assertEqual(message.count("\n"), 0)
        self.assertIn("far.ply: point at pixel (7, 3) lies beyond 1 km (1e6 mm) from the origin", message)
        with self.assertRaises(picoscan.Error) as caught:
            picoscan.register_pair(plane_view(), far)
        self.assertIn("moving view: point at pixel (7, 3) lies beyond 1 km", str(caught.exception))

    def test_nan_points_are_unmeasured_not_refused(self):
        view = plane_view()
        points = view.points
        points[0:5, :] = numpy.nan
        view.points = points
        options = picoscan.RegistrationOptions()
        options.initial_poses = [numpy.eye(4), numpy.eye(4)]
        alignment = picoscan.align_views([plane_view(), view], ["a", "b"], options)
        self.assertEqual(len(alignment.views), 2)

    def test_float64_points_are_refused_naming_the_view(self):
        view = plane_view()
        view.points = view.points.astype(numpy.float64)
        with self.assertRaises(picoscan.Error) as caught:
            picoscan.align_views([plane_view(), view], ["a", "b.ply"])
        self.assertEqual(str(caught.exception), "b.ply: points must be CV_32FC3")


if __name__ == "__main__":
    unittest.main()
