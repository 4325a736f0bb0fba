"""Headless acceptance tests of the PicoScan workbench (run by freecadcmd -t TestPicoScanApp -M <folder>):
simulate a scan, reconstruct it into a ScanView, clean, mesh, make a solid, fit primitives, cut a
section, export STL, show the rig, encoding pictures, save, reopen and recompute."""
import math
import os
import shutil
import tempfile
import unittest

import numpy
import FreeCAD
import Mesh

import picoscan
from picoscan_wb.objects import cloud_of, scan_mesh, scan_view, stitch
from picoscan_wb.operations import encoding, primitives, rig, section, simulate, solid

SHAFT_RADIUS_MM = 12.5
BACKGROUND_Z_MM = 460.0


class PicoScanAppTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.folder = tempfile.mkdtemp(prefix="picoscan_fc_")
        cls.captures = os.path.join(cls.folder, "shaft")
        # The seed rig at half camera resolution (800 x 600): a shaft 400 mm away, a wall behind it.
        cls.calibration = simulate.simulate_scan(cls.captures, simulate.shaft_scene(SHAFT_RADIUS_MM, background_mm=BACKGROUND_Z_MM),
                                                 camera_scale=0.5)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder, ignore_errors=True)

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanTest")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)

    def scan(self, **options):
        view = scan_view.create(self.doc, self.captures, self.calibration, **options)
        self.assertTrue(view.isValid(), view.getStatusString())
        return view

    def test_scan_view_reconstructs_and_recomputes_on_parameter_change(self):
        view = self.scan()
        self.assertGreater(view.PointCount, 200000)
        self.assertEqual(view.Points.CountPoints, view.PointCount)
        box = view.Points.BoundBox
        self.assertAlmostEqual(box.ZMax, BACKGROUND_Z_MM, delta=1.0)
        self.assertAlmostEqual(box.ZMin, 400.0 - SHAFT_RADIUS_MM, delta=0.5)
        all_points = view.PointCount
        view.MinContrast = 120  # most of the wall is darker than this: fewer points after recompute
        self.doc.recompute()
        self.assertTrue(view.isValid())
        self.assertLess(view.PointCount, all_points)
        self.assertEqual(view.Points.CountPoints, view.PointCount)

    def test_clean_removes_points_and_reports(self):
        view = self.scan()
        before = view.PointCount
        view.Clean = True
        self.doc.recompute()
        self.assertLessEqual(view.PointCount, before)
        self.assertIn("removed", view.CleanReport)

    def test_grid_mesh_and_stl_export(self):
        view = self.scan()
        mesh = scan_mesh.create(self.doc, view, pixel_step=2)
        self.assertTrue(mesh.isValid(), mesh.getStatusString())
        self.assertGreater(mesh.Mesh.CountFacets, 100000)
        self.assertIn("open", mesh.Check)
        path = os.path.join(self.folder, "grid.stl")
        Mesh.export([mesh], path)
        read_back = Mesh.Mesh(path)
        self.assertEqual(read_back.CountFacets, mesh.Mesh.CountFacets)
        mesh.PixelStep = 4  # parametric: a coarser grid after recompute
        self.doc.recompute()
        self.assertLess(mesh.Mesh.CountFacets, read_back.CountFacets / 3)

    def test_make_solid(self):
        view = self.scan()
        open_mesh = scan_mesh.create(self.doc, view, pixel_step=8)
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "not closed"):
            solid.make_solid(self.doc, open_mesh)
        self.assertEqual([o.Name for o in self.doc.Objects], names)
        closed = self.doc.addObject("Mesh::Feature", "Closed")
        closed.Mesh = Mesh.createSphere(10.0, 40)
        feature = solid.make_solid(self.doc, closed)
        self.assertTrue(feature.Shape.isValid())
        self.assertEqual(feature.Shape.ShapeType, "Solid")
        self.assertAlmostEqual(feature.Shape.Volume, closed.Mesh.Volume, delta=1e-3 * closed.Mesh.Volume)

    def test_fit_cylinder_to_shaft_and_plane_to_wall(self):
        view = self.scan()
        organised, _ = view.Proxy.scan_view(view)
        group, created = primitives.fit_primitives(self.doc, picoscan.to_point_cloud(organised))
        cylinders = [obj for obj, shape in created if obj.TypeId == "Part::Cylinder"]
        planes = [obj for obj, shape in created if obj.TypeId == "Part::Plane"]
        self.assertEqual(len(cylinders), 1, [obj.TypeId for obj, _ in created])
        self.assertGreaterEqual(len(planes), 1)
        shaft = cylinders[0]
        FreeCAD.Console.PrintMessage("shaft radius %.4f mm (error %.1f um), rms %.4f mm, %d inliers\n" % (
            shaft.Radius.Value, (shaft.Radius.Value - SHAFT_RADIUS_MM) * 1000, shaft.FitRmsMm, shaft.InlierCount))
        self.assertAlmostEqual(shaft.Radius.Value, SHAFT_RADIUS_MM, delta=0.020)
        axis = shaft.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        self.assertGreater(abs(axis.y), math.cos(math.radians(0.2)))
        base = shaft.Placement.Base
        self.assertAlmostEqual(base.x, 0.0, delta=0.05)
        self.assertAlmostEqual(base.z, 400.0, delta=0.05)
        self.assertTrue(shaft.Shape.isValid())
        wall = planes[0]
        normal = wall.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        FreeCAD.Console.PrintMessage("wall plane z %.4f mm (true %.1f), normal off by %.4f deg, rms %.4f mm\n" % (
            wall.Placement.Base.z, BACKGROUND_Z_MM, math.degrees(normal.getAngle(FreeCAD.Vector(0, 0, -1))), wall.FitRmsMm))
        self.assertGreater(-normal.z, math.cos(math.radians(0.05)))
        self.assertAlmostEqual(wall.Placement.Base.z, BACKGROUND_Z_MM, delta=0.05)
        self.assertLess(wall.FitRmsMm, 0.1)
        self.assertGreater(wall.Shape.Area, 100 * 100)

    def test_cross_section_sketch_and_profile_plot(self):
        view = self.scan()
        mesh = scan_mesh.create(self.doc, view, pixel_step=1)
        sketch = section.cross_section(self.doc, mesh, axis="Y", offset_mm=0.0)
        self.assertTrue(sketch.isValid())
        self.assertGreater(sketch.GeometryCount, 50)
        radii = []
        for geometry in sketch.Geometry:
            point = sketch.Placement.multVec(geometry.StartPoint)
            self.assertAlmostEqual(point.y, 0.0, delta=1e-6)
            if point.z < 420:  # on the shaft, not the wall
                radii.append(math.hypot(point.x, point.z - 400.0))
        self.assertGreater(len(radii), 20)
        self.assertLess(max(abs(r - SHAFT_RADIUS_MM) for r in radii), 0.15)
        plot = section.hybrid_vs_binary_plot(view, "Y", 0.0, os.path.join(self.folder, "profile.png"))
        self.assertGreater(os.path.getsize(plot), 10000)
        with self.assertRaisesRegex(picoscan.Error, "does not cut"):
            section.cross_section(self.doc, mesh, axis="Y", offset_mm=500.0)

    def test_show_rig(self):
        group, camera, projector = rig.show_rig(self.doc, self.calibration, depth_mm=450)
        calibration = picoscan.read_calibration(self.calibration)
        self.assertEqual(len(camera.Shape.Edges), 8)
        apex = projector.Shape.Edges[0].Vertexes[0].Point
        self.assertAlmostEqual(apex.Length, float(numpy.linalg.norm(calibration.T)), delta=1e-6)
        self.assertGreater(apex.Length, 100)  # the seed rig's ~150 mm baseline

    def test_encoding_images(self):
        paths = encoding.encoding_images(self.captures, os.path.join(self.folder, "encoding"))
        self.assertEqual(sorted(paths), ["projector_u", "projector_v", "quality", "status"])
        for path in paths.values():
            self.assertGreater(os.path.getsize(path), 1000)

    def test_bad_input_leaves_document_unchanged(self):
        self.scan()
        names = [o.Name for o in self.doc.Objects]
        missing = os.path.join(self.folder, "no_such_folder")
        with self.assertRaisesRegex(picoscan.Error, "no_such_folder: capture folder does not exist"):
            scan_view.create(self.doc, missing, self.calibration)
        wrong = os.path.join(self.folder, "wrong.yml")
        picoscan.write_calibration(picoscan.seed_rig_calibration(), wrong)  # full-size camera, 1600 x 1200
        with self.assertRaisesRegex(picoscan.Error, "wrong.yml: camera_size 1600x1200 differs"):
            scan_view.create(self.doc, self.captures, wrong)
        garbage = os.path.join(self.folder, "garbage.yml")
        with open(garbage, "w") as stream:
            stream.write("not: a calibration\n")
        with self.assertRaisesRegex(picoscan.Error, "garbage.yml"):
            scan_view.create(self.doc, self.captures, garbage)
        self.assertEqual([o.Name for o in self.doc.Objects], names)
        self.assertTrue(all(o.isValid() for o in self.doc.Objects))

    def test_save_reopen_recompute(self):
        view = self.scan()
        mesh = scan_mesh.create(self.doc, view, pixel_step=4)
        points, facets = view.PointCount, mesh.Mesh.CountFacets
        view_name, mesh_name = view.Name, mesh.Name
        path = os.path.join(self.folder, "scan.FCStd")
        self.doc.saveAs(path)
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(path)
        view, mesh = self.doc.getObject(view_name), self.doc.getObject(mesh_name)
        self.assertEqual(view.Points.CountPoints, points)  # stored in the file
        self.assertEqual(mesh.Mesh.CountFacets, facets)
        self.assertEqual(view.Proxy.Type, "PicoScan::ScanView")
        view.touch()
        self.doc.recompute()
        self.assertTrue(view.isValid() and mesh.isValid())
        self.assertEqual(view.PointCount, points)
        self.assertEqual(mesh.Mesh.CountFacets, facets)


class PicoScanStitchTest(unittest.TestCase):
    """Three views of the speckle-painted mechanical part, 45 degrees apart on a turntable."""

    @classmethod
    def setUpClass(cls):
        cls.folder = tempfile.mkdtemp(prefix="picoscan_stitch_")
        cls.scans, cls.truth = simulate.simulate_turntable(cls.folder, (0, 1, 2))

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder, ignore_errors=True)

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanStitchTest")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)

    def scan_views(self):
        views = []
        for folder, calibration in self.scans:
            view = scan_view.create(self.doc, folder, calibration, clean=True)
            view.MinModulation = 15  # the part is bright: reject its dim, grazing edges
            views.append(view)
        self.doc.recompute()
        return views

    def test_stitch_registers_views_and_survives_reopening(self):
        views = self.scan_views()
        merged = stitch.create(self.doc, views)
        self.assertTrue(merged.isValid(), merged.getStatusString())
        self.assertEqual(merged.AlignedCount, 3, merged.Report)
        self.assertEqual(merged.PointCount, sum(v.PointCount for v in views))
        centre = numpy.array([0.0, 0.0, 400.0])  # the part's middle, where pose errors matter
        for placement, truth in zip(merged.ViewPoses, self.truth):
            pose = numpy.array(placement.toMatrix().A).reshape(4, 4)
            error = picoscan.pose_difference(pose, truth, centre)
            FreeCAD.Console.PrintMessage("view pose error %.4f deg, %.4f mm\n" % (error.rotation_deg, error.translation_mm))
            self.assertLess(error.rotation_deg, 0.05)
            self.assertLess(error.translation_mm, 0.05)
        # Primitives fitted on the merged cloud: the through hole (10 mm) is a cylinder.
        group, created = primitives.fit_primitives(self.doc, cloud_of(merged))
        radii = sorted(obj.Radius.Value for obj, _ in created if obj.TypeId == "Part::Cylinder")
        FreeCAD.Console.PrintMessage("cylinders on the merged cloud: %s\n" % radii)
        self.assertTrue(any(abs(r - 5.0) < 0.02 for r in radii), radii)
        # Poisson: a watertight mesh of the merged cloud, small enough for a Part solid, exported as STL.
        mesh = scan_mesh.create(self.doc, merged, method="Poisson", sample_spacing_mm=1.0, target_faces=4000)
        self.assertTrue(mesh.isValid(), mesh.getStatusString())
        FreeCAD.Console.PrintMessage("Poisson mesh: %s\n" % mesh.Check)
        self.assertIn("watertight", mesh.Check)
        self.assertNotIn("NOT watertight", mesh.Check)
        self.assertTrue(mesh.Mesh.isSolid())
        part = solid.make_solid(self.doc, mesh)
        self.assertTrue(part.Shape.isValid())
        self.assertAlmostEqual(part.Shape.Volume, mesh.Mesh.Volume, delta=0.01 * mesh.Mesh.Volume)
        FreeCAD.Console.PrintMessage("solid volume %.0f mm3 from %d facets\n" % (part.Shape.Volume, mesh.Mesh.CountFacets))
        stl = os.path.join(self.folder, "stitched.stl")
        Mesh.export([mesh], stl)
        self.assertEqual(Mesh.Mesh(stl).CountFacets, mesh.Mesh.CountFacets)
        with self.assertRaisesRegex(picoscan.Error, "Grid meshing needs a single ScanView"):
            scan_mesh.create(self.doc, merged, method="Grid")
        path = os.path.join(self.folder, "stitched.FCStd")
        count, name = merged.PointCount, merged.Name
        self.doc.saveAs(path)
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(path)
        merged = self.doc.getObject(name)
        self.assertEqual(merged.Points.CountPoints, count)
        merged.touch()
        self.doc.recompute()
        self.assertTrue(merged.isValid(), merged.getStatusString())
        self.assertEqual(merged.PointCount, count)

    def test_stitch_needs_two_views(self):
        views = self.scan_views()
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "two or more ScanViews"):
            stitch.create(self.doc, views[:1])
        self.assertEqual([o.Name for o in self.doc.Objects], names)
