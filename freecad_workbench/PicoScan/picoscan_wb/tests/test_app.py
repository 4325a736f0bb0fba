"""Headless acceptance tests of the PicoScan workbench (run by freecadcmd -t TestPicoScanApp -M <folder>):
simulate a scan, reconstruct it into a ScanView, clean, mesh, make a solid, fit primitives, cut a
section, export STL, show the rig, encoding pictures, save, reopen and recompute."""
import math
import os
import re
import shutil
import tempfile
import time
import unittest

import numpy
import FreeCAD
import Mesh
import Part
import Points

import picoscan
from picoscan_wb.objects import cloud_of, deviation_map, measurements, scan_mesh, scan_view, stitch
from picoscan_wb.operations import (alignment, datum, encoding, primitives, reconstruct, region_fit, rig, section,
                                   simulate, solid)

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
        self.check_normals(view)
        all_points = view.PointCount
        view.MinContrast = 120  # most of the wall is darker than this: fewer points after recompute
        self.doc.recompute()
        self.assertTrue(view.isValid())
        self.assertLess(view.PointCount, all_points)
        self.assertEqual(view.Points.CountPoints, view.PointCount)
        self.check_normals(view)

    def check_normals(self, view):
        """The ScanView's Normal (what the 3D view lights its points by): one per point, in the points'
        order, the core's from the pixel grid: on the shaft (axis along y through z = 400 mm) radial,
        turned towards the camera."""
        from picoscan_wb.property_content import normals_from_content, points_from_content

        normals = normals_from_content(view.dumpPropertyContent("Normal", Compression=0))
        points = points_from_content(view.dumpPropertyContent("Points", Compression=0), moved=False)
        self.assertEqual(len(normals), view.PointCount)
        self.assertLess(numpy.abs(numpy.linalg.norm(normals, axis=1) - 1).max(), 1e-3)  # no NaN left
        radial = points[:, [0, 2]] - [0.0, 400.0]
        distance = numpy.linalg.norm(radial, axis=1)
        on_shaft = (numpy.abs(distance - SHAFT_RADIUS_MM) < 0.3) & (numpy.abs(points[:, 1]) < 30)
        self.assertGreater(on_shaft.sum(), 10000)
        cosine = (normals[on_shaft][:, [0, 2]] * radial[on_shaft]).sum(axis=1) / distance[on_shaft]
        angle = numpy.degrees(numpy.arccos(numpy.clip(cosine, -1, 1)))
        FreeCAD.Console.PrintMessage("ScanView normals on the shaft: median %.2f, p95 %.2f degrees from radial\n" % (
            numpy.median(angle), numpy.percentile(angle, 95)))
        self.assertLess(numpy.median(angle), 4.0)
        self.assertLess(numpy.percentile(angle, 95), 15.0)

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

    def test_open_fill_meshes_one_view_on_its_points(self):
        """Poisson with Fill Open on one ScanView: the band surface, open, nothing filled in, and no
        Poisson bubble past the measured depths (the shaft and the background plane)."""
        view = self.scan()
        mesh = scan_mesh.create(self.doc, view, method="Poisson", fill="Open", sample_spacing_mm=0.5)
        self.assertTrue(mesh.isValid(), mesh.getStatusString())
        FreeCAD.Console.PrintMessage("Poisson, fill open, one view: %s\n" % mesh.Check)
        self.assertIn("NOT watertight", mesh.Check)
        self.assertIn("0 non-manifold edges, 0 non-manifold vertices", mesh.Check)
        self.assertIn("0.0 % of the surface filled in", mesh.Check)
        self.assertGreater(mesh.Mesh.CountFacets, 10000)
        box = mesh.Mesh.BoundBox
        self.assertLess(box.ZMax, BACKGROUND_Z_MM + 1.0)
        self.assertGreater(box.ZMin, 400.0 - SHAFT_RADIUS_MM - 1.0)
        with self.assertRaisesRegex(picoscan.Error, "fill must be one of"):
            scan_mesh.create(self.doc, view, method="Poisson", fill="Bubble")

    def test_make_solid(self):
        view = self.scan()
        open_mesh = scan_mesh.create(self.doc, view, pixel_step=8)
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "not closed"):
            solid.make_solid(self.doc, open_mesh)
        self.assertEqual([o.Name for o in self.doc.Objects], names)
        closed = self.doc.addObject("Mesh::Feature", "Closed")
        closed.Mesh = Mesh.createSphere(10.0, 60)  # 7080 facets
        feature = solid.make_solid(self.doc, closed)
        self.assertTrue(feature.Shape.isValid())
        self.assertEqual(feature.Shape.ShapeType, "Solid")
        # The curved facets simplified (every mesh vertex within 4 x the noise estimated from the
        # mesh), the volume kept.
        self.assertLess(len(feature.Shape.Faces), closed.Mesh.CountFacets / 5)
        self.assertIn("curved regions simplified", feature.SolidReport)
        self.assertAlmostEqual(feature.Shape.Volume, closed.Mesh.Volume, delta=1e-4 * closed.Mesh.Volume)
        # Facets turned inwards: the same solid, outward.
        inverted = closed.Mesh.copy()
        inverted.flipNormals()
        shape = solid.solid_of_mesh(inverted, "inverted")
        self.assertAlmostEqual(shape.Volume, closed.Mesh.Volume, delta=1e-4 * closed.Mesh.Volume)
        # Two overlapping closed spheres in one mesh bound no single solid: refused, nothing added.
        overlapping = Mesh.createSphere(10.0, 30)
        other = Mesh.createSphere(10.0, 30)
        other.translate(8, 0, 0)
        overlapping.addMesh(other)
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "overlap: the mesh intersects itself"):
            solid.solid_of_mesh(overlapping, "overlap")
        self.assertEqual([o.Name for o in self.doc.Objects], names)

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
            shaft.Radius.Value, (shaft.Radius.Value - SHAFT_RADIUS_MM) * 1000, shaft.FitRms.Value, shaft.InlierCount))
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
            wall.Placement.Base.z, BACKGROUND_Z_MM, math.degrees(normal.getAngle(FreeCAD.Vector(0, 0, -1))), wall.FitRms.Value))
        self.assertGreater(-normal.z, math.cos(math.radians(0.05)))
        self.assertAlmostEqual(wall.Placement.Base.z, BACKGROUND_Z_MM, delta=0.05)
        self.assertLess(wall.FitRms.Value, 0.1)
        self.assertEqual(wall.FitRms.Unit, FreeCAD.Units.Length)  # shown in mm in the property editor
        self.assertGreater(wall.Shape.Area, 100 * 100)

    def test_cross_section_sketch_and_profile_plot(self):
        view = self.scan()
        mesh = scan_mesh.create(self.doc, view, pixel_step=1)
        sketch = section.cross_section(self.doc, mesh, axis="Y", offset_mm=0.0)
        self.assertTrue(sketch.isValid())
        FreeCAD.Console.PrintMessage("shaft section: scan noise %.4f mm, tolerance %.4f mm (%s)\n%s\n" % (
            sketch.FitNoise.Value, sketch.FitTolerance.Value, sketch.FitToleranceFrom, "\n".join(sketch.FitReport)))
        # The mesh has its scan behind it: the default tolerance is 5 x the scan's noise, measured on
        # the ScanView's points by the core, whatever the mesh's cut shows.
        noise = picoscan.estimate_scan_noise(cloud_of(view))
        self.assertGreater(noise, 0.001)
        self.assertLess(noise, 0.05)
        self.assertEqual(sketch.FitNoise.Value, noise)
        self.assertAlmostEqual(sketch.FitTolerance.Value, max(0.005, 5 * noise), delta=1e-12)
        self.assertEqual(sketch.FitToleranceFrom, "the scan %s: tolerance %.4f mm: 5 x the noise of the scan the mesh was "
                         "made from, %.4f mm (measured on its points)" % (view.Label, sketch.FitTolerance.Value, noise))
        given = section.cross_section(self.doc, mesh, axis="Y", offset_mm=0.0, tolerance_mm=0.05, name="Given")
        self.assertEqual((given.FitNoise.Value, given.FitToleranceFrom), (0.0, "tolerance 0.0500 mm: given"))
        self.doc.removeObject(given.Name)
        # Built to fool a default from the mesh: a Poisson surface (2 mm samples) of the same view is
        # smoother than its scan, so its cut shows a fraction of the scan's noise. The default
        # tolerance is 5 x the scan's noise all the same, and says so.
        smooth = scan_mesh.create(self.doc, view, method="Poisson", sample_spacing_mm=2.0, fill="Open", name="Smooth")
        _, cut = section.fitted_section(smooth.Mesh, smooth.Label, "Y", 0.0, band_mm=0.0,
                                       scan=section.scan_behind(smooth)[0])
        used = cut.scan_noise_mm
        FreeCAD.Console.PrintMessage("Poisson mesh of the shaft view: noise of its cut %.4f mm, of the scan %.4f mm\n" % (
            cut.fits.noise_mm, noise))
        self.assertEqual(used, noise)
        self.assertLess(cut.fits.noise_mm, noise / 2)  # the mesh hides the scan's noise
        # The scan in another frame (moved 10 mm along each axis) is not the mesh's: refused before its
        # noise sets the tolerance.
        moved = section.placed_cloud(section.scan_behind(smooth)[0], FreeCAD.Placement(FreeCAD.Vector(10, 10, 10), FreeCAD.Rotation()))
        with self.assertRaisesRegex(picoscan.Error, "is not the scan this mesh was made from"):
            section.fitted_section(smooth.Mesh, smooth.Label, "Y", 0.0, band_mm=0.0, scan=moved)
        smooth_sketch = section.cross_section(self.doc, smooth, axis="Y", offset_mm=0.0, band_mm=0.0, name="SmoothSection")
        self.assertTrue(smooth_sketch.isValid(), smooth_sketch.getStatusString())
        self.assertEqual(smooth_sketch.FitNoise.Value, noise)
        self.assertAlmostEqual(smooth_sketch.FitTolerance.Value, 5 * noise, delta=1e-12)
        self.assertTrue(smooth_sketch.FitToleranceFrom.startswith("the scan %s: tolerance %.4f mm: 5 x the noise of the scan" % (
            view.Label, smooth_sketch.FitTolerance.Value)), smooth_sketch.FitToleranceFrom)
        self.assertEqual(len(sketch.FitReport), sketch.GeometryCount)
        self.assertLess(sketch.GeometryCount, 20)  # fitted elements, not hundreds of segments
        self.assertLess(sketch.FitTolerance.Value, 0.2)
        for geometry in sketch.Geometry:
            point = sketch.Placement.multVec(geometry.StartPoint)
            self.assertAlmostEqual(point.y, 0.0, delta=1e-6)
        # The shaft's visible half is one arc of the true radius around the true axis.
        arcs = [g for g in sketch.Geometry if g.TypeId == "Part::GeomArcOfCircle"]
        shaft = [a for a in arcs if (sketch.Placement.multVec(a.Center) - FreeCAD.Vector(0, 0, 400)).Length < 0.1]
        self.assertEqual(len(shaft), 1, [(a.Radius, sketch.Placement.multVec(a.Center)) for a in arcs])
        FreeCAD.Console.PrintMessage("shaft arc radius %.4f mm (error %.1f um)\n" % (
            shaft[0].Radius, 1000 * (shaft[0].Radius - SHAFT_RADIUS_MM)))
        self.assertAlmostEqual(shaft[0].Radius, SHAFT_RADIUS_MM, delta=0.02)
        plot = section.hybrid_vs_binary_plot(view, "Y", 0.0, os.path.join(self.folder, "profile.png"))
        self.assertGreater(os.path.getsize(plot), 10000)
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "does not cut"):
            section.cross_section(self.doc, mesh, axis="Y", offset_mm=500.0)
        with self.assertRaisesRegex(picoscan.Error, "Tolerance: must be 0"):
            section.cross_section(self.doc, mesh, axis="Y", offset_mm=0.0, tolerance_mm=-1)
        self.assertEqual([o.Name for o in self.doc.Objects], names)

    def test_deviation_map_of_the_shaft_follows_the_model(self):
        view = self.scan()
        model = self.doc.addObject("Part::Cylinder", "ShaftModel")
        model.Radius = SHAFT_RADIUS_MM
        model.Height = 80
        model.Placement = FreeCAD.Placement(FreeCAD.Vector(0, -40, 400),
                                            FreeCAD.Rotation(FreeCAD.Vector(0, 0, 1), FreeCAD.Vector(0, 1, 0)))
        self.doc.recompute()
        report = os.path.join(self.folder, "shaft_deviation.html")
        result = deviation_map.create(self.doc, view, model, tolerance_mm=0.05, max_distance_mm=1.0, report_file=report)
        FreeCAD.Console.PrintMessage("shaft deviation: %s\n" % result.Summary)
        self.assertGreater(result.PointCount, 10000)
        self.assertEqual(result.Points.CountPoints, view.PointCount)  # the wall is kept, grey, out of the figures
        self.assertEqual(len(result.Color), result.Points.CountPoints)
        self.assertLess(abs(result.MeanDeviation.Value), 0.01)
        self.assertLess(result.MeanAbsDeviation.Value, 0.03)
        self.assertLess(result.Sigma.Value, 0.04)
        self.assertGreater(result.WithinTolerance, 90)
        for path in (report, report + ".png", os.path.join(self.folder, "shaft_deviation.ply")):
            self.assertGreater(os.path.getsize(path), 500, path)
        # Parametric: a model 0.1 mm fatter puts the scan 0.1 mm inside it after recompute.
        model.Radius = SHAFT_RADIUS_MM + 0.1
        self.doc.recompute()
        self.assertTrue(result.isValid(), result.getStatusString())
        FreeCAD.Console.PrintMessage("after radius + 0.1 mm: %s\n" % result.Summary)
        self.assertAlmostEqual(result.MeanDeviation.Value, -0.1, delta=0.01)
        self.assertLess(result.WithinTolerance, 10)
        # A shaft alone can slide along and turn about its axis: best fit refuses, the scan stays put.
        with self.assertRaisesRegex(picoscan.Error, "do not fix all six degrees of freedom"):
            alignment.best_fit(view, model)
        self.assertTrue(view.Placement.isIdentity())
        # Bad input: nothing is added.
        far = self.doc.addObject("Part::Box", "FarAway")  # 1 m from the scan
        far.Placement.Base = FreeCAD.Vector(1000, 0, 0)
        self.doc.recompute()
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "no faces or triangles"):
            deviation_map.create(self.doc, view, view)
        with self.assertRaisesRegex(picoscan.Error, "Tolerance: must be positive"):
            deviation_map.create(self.doc, view, model, tolerance_mm=0)
        with self.assertRaisesRegex(picoscan.Error, "none lies within"):
            deviation_map.create(self.doc, view, far, max_distance_mm=1.0)
        self.assertEqual([o.Name for o in self.doc.Objects], names)
        # Set to 0 in the property editor: the map's Deflection is named, not as if it were the model's.
        result.Deflection = 0
        self.doc.recompute()
        self.assertEqual(result.getStatusString(), "Deflection: must be positive, is 0 mm (how far the tessellated "
                                                   "ShaftModel may lie from its true surface)")
        result.Deflection = 0.005
        self.doc.recompute()
        self.assertTrue(result.isValid())

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
        view = self.scan()
        names = [o.Name for o in self.doc.Objects]
        missing = os.path.join(self.folder, "no_such_folder")
        with self.assertRaisesRegex(picoscan.Error, "no_such_folder: capture folder does not exist"):
            scan_view.create(self.doc, missing, self.calibration)
        wrong = os.path.join(self.folder, "wrong.yml")
        picoscan.write_calibration(picoscan.seed_rig_calibration(), wrong)  # full-size camera, 1600 x 1200
        with self.assertRaisesRegex(picoscan.Error, "000_white.png: image is 800x600 but the calibration.s camera_size is 1600x1200"):
            scan_view.create(self.doc, self.captures, wrong)
        garbage = os.path.join(self.folder, "garbage.yml")
        with open(garbage, "w") as stream:
            stream.write("not: a calibration\n")
        with self.assertRaisesRegex(picoscan.Error, "garbage.yml"):
            scan_view.create(self.doc, self.captures, garbage)
        self.assertEqual([o.Name for o in self.doc.Objects], names)
        self.assertTrue(all(o.isValid() for o in self.doc.Objects))
        # A property out of the core's range: the error names the property, not the core's option.
        view.MinContrast = 300
        self.doc.recompute()
        self.assertEqual(view.getStatusString(), "%s: MinContrast: must be 0..255" % view.Label)
        view.MinContrast = 15
        view.Clean, view.MaxGrazingAngle = True, 200
        self.doc.recompute()
        self.assertEqual(view.getStatusString(), "%s: MaxGrazingAngle: must be 0..180" % view.Label)
        view.Clean, view.MaxGrazingAngle = False, 80
        mesh = scan_mesh.create(self.doc, view, pixel_step=4)
        mesh.MaxEdgeFactor = -1
        self.doc.recompute()
        self.assertEqual(mesh.getStatusString(), "%s: MaxEdgeFactor: must be 0.01..10000" % mesh.Label)
        # The Mesh panel's "Unseen side" Table refused (a Stitch of too few views): named as the Fill property.
        from picoscan_wb.objects import _naming_the_property

        refused = picoscan.Error("mesh.fill: table: the edge of the unseen side does not lie on one plane")
        self.assertEqual(str(_naming_the_property(mesh, refused)),
                         "%s: Fill: table: the edge of the unseen side does not lie on one plane" % mesh.Label)

    def test_save_reopen_recompute(self):
        view = self.scan(part_frame=True)
        mesh = scan_mesh.create(self.doc, view, pixel_step=4)
        # Up to date as FreeCAD's own tools leave what they make, not marked as needing a recompute.
        self.assertEqual([o.Name for o in self.doc.Objects if "Touched" in o.State], [])
        points, facets = view.PointCount, mesh.Mesh.CountFacets
        view_name, mesh_name = view.Name, mesh.Name
        path = os.path.join(self.folder, "scan.FCStd")
        self.doc.saveAs(path)
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(path)
        view, mesh = self.doc.getObject(view_name), self.doc.getObject(mesh_name)
        self.assertEqual(view.Points.CountPoints, points)  # stored in the file
        self.assertEqual(len(view.Normal), points)
        self.assertEqual(mesh.Mesh.CountFacets, facets)
        self.assertEqual(view.Proxy.Type, "PicoScan::ScanView")
        view.touch()
        self.doc.recompute()
        self.assertTrue(view.isValid() and mesh.isValid())
        self.assertEqual(view.PointCount, points)
        self.assertEqual(mesh.Mesh.CountFacets, facets)

    def test_scan_view_saved_before_normals_gets_them_on_reopen_from_its_stored_view(self):
        """A ScanView saved before views had normals (no Normal property) gets them when reopened, from the
        view kept in the document when its capture folder is gone; saved before views were kept too,
        with nothing to recompute from, it opens without them (drawn flat, a warning) and stays valid."""
        view = self.scan()
        points, name = view.PointCount, view.Name
        view.removeProperty("Normal")
        view.CaptureFolder = os.path.join(self.folder, "moved_away")
        view.purgeTouched()
        path = os.path.join(self.folder, "saved_before_normals.FCStd")
        self.doc.saveAs(path)
        view.removeProperty("StoredView")
        view.removeProperty("StoredDecoding")
        older = os.path.join(self.folder, "saved_before_stored_views.FCStd")
        self.doc.saveAs(older)
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(path)
        view = self.doc.getObject(name)
        self.assertEqual(len(view.Normal), points)
        self.assertNotIn("Touched", view.State)
        self.check_normals(view)
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(older)
        view = self.doc.getObject(name)
        self.assertEqual(len(view.Normal), 0)
        self.assertEqual(view.Points.CountPoints, points)
        self.assertTrue(view.isValid())

    def test_part_frame_on_the_base_plane_and_what_follows_it(self):
        """The shaft's scan stands on the wall behind it: Z along the wall's normal towards the camera,
        the wall at z = 0, the shaft's axis 60 mm above it; meshes and fitted primitives follow, and a
        recompute keeps the placement."""
        view = self.scan()
        frame = datum.place_in_part_frame(view)
        FreeCAD.Console.PrintMessage("part frame of the shaft scan: %s\n" % frame.basis)
        self.assertIn("base plane", view.PartFrame)
        z_axis = numpy.asarray(frame.frame.z_axis)
        self.assertGreater(-z_axis[2], math.cos(math.radians(0.05)))  # the camera's -z: out of the wall
        box = view.Points.BoundBox
        self.assertAlmostEqual(box.ZMin, 0.0, delta=0.3)
        self.assertAlmostEqual(box.ZMax, BACKGROUND_Z_MM - 400.0 + SHAFT_RADIUS_MM, delta=0.3)
        mesh = scan_mesh.create(self.doc, view, pixel_step=4)
        self.assertAlmostEqual(mesh.Mesh.BoundBox.ZMax, box.ZMax, delta=0.3)
        group, created = primitives.fit_primitives(self.doc, cloud_of(view), placement=view.Placement)
        shaft = [obj for obj, _ in created if obj.TypeId == "Part::Cylinder"][0]
        axis = shaft.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        self.assertLess(abs(axis.z), math.sin(math.radians(0.1)))  # parallel to the wall
        self.assertAlmostEqual(shaft.Placement.Base.z, BACKGROUND_Z_MM - 400.0, delta=0.05)
        placement = view.Placement
        view.touch()
        self.doc.recompute()
        self.assertTrue(view.isValid() and mesh.isValid(), view.getStatusString())
        self.assertEqual(view.Placement, placement)
        self.assertAlmostEqual(view.Points.BoundBox.ZMax, box.ZMax, delta=1e-3)
        self.assertAlmostEqual(mesh.Mesh.BoundBox.ZMax, box.ZMax, delta=0.3)

    def test_bad_input_during_recompute_prints_one_line_not_a_traceback(self):
        """What the Report view shows: a separate freecadcmd runs brief_errors_script.py."""
        import subprocess

        workbench = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "brief_errors_script.py")
        environment = dict(os.environ, PICOSCAN_WORKBENCH=workbench, PICOSCAN_CAPTURES=self.captures,
                           PICOSCAN_CALIBRATION=self.calibration)
        run = subprocess.run(["freecadcmd", script], env=environment, capture_output=True, text=True, timeout=300)
        output = run.stdout + run.stderr
        self.assertIn("DONE", output, output[-3000:])
        self.assertIn("MESH VALID False: ScanMesh: PixelStep must be at least 1", output)
        self.assertIn("CREATE REFUSED: ScanMesh001: PixelStep must be at least 1", output)
        self.assertIn("VIEW VALID False", output)
        self.assertIn("<class 'picoscan.Error'>: ScanMesh: PixelStep must be at least 1", output)
        self.assertNotIn("Traceback", output, output[-3000:])
        self.assertNotIn('File "', output)
        # Only bad input is shortened: a real bug's traceback is whole afterwards.
        lines = int(output.split("BUG TRACEBACK LINES ")[1].split()[0])
        self.assertGreaterEqual(lines, 3)

    def test_document_recomputes_without_its_capture_folder(self):
        """The decoded view is kept in the .FCStd: with the captures deleted, the reopened document
        still meshes, fits and measures, with the same results."""
        captures = os.path.join(self.folder, "doomed_captures")
        shutil.copytree(self.captures, captures)
        view = scan_view.create(self.doc, captures, self.calibration)
        mesh = scan_mesh.create(self.doc, view, pixel_step=4)
        poisson = scan_mesh.create(self.doc, view, method="Poisson", fill="Open", sample_spacing_mm=4.0, name="PoissonMesh")
        _, fitted = primitives.fit_primitives(self.doc, cloud_of(view), placement=view.Placement)
        table = measurements.create(self.doc, [obj for obj, _ in fitted])
        model = self.doc.addObject("Part::Cylinder", "ShaftModel")
        model.Radius, model.Height = SHAFT_RADIUS_MM, 80
        model.Placement = FreeCAD.Placement(FreeCAD.Vector(0, -40, 400),
                                            FreeCAD.Rotation(FreeCAD.Vector(0, 0, 1), FreeCAD.Vector(0, 1, 0)))
        self.doc.recompute()
        deviation = deviation_map.create(self.doc, view, model, tolerance_mm=0.05, max_distance_mm=1.0)
        shaft = [shape for _, shape in fitted if shape.kind == picoscan.ShapeKind.Cylinder][0]
        before = (view.PointCount, mesh.Mesh.CountFacets, deviation.MeanAbsDeviation.Value, deviation.PointCount)
        names = (view.Name, mesh.Name, deviation.Name)
        poisson_before = (poisson.Mesh.CountPoints, poisson.Mesh.CountFacets, poisson.Mesh.Area, poisson.Check)
        table_before = list(table.Table)
        self.assertGreaterEqual(len(table_before), 2, table_before)  # the shaft and the wall: a diameter, an axis angle
        self.assertGreater(poisson_before[1], 1000)
        poisson_name, table_name = poisson.Name, table.Name
        path = os.path.join(self.folder, "self_contained.FCStd")
        self.doc.saveAs(path)
        FreeCAD.closeDocument(self.doc.Name)
        shutil.rmtree(captures)
        self.doc = FreeCAD.openDocument(path)
        view, mesh, deviation = (self.doc.getObject(name) for name in names)
        poisson, table = self.doc.getObject(poisson_name), self.doc.getObject(table_name)
        poisson.Mesh, table.Table = Mesh.Mesh(), []  # emptied: what they show next is recomputed
        for obj in (view, poisson, table):
            obj.touch()
        self.doc.recompute()
        self.assertTrue(all(o.isValid() for o in (view, mesh, deviation, poisson, table)),
                        [o.getStatusString() for o in (view, mesh, deviation, poisson, table)])
        # The Poisson mesh is remade from the stored view (recomputed, not just reloaded), the table from the
        # fitted features: the same figures as before saving.
        poisson_after = (poisson.Mesh.CountPoints, poisson.Mesh.CountFacets, poisson.Mesh.Area, poisson.Check)
        FreeCAD.Console.PrintMessage("without captures: Poisson points, facets, area, check: %s -> %s; measurements %s -> %s\n"
                                     % (poisson_before, poisson_after, table_before, list(table.Table)))
        self.assertEqual(poisson_after[:2], poisson_before[:2])
        self.assertAlmostEqual(poisson_after[2], poisson_before[2], delta=1e-6 * poisson_before[2])
        self.assertEqual(poisson_after[3], poisson_before[3])
        self.assertEqual(list(table.Table), table_before)
        after = (view.PointCount, mesh.Mesh.CountFacets, deviation.MeanAbsDeviation.Value, deviation.PointCount)
        FreeCAD.Console.PrintMessage("without captures: points, facets, mean |d|, measured: %s -> %s\n" % (before, after))
        self.assertEqual(after[:2], before[:2])
        self.assertAlmostEqual(after[2], before[2], delta=1e-6)
        self.assertEqual(after[3], before[3])
        again = [shape for shape in picoscan.detect_shapes(cloud_of(view), primitives.detection_options())
                 if shape.kind == picoscan.ShapeKind.Cylinder][0]
        self.assertAlmostEqual(again.radius_mm, shaft.radius_mm, delta=1e-4)
        mesh.PixelStep = 8  # still parametric: a coarser grid from the stored view
        self.doc.recompute()
        self.assertTrue(mesh.isValid(), mesh.getStatusString())
        self.assertLess(mesh.Mesh.CountFacets, before[1] / 3)
        # Decoding differently needs the captures: refused with the reason, the points stay.
        view.MinContrast = 100
        self.doc.recompute()
        self.assertFalse(view.isValid())
        self.assertRegex(view.getStatusString(), "doomed_captures is gone, and the view kept in the document was decoded "
                                                 "with other parameters")
        self.assertEqual(view.Points.CountPoints, before[0])


class PicoScanStereoTest(unittest.TestCase):
    """Two cameras 200 mm apart (the seed stereo rig at half resolution, 800 x 600), the projector between
    them uncalibrated, looking at a sphere of radius 25 mm 400 mm away: a ScanView from a stereo calibration
    and two capture folders."""

    CENTRE = (0.0, 0.0, 400.0)
    RADIUS_MM = 25.0

    @classmethod
    def setUpClass(cls):
        cls.folder = tempfile.mkdtemp(prefix="picoscan_stereo_")
        cls.first, cls.second = os.path.join(cls.folder, "camera1"), os.path.join(cls.folder, "camera2")
        scene = picoscan.Scene()
        scene.add_sphere(cls.CENTRE, cls.RADIUS_MM, 0.9)
        cls.calibration = simulate.simulate_stereo_scan(cls.first, cls.second, scene, camera_scale=0.5)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder, ignore_errors=True)

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanStereoTest")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)

    def sphere_fit(self, view):
        fit = picoscan.fit_sphere(numpy.array([tuple(p) for p in view.Points.Points], dtype=numpy.float32))
        centre_error = numpy.linalg.norm(numpy.asarray(fit.centre) - self.CENTRE)
        FreeCAD.Console.PrintMessage("stereo ScanView: %d points, radius %.4f mm (truth %.1f), centre error %.4f mm, "
                                     "RMS %.4f mm; %s\n" % (view.PointCount, fit.radius_mm, self.RADIUS_MM, centre_error,
                                                             fit.rms_mm, view.StereoReport))
        return fit, centre_error

    def test_stereo_scan_view_measures_the_sphere_and_survives_reopening(self):
        view = scan_view.create(self.doc, self.first, self.calibration, second_capture_folder=self.second)
        self.assertTrue(view.isValid(), view.getStatusString())
        self.assertEqual(view.SecondCaptureFolder, self.second)
        self.assertGreater(view.PointCount, 15000)  # of the ~18700 sphere pixels the first camera decodes
        fit, centre_error = self.sphere_fit(view)
        self.assertLess(abs(fit.radius_mm - self.RADIUS_MM), 0.015)
        self.assertLess(centre_error, 0.02)
        self.assertLess(fit.rms_mm, 0.02)
        self.assertIn("left-right consistency", view.StereoReport)
        # The rig of a stereo calibration: the second camera's centre is the baseline away.
        _, _, second_camera = rig.show_rig(self.doc, self.calibration)
        self.assertAlmostEqual(second_camera.Shape.Edges[0].Vertexes[0].Point.Length, 200.0, delta=1e-6)
        # The camera-projector fields stay empty: nothing was confirmed or cleaned.
        self.assertEqual(view.CleanReport, "")
        points, name = view.PointCount, view.Name
        path = os.path.join(self.folder, "stereo.FCStd")
        self.doc.saveAs(path)
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(path)
        view = self.doc.getObject(name)
        self.assertEqual(view.Points.CountPoints, points)
        view.touch()
        self.doc.recompute()
        self.assertTrue(view.isValid(), view.getStatusString())
        self.assertEqual(view.PointCount, points)
        # Parametric: without the second folder the stereo calibration cannot be used, and the object says why.
        view.SecondCaptureFolder = ""
        self.doc.recompute()
        self.assertFalse(view.isValid())
        self.assertIn("SecondCaptureFolder", view.getStatusString())

    def test_stereo_view_recomputes_without_its_second_capture_folder(self):
        """A saved stereo ScanView whose second camera's captures are deleted recomputes from the view kept in
        the .FCStd (with the stereo calibration), its grid mesh too; clearing SecondCaptureFolder then says why
        in one line and keeps the points."""
        second = os.path.join(self.folder, "doomed_camera2")
        shutil.copytree(self.second, second)
        view = scan_view.create(self.doc, self.first, self.calibration, second_capture_folder=second)
        mesh = scan_mesh.create(self.doc, view, pixel_step=2)
        fit, _ = self.sphere_fit(view)
        before = (view.PointCount, mesh.Mesh.CountFacets, fit.radius_mm, tuple(fit.centre))
        names = (view.Name, mesh.Name)
        path = os.path.join(self.folder, "stereo_self_contained.FCStd")
        self.doc.saveAs(path)
        FreeCAD.closeDocument(self.doc.Name)
        shutil.rmtree(second)
        self.doc = FreeCAD.openDocument(path)
        view, mesh = (self.doc.getObject(name) for name in names)
        mesh.Mesh = Mesh.Mesh()  # emptied: what it shows next is recomputed from the stored view
        view.touch()
        mesh.touch()
        self.doc.recompute()
        self.assertTrue(view.isValid() and mesh.isValid(), (view.getStatusString(), mesh.getStatusString()))
        fit, _ = self.sphere_fit(view)
        after = (view.PointCount, mesh.Mesh.CountFacets, fit.radius_mm, tuple(fit.centre))
        FreeCAD.Console.PrintMessage("stereo without its second folder: points, facets, radius, centre: %s -> %s\n"
                                     % (before, after))
        self.assertEqual(after[:2], before[:2])
        self.assertAlmostEqual(after[2], before[2], delta=1e-6)
        self.assertLess(numpy.linalg.norm(numpy.subtract(after[3], before[3])), 1e-6)
        self.assertEqual(type(view.Proxy.scan_view(view)[1]), picoscan.StereoCalibration)
        # Clearing the second folder: the stereo calibration needs it, stored view or not.
        view.SecondCaptureFolder = ""
        self.doc.recompute()
        self.assertFalse(view.isValid())
        self.assertRegex(view.getStatusString(), "^SecondCaptureFolder: .*stereo.yml is a stereo calibration")
        self.assertEqual(view.Points.CountPoints, before[0])

    def test_clearing_the_second_folder_prints_one_line_not_a_traceback(self):
        """What the Report view shows: a separate freecadcmd runs brief_errors_script.py on the stereo captures."""
        import subprocess

        workbench = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "brief_errors_script.py")
        environment = dict(os.environ, PICOSCAN_WORKBENCH=workbench, PICOSCAN_STEREO_CAPTURES=self.first,
                           PICOSCAN_STEREO_SECOND=self.second, PICOSCAN_STEREO_CALIBRATION=self.calibration)
        environment.pop("PICOSCAN_CAPTURES", None)
        run = subprocess.run(["freecadcmd", script], env=environment, capture_output=True, text=True, timeout=300)
        output = run.stdout + run.stderr
        self.assertIn("DONE", output, output[-3000:])
        cleared = "SecondCaptureFolder: %s is a stereo calibration (two cameras): give the second camera's capture " \
                  "folder" % self.calibration
        self.assertIn("STEREO CLEARED VALID False: " + cleared, output)
        self.assertIn("STEREO REOPENED CLEARED VALID False: " + cleared, output)
        self.assertIn("<class 'picoscan.Error'>: " + cleared, output)
        self.assertNotIn("Traceback", output, output[-3000:])
        self.assertNotIn('File "', output)

    def test_progress_reports_the_stereo_stages_and_cancel_stops_matching(self):
        # The progress the GUI's dialog shows (and its Cancel answers) while the work runs off the GUI thread.
        stages = set()
        reconstruct.reconstruct(self.first, self.calibration, second_capture_folder=self.second,
                                progress=lambda fraction, stage: stages.add(stage) or True)
        self.assertTrue({"load", "decode", "stereo"} <= stages, stages)
        with self.assertRaisesRegex(picoscan.Error, "cancelled"):
            reconstruct.reconstruct(self.first, self.calibration, second_capture_folder=self.second,
                                    progress=lambda fraction, stage: stage != "stereo")

    def test_opencv_stereo_calibration_file_gives_the_same_scan(self):
        # The keys OpenCV's stereoCalibrate sample writes (M1 D1 M2 D2 R T) plus image_size.
        stereo = picoscan.read_stereo_calibration(self.calibration)

        def matrix(name, values, rows, cols):
            data = ", ".join("%.17g" % v for v in numpy.asarray(values, dtype=float).ravel())
            return "%s: !!opencv-matrix\n   rows: %d\n   cols: %d\n   dt: d\n   data: [ %s ]\n" % (name, rows, cols, data)

        text = "%YAML:1.0\n---\n" + "image_size: [ %d, %d ]\n" % tuple(stereo.left_size)
        text += matrix("M1", stereo.left_matrix, 3, 3) + matrix("D1", stereo.left_distortion, 1, 5)
        text += matrix("M2", stereo.right_matrix, 3, 3) + matrix("D2", stereo.right_distortion, 1, 5)
        text += matrix("R", stereo.R, 3, 3) + matrix("T", stereo.T, 3, 1)
        opencv_file = os.path.join(self.folder, "opencv_stereo.yml")
        with open(opencv_file, "w") as stream:
            stream.write(text)
        ours = scan_view.create(self.doc, self.first, self.calibration, second_capture_folder=self.second)
        theirs = scan_view.create(self.doc, self.first, opencv_file, second_capture_folder=self.second)
        self.assertTrue(theirs.isValid(), theirs.getStatusString())
        self.assertEqual(theirs.PointCount, ours.PointCount)
        difference = numpy.abs(numpy.array(theirs.Points.Points) - numpy.array(ours.Points.Points)).max()
        self.assertLess(difference, 1e-4)

    def test_wrong_calibration_or_folders_are_refused_and_leave_the_document_unchanged(self):
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "^SecondCaptureFolder: .*stereo.yml is a stereo calibration"):
            scan_view.create(self.doc, self.first, self.calibration)
        projector_calibration = os.path.join(self.folder, "camera_projector.yml")
        picoscan.write_calibration(simulate.scaled_stereo_rig(picoscan.seed_stereo_rig(), 0.5).left,
                                   projector_calibration)
        with self.assertRaisesRegex(picoscan.Error, "^SecondCaptureFolder: .*camera_projector.yml is a camera-projector"):
            scan_view.create(self.doc, self.first, projector_calibration, second_capture_folder=self.second)
        with self.assertRaisesRegex(picoscan.Error, "no_such_folder: second capture folder does not exist"):
            scan_view.create(self.doc, self.first, self.calibration,
                             second_capture_folder=os.path.join(self.folder, "no_such_folder"))
        # The cameras swapped, and a calibration whose second camera is turned 0.1 degree about the
        # baseline: both decode and match, but the rows show that R, T do not fit.
        with self.assertRaisesRegex(picoscan.Error, "does not fit these captures"):
            scan_view.create(self.doc, self.second, self.calibration, second_capture_folder=self.first)
        turned = picoscan.read_stereo_calibration(self.calibration)
        angle = math.radians(0.1)
        turned.R = numpy.array([[1, 0, 0], [0, math.cos(angle), -math.sin(angle)],
                                [0, math.sin(angle), math.cos(angle)]]) @ numpy.asarray(turned.R)
        turned_file = os.path.join(self.folder, "turned.yml")
        picoscan.write_stereo_calibration(turned, turned_file)
        with self.assertRaisesRegex(picoscan.Error, "does not fit these captures"):
            scan_view.create(self.doc, self.first, turned_file, second_capture_folder=self.second)
        full_size = os.path.join(self.folder, "full_size.yml")
        picoscan.write_stereo_calibration(picoscan.seed_stereo_rig().stereo, full_size)
        with self.assertRaisesRegex(picoscan.Error, "full_size.yml: camera1_size is 1600x1200 but the captures in .* are 800x600"):
            scan_view.create(self.doc, self.first, full_size, second_capture_folder=self.second)
        self.assertEqual([o.Name for o in self.doc.Objects], names)


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
        # It lands in its part frame: Z up the turntable's axis, the part's foot at z = 0.
        plan = picoscan.TurntablePlan()
        plan.top_view = False
        part_to_camera = numpy.asarray(picoscan.turntable_part_poses(plan)[0])
        to_document = numpy.array(merged.Placement.toMatrix().A).reshape(4, 4) @ part_to_camera
        tilt = math.degrees(math.acos(min(1.0, to_document[2, 2])))
        origin = to_document[:3, 3]  # where the part's own origin (its foot, on the axis) landed
        FreeCAD.Console.PrintMessage("stitch part frame (%s): Z off %.4f deg, part origin at (%.3f, %.3f, %.3f) mm\n" % (
            merged.PartFrame, tilt, origin[0], origin[1], origin[2]))
        self.assertIn("turntable axis", merged.PartFrame)
        self.assertLess(tilt, 0.1)
        self.assertLess(math.hypot(origin[0], origin[1]), 0.2)
        self.assertLess(abs(origin[2]), 0.5)
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
        # Simplified without crossing itself, it bounds a solid of the mesh's volume. Planar regions
        # grown on this coarse, mostly curved mesh moved its volume by 0.3 % in one run, and made a
        # solid OpenCASCADE found invalid in another (after edges were sharpened); Make solid then
        # keeps the mesh's own triangles and says so in SolidReport.
        self.assertNotIn("self-intersecting", mesh.Check)
        made = solid.make_solid(self.doc, mesh)
        FreeCAD.Console.PrintMessage("solid of the stitched mesh: %s\n" % made.SolidReport)
        self.assertTrue(made.Shape.isValid())
        self.assertLess(abs(made.Shape.Volume - mesh.Mesh.Volume), 1e-3 * mesh.Mesh.Volume)
        self.doc.removeObject(made.Name)
        stl = os.path.join(self.folder, "stitched.stl")
        Mesh.export([mesh], stl)
        self.assertEqual(Mesh.Mesh(stl).CountFacets, mesh.Mesh.CountFacets)
        with self.assertRaisesRegex(picoscan.Error, "Grid meshing needs a single ScanView"):
            scan_mesh.create(self.doc, merged, method="Grid")
        path = os.path.join(self.folder, "stitched.FCStd")
        count, name = merged.PointCount, merged.Name
        poses = [p.toMatrix() for p in merged.ViewPoses]
        self.assertEqual(merged.AlignmentReport[0], "features aligned 3 of 3 views; kept")  # Automatic, the default
        # Saved as a document from before Mode existed (a TurntableRound property instead).
        merged.removeProperty("Mode")
        merged.addProperty("App::PropertyBool", "TurntableRound", "Registration", "")
        merged.TurntableRound = True
        merged.removeProperty("Normal")  # and from before Stitches were drawn lit
        self.doc.saveAs(path)
        FreeCAD.closeDocument(self.doc.Name)
        # The capture folders are gone when the document is reopened: it stitches from the views kept in it.
        for folder, _ in self.scans:
            os.rename(folder, folder + ".gone")
        try:
            self.doc = FreeCAD.openDocument(path)
            merged = self.doc.getObject(name)
            self.assertEqual(merged.Points.CountPoints, count)
            self.assertEqual(merged.Mode, "Turntable round")  # the old property became the mode
            self.assertFalse(hasattr(merged, "TurntableRound"))
            self.assertEqual(len(merged.Normal), 0)
            self.assertIn("Touched", merged.State)  # the recompute brings its normals
            merged.Mode = "Automatic"  # three views 45 degrees apart are not a full round
            for view in merged.Views:
                view.touch()
            merged.touch()
            self.doc.recompute()
            self.assertTrue(merged.isValid(), merged.getStatusString())
            self.assertEqual(merged.PointCount, count)
            self.assertEqual(len(merged.Normal), count)
            for placement, pose in zip(merged.ViewPoses, poses):
                difference = numpy.abs(numpy.array(placement.toMatrix().A) - numpy.array(pose.A))
                self.assertLess(difference.max(), 1e-6)
        finally:
            for folder, _ in self.scans:
                os.rename(folder + ".gone", folder)

    def test_stitch_needs_two_views(self):
        views = self.scan_views()
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "two or more ScanViews"):
            stitch.create(self.doc, views[:1])
        self.assertEqual([o.Name for o in self.doc.Objects], names)


def plain_part(shape=None):
    """The built-in test part (or another shape of it) in plain grey: no paint to find features on."""
    part = picoscan.mechanical_part(shape or picoscan.MechanicalPartShape())
    part.colours = numpy.zeros((0, 3), numpy.uint8)
    return part


class PicoScanPlacementsTest(unittest.TestCase):
    """The plain grey part in two placements, one turntable round of 8 views each (half-resolution
    camera): standing, then on its side turned 20 degrees. No paint, no axis given."""

    PLACEMENTS = ((picoscan.PartPlacement.Standing, 0, 1), (picoscan.PartPlacement.OnItsSide, 20, 101))

    @classmethod
    def setUpClass(cls):
        cls.folder = tempfile.mkdtemp(prefix="picoscan_placements_")
        cls.scans, cls.truth = simulate.simulate_placements(os.path.join(cls.folder, "grey"), plain_part(),
                                                            cls.PLACEMENTS, part_albedo=0.6)
        # Another part (longer, taller, no chamfer, hole and boss elsewhere) on its side, given as if
        # it were the grey part's second placement.
        shape = picoscan.MechanicalPartShape()
        shape.length_mm, shape.width_mm, shape.height_mm, shape.chamfer_mm = 56, 30, 28, 0
        shape.hole_centre_mm, shape.boss_centre_mm = (14, 4), (-12, 0)
        cls.other, cls.other_truth = simulate.simulate_placements(os.path.join(cls.folder, "other"), plain_part(shape),
                                                    cls.PLACEMENTS[1:], part_albedo=0.6)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder, ignore_errors=True)

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanPlacementsTest")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)

    def scan_views(self, scans):
        views = []
        for folder, calibration, _ in scans:
            view = scan_view.create(self.doc, folder, calibration, clean=True)
            view.MinModulation = 15  # as the turntable session decodes
            views.append(view)
        self.doc.recompute()
        return views

    @staticmethod
    def pose_errors(views, poses, truths):
        """Worst rotation and shift of view poses (FreeCAD placements) against the truth, at each view's points."""
        worst = (0.0, 0.0)
        for view, placement, truth in zip(views, poses, truths):
            pose = numpy.array(placement.toMatrix().A).reshape(4, 4)
            error = picoscan.pose_difference(pose, truth, numpy.asarray(cloud_of(view).points).mean(axis=0))
            worst = (max(worst[0], error.rotation_deg), max(worst[1], error.translation_mm))
        return worst

    def test_two_placements_align_on_the_truth_and_a_wrong_placement_is_named(self):
        """Also the Stitch views command's path (stitch.create with the task panel's modes) on single
        rounds, sharing the views: the grey part's standing round with its true axis given as a known
        axis, then with an axis across the part (refused: one line, document unchanged); and the other
        part's round in Automatic mode (the panel's default)."""
        views = self.scan_views(self.scans)
        placements = [number for _, _, number in self.scans]
        merged = stitch.create(self.doc, views, placement_of_view=placements, mode="Turntable round")
        self.assertTrue(merged.isValid(), merged.getStatusString())
        FreeCAD.Console.PrintMessage("two placements: %s\n" % "; ".join(merged.PlacementReport))
        self.assertEqual(merged.AlignedCount, 16, merged.Report)
        self.assertEqual(len(merged.PlacementReport), 2)
        self.assertTrue(merged.PlacementReport[1].startswith("placement 2: aligned to the others"), merged.PlacementReport)
        self.assertEqual(merged.PointCount, sum(v.PointCount for v in views))
        worst = self.pose_errors(views, merged.ViewPoses, self.truth)
        FreeCAD.Console.PrintMessage("two placements: worst pose error of 16 views %.4f deg, %.4f mm\n" % worst)
        self.assertLess(worst[0], 0.05)
        self.assertLess(worst[1], 0.05)

        # A known turntable axis (as calibrated: here the truth's, in view 0's camera frame).
        started = time.monotonic()
        standing = views[:8]
        axis = picoscan.fit_turntable_axis(self.truth[:8])
        known = stitch.create(self.doc, standing, mode="Turntable axis", axis_point=tuple(axis.point_mm),
                              axis_direction=tuple(axis.direction))
        self.assertEqual(known.AlignedCount, 8, known.Report)
        self.assertEqual(list(known.AlignmentReport), ["turntable axis (given) aligned 8 of 8 views; kept"])
        self.assertEqual(known.getTypeIdOfProperty("TurntableAxisPoint"), "App::PropertyVectorDistance")  # in mm
        for line in known.Report:
            self.assertIn(": turntable axis (given), overlap", line)
        worst = self.pose_errors(standing, known.ViewPoses, self.truth)
        FreeCAD.Console.PrintMessage("known turntable axis: worst pose error of 8 views %.4f deg, %.4f mm\n" % worst)
        self.assertLess(worst[0], 0.05)
        self.assertLess(worst[1], 0.05)
        self.assertIn("turntable axis", known.PartFrame)
        # The same axis laid across the part (square to it and to the camera's line of sight): refused.
        names = [o.Name for o in self.doc.Objects]
        direction = numpy.asarray(axis.direction)
        across = (-direction[1], direction[0], 0.0)
        with self.assertRaisesRegex(picoscan.Error, r"fewer than two views could be aligned: turntable axis \(given\) "
                                                    r"aligned 1 of 8 views \(first left out: .*no turntable step fits") as refused:
            stitch.create(self.doc, standing, mode="Turntable axis", axis_point=tuple(axis.point_mm), axis_direction=across)
        FreeCAD.Console.PrintMessage("axis across the part: %s\n" % refused.exception)
        self.assertNotIn("\n", str(refused.exception))
        with self.assertRaisesRegex(picoscan.Error, "TurntableAxisDirection must not be zero"):
            stitch.create(self.doc, standing, mode="Turntable axis", axis_point=tuple(axis.point_mm))
        # Placement numbers that do not match the views (refused before any work; these views are shared
        # to save reconstructing two more).
        with self.assertRaisesRegex(picoscan.Error, "PlacementOfView has 3 entries for 2 views"):
            stitch.create(self.doc, standing[:2], placement_of_view=[1, 2, 2])
        with self.assertRaisesRegex(picoscan.Error, "PlacementOfView: .* has placement 3; number the placements 1, 2"):
            stitch.create(self.doc, standing[:2], placement_of_view=[1, 3])
        self.assertEqual([o.Name for o in self.doc.Objects], names)
        self.doc.removeObject(known.Name)
        known_seconds = time.monotonic() - started

        # Parametric: the second placement's views replaced by another part's; recompute refuses that
        # placement, names it with the reason and keeps the first placement's model.
        others = self.scan_views(self.other)
        merged.Views = views[:8] + others
        self.doc.recompute()
        self.assertTrue(merged.isValid(), merged.getStatusString())
        FreeCAD.Console.PrintMessage("another part as placement 2: %s\n" % "; ".join(merged.PlacementReport))
        self.assertTrue(merged.PlacementReport[1].startswith("placement 2: NOT aligned: "), merged.PlacementReport)
        self.assertEqual(merged.AlignedCount, 8, merged.Report)
        self.assertEqual(merged.PointCount, sum(v.PointCount for v in views[:8]))
        for line in merged.Report[8:]:
            self.assertIn("left out: aligned within placement 2, but that placement did not align", line)

        # Automatic, the panel's default, on the other part's round (a plain block on its side).
        started = time.monotonic()
        automatic = stitch.create(self.doc, others)
        FreeCAD.Console.PrintMessage("automatic stitch of the other part's round: %s\n" % " | ".join(automatic.AlignmentReport))
        self.assertEqual(automatic.Mode, "Automatic")
        self.assertEqual(automatic.AlignedCount, 8, automatic.Report)
        # Its flat faces let feature fits slide (3 of 8 views aligned by features in our runs): the round takes over.
        self.assertRegex(automatic.AlignmentReport[0], r"^features aligned [0-7] of 8 views \(first left out: .+\); not kept$")
        self.assertEqual(automatic.AlignmentReport[1], "turntable round (axis estimated) aligned 8 of 8 views; kept")
        self.assertTrue(automatic.AlignmentReport[2].startswith("turntable axis found: point ("), automatic.AlignmentReport)
        for line in automatic.Report:
            self.assertIn(": turntable round (axis estimated), overlap", line)
        worst = self.pose_errors(others, automatic.ViewPoses, self.other_truth)
        FreeCAD.Console.PrintMessage("automatic: worst pose error of 8 views %.4f deg, %.4f mm\n" % worst)
        self.assertLess(worst[0], 0.05)
        self.assertLess(worst[1], 0.05)
        FreeCAD.Console.PrintMessage("stitch mode checks took %.1f s (known and wrong axis) and %.1f s (automatic)\n" % (
            known_seconds, time.monotonic() - started))


class PicoScanSectionFitTest(unittest.TestCase):
    """The demo part's true mesh with scan-like noise on its vertices, cut at mid height: the fitted
    sketch must hold its outline (5 lines) and hole (1 circle) at the true sizes, and pad into a solid."""

    # The outline at mid height: the 50 x 36 block with its (+x, +y) corner chamfered 8 mm.
    CORNERS = [(-25, -18), (25, -18), (25, 10), (17, 18), (-25, 18)]

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanSectionTest")
        self.folder = tempfile.mkdtemp(prefix="picoscan_section_")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)
        shutil.rmtree(self.folder, ignore_errors=True)

    def noisy_part(self, sigma_mm, seed=1):
        part = picoscan.mechanical_part()
        # The part's triangles repeat their corners: one noise per position keeps the surface closed.
        positions, corner_of = numpy.unique(numpy.array(part.vertices), axis=0, return_inverse=True)
        positions = positions + numpy.random.default_rng(seed).normal(0.0, sigma_mm, positions.shape)
        part.vertices = positions[corner_of.ravel()].astype(numpy.float32)
        obj = self.doc.addObject("Mesh::Feature", "DemoPart")
        obj.Mesh = scan_mesh.freecad_mesh(part)
        return obj

    def true_directions(self):
        corners = self.CORNERS
        return [math.degrees(math.atan2(b[1] - a[1], b[0] - a[0])) for a, b in zip(corners, corners[1:] + corners[:1])]

    def direction_error(self, line):
        """Degrees between the sketch line and the nearest side of the true outline, either way along
        it: which way a section's loop runs is set by the order the mesh stores its triangles and their
        corners (the cut starts from the first triangle it meets), not by the part."""
        direction = math.degrees(math.atan2(line.EndPoint.y - line.StartPoint.y, line.EndPoint.x - line.StartPoint.x))
        return min(min(abs(direction - t) % 180, 180 - abs(direction - t) % 180) for t in self.true_directions())

    def seen_points(self, scan):
        """What a scanner sees of the part: the mesh's vertices (with their normals) less those inside
        it (the boss is a separate cylinder sunk 1 mm into the block, so the block's top under it and
        its foot are hidden). Kept per scan: the heights and the deviation map both need them."""
        cached = getattr(self, "_seen", {}).get(scan.Name)
        if cached is not None:
            return cached
        vertices = numpy.array([(p.x, p.y, p.z) for p in scan.Mesh.Topology[0]])
        normals = numpy.array([(n.x, n.y, n.z) for n in scan.Mesh.getPointNormals()])
        from_boss_axis = numpy.hypot(vertices[:, 0] - 12, vertices[:, 1] + 2)
        hidden = ((from_boss_axis < 7.05) & (vertices[:, 2] < 23.95)) | ((from_boss_axis < 6.95) & (vertices[:, 2] < 24.1))
        self._seen = {scan.Name: (vertices[~hidden], normals[~hidden])}
        return self._seen[scan.Name]

    def fitted_heights(self, scan, sigma):
        """The heights measured on the scan as a user does with Fit at picked point: a plane fitted to
        the face grown from a point picked on the bottom, on the block's top and on the boss's top
        (the core's fit_at_point), each added as a Part::Plane. Returns the bottom's z and the
        distances of the tops from the bottom along its normal (the part frame's Z)."""
        vertices, normals = self.seen_points(scan)
        cloud = picoscan.PointCloud()
        cloud.points = vertices.astype(numpy.float32)
        cloud.normals = normals.astype(numpy.float32)
        options = region_fit.picked_options(kind="plane", noise_mm=sigma)
        planes = {}
        for name, seed in (("bottom", (5.0, 10.0, 0.0)), ("top", (-5.0, 10.0, 24.0)), ("boss top", (12.0, -2.0, 32.0))):
            picked = region_fit.fit_at_point(cloud, seed, options)
            region_fit.add_fitted(self.doc, cloud, picked.fit, label="Fitted " + name)
            planes[name] = picked.fit.shape
            FreeCAD.Console.PrintMessage("plane fitted to the %s: %d points, rms %.4f mm\n" % (
                name, len(picked.region), picked.fit.shape.rms_mm))
        up = -numpy.asarray(planes["bottom"].direction)  # the bottom's outward normal points down
        base = numpy.asarray(planes["bottom"].point)
        height = {name: float(numpy.dot(numpy.asarray(planes[name].point) - base, up)) for name in ("top", "boss top")}
        for name in ("top", "boss top"):  # parallel to the bottom, as the part is
            self.assertLess(math.degrees(math.acos(min(1.0, abs(numpy.dot(planes[name].direction, up))))), 0.05)
        return float(base[2]), height["top"], height["boss top"]

    @staticmethod
    def pad_between(pad, sketch, low, high):
        """A pad of `sketch` from z = low to z = high (both lengths measured, not typed)."""
        z = sketch.Placement.Base.z
        upwards = sketch.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1)).z > 0
        pad.Type = "TwoLengths"
        pad.Length, pad.Length2 = (high - z, z - low) if upwards else (z - low, high - z)

    def test_demo_outline_gives_five_lines_and_the_hole(self):
        for sigma in (0.0, 0.01, 0.02, 0.04):
            mesh = self.noisy_part(sigma)
            sketch = section.cross_section(self.doc, mesh, axis="Z", offset_mm=12.0, name="Outline")
            self.assertTrue(sketch.isValid(), sketch.getStatusString())
            self.assertEqual(sketch.FitBand.Value, picoscan.DEFAULT_SECTION_BAND_MM)  # the default: 17 cuts over +-3 mm
            FreeCAD.Console.PrintMessage("demo outline, vertex noise %.2f mm: noise %.4f mm, tolerance %.4f mm, "
                                         "%d constraints\n%s\n" % (sigma, sketch.FitNoise.Value, sketch.FitTolerance.Value,
                                                                   sketch.ConstraintCount, "\n".join(sketch.FitReport)))
            # No scan behind this mesh: no noise is claimed (the true mesh's cut has none to speak of),
            # and the sketch says where its tolerance came from and that it is the user's to set.
            self.assertEqual(sketch.FitNoise.Value, 0.0)
            self.assertTrue(sketch.FitToleranceFrom.startswith("no scan noise known (%s was not meshed from a scan" % (
                mesh.Label)), sketch.FitToleranceFrom)
            self.assertIn("tolerance %.4f mm: from the cut of the mesh" % sketch.FitTolerance.Value, sketch.FitToleranceFrom)
            self.assertTrue(sketch.FitToleranceFrom.endswith("set it yourself"), sketch.FitToleranceFrom)
            if sigma == 0.0:
                self.assertEqual(sketch.FitTolerance.Value, 0.005)  # the core's floor
            lines = [g for g in sketch.Geometry if g.TypeId == "Part::GeomLineSegment"]
            circles = [g for g in sketch.Geometry if g.TypeId == "Part::GeomCircle"]
            self.assertEqual((len(lines), len(circles), sketch.GeometryCount), (5, 1, 6))
            for line in lines:  # after the constraints were solved
                error = self.direction_error(line)
                # One cut alone missed 0.05 degrees on the 11.3 mm chamfer at 20 and 40 um (0.075, 0.149):
                # the default band's 17 cuts hold it (0.0099 and 0.0193 when this was written).
                FreeCAD.Console.PrintMessage("  line of %.3f mm: direction error %.4f deg\n" % (line.length(), error))
                self.assertLess(error, 0.05, "line from %s to %s" % (line.StartPoint, line.EndPoint))
            hole = circles[0]
            centre = sketch.Placement.multVec(hole.Center)
            FreeCAD.Console.PrintMessage("hole radius %.4f mm (error %.1f um)\n" % (hole.Radius, 1000 * (hole.Radius - 5)))
            self.assertAlmostEqual(hole.Radius, 5.0, delta=0.02)
            self.assertAlmostEqual(centre.x, -11.0, delta=0.02)
            self.assertAlmostEqual(centre.y, 0.0, delta=0.02)
            kinds = [c.Type for c in sketch.Constraints]
            self.assertEqual(kinds.count("Coincident"), 5)
            self.assertEqual(kinds.count("Horizontal") + kinds.count("Vertical"), 4)
            # Editable and paddable: a PartDesign pad of the fitted sketch is a valid solid of the right volume.
            body = self.doc.addObject("PartDesign::Body", "Body")
            body.addObject(sketch)
            pad = body.newObject("PartDesign::Pad", "Pad")
            pad.Profile = sketch
            pad.Length = 10
            self.doc.recompute()
            self.assertTrue(pad.Shape.isValid())
            area = 50 * 36 - 8 * 8 / 2 - math.pi * 5 ** 2
            self.assertAlmostEqual(pad.Shape.Volume, 10 * area, delta=0.002 * 10 * area)
            for name in (pad.Name, body.Name, sketch.Name, mesh.Name):
                self.doc.removeObject(name)

    def test_band_keeps_to_its_cut_where_the_part_is_not_prismatic(self):
        """Built to fool the default Band: a sphere's wall (radius 10 mm, 10 um of vertex noise, as a scan's
        mesh) cut 0.5 mm above its equator, where the cuts below it nearly match the section and those
        above do not. The circle keeps to its own cut, FitReport says why, and its radius is the true
        one at that height (as Band 0 gives it)."""
        radius, height = 10.0, 0.5
        rows, columns = numpy.arange(-3.5, 4.5001, 0.1), 360
        angles = 2 * numpy.pi * numpy.arange(columns) / columns
        ring = numpy.sqrt(radius ** 2 - rows ** 2)[:, None] + numpy.random.default_rng(4).normal(0.0, 0.01, (len(rows), columns))
        vertices = numpy.stack([ring * numpy.cos(angles), ring * numpy.sin(angles),
                                numpy.repeat(rows[:, None], columns, axis=1)], axis=-1).reshape(-1, 3)
        a = (numpy.arange(len(rows) - 1)[:, None] * columns + numpy.arange(columns)).ravel()
        b = (numpy.arange(len(rows) - 1)[:, None] * columns + (numpy.arange(columns) + 1) % columns).ravel()
        wall = picoscan.Mesh()
        wall.vertices = vertices.astype(numpy.float32)
        wall.faces = numpy.concatenate([numpy.stack([a, b, b + columns], 1), numpy.stack([a, b + columns, a + columns], 1)]).astype(numpy.int32)
        mesh = self.doc.addObject("Mesh::Feature", "SphereWall")
        mesh.Mesh = scan_mesh.freecad_mesh(wall)
        truth = math.sqrt(radius ** 2 - height ** 2)
        radii = {}
        for band in (picoscan.DEFAULT_SECTION_BAND_MM, 0.0):
            sketch = section.cross_section(self.doc, mesh, axis="Z", offset_mm=height, name="Section", band_mm=band)
            circles = [g for g in sketch.Geometry if g.TypeId == "Part::GeomCircle"]
            self.assertEqual((len(circles), sketch.GeometryCount), (1, 1), sketch.FitReport)
            radii[band] = circles[0].Radius
            FreeCAD.Console.PrintMessage("sphere at z = %.1f mm, band %.0f mm: radius %+.1f um off; %s\n" % (
                height, band, 1000 * (radii[band] - truth), sketch.FitReport[0]))
            if band:
                self.assertIn("fitted to its own cut only", sketch.FitReport[0])
                self.assertIn("not prismatic", sketch.FitReport[0])
            self.assertAlmostEqual(radii[band], truth, delta=0.02)
            tolerance = sketch.FitTolerance.Value
        self.assertAlmostEqual(radii[picoscan.DEFAULT_SECTION_BAND_MM], radii[0.0], delta=tolerance)

    def test_parametric_rebuild_of_the_demo_part_and_its_deviation_map(self):
        """The walkthrough of docs/freecad.md: two fitted sections, two pads, and the deviation map of
        the scan against the rebuilt body, which follows when the body changes."""
        scan = self.noisy_part(0.02)
        outline = section.cross_section(self.doc, scan, axis="Z", offset_mm=12.0, name="Outline")
        boss_section = section.cross_section(self.doc, scan, axis="Z", offset_mm=28.0, name="BossSection")
        bottom, top, boss_top = self.fitted_heights(scan, 0.02)  # fitted planes, not typed heights
        body = self.doc.addObject("PartDesign::Body", "Body")
        body.addObject(outline)
        body.addObject(boss_section)
        block = body.newObject("PartDesign::Pad", "Block")
        block.Profile = outline
        self.pad_between(block, outline, bottom, bottom + top)
        boss = body.newObject("PartDesign::Pad", "Boss")
        boss.Profile = boss_section
        self.pad_between(boss, boss_section, bottom + top, bottom + boss_top)
        self.doc.recompute()
        self.assertTrue(body.Shape.isValid())
        box = body.Shape.BoundBox
        FreeCAD.Console.PrintMessage("rebuilt heights: bottom at z = %.4f mm, block %.4f mm, boss top %.4f mm "
                                     "(truth 0, 24, 32)\n" % (bottom, top, boss_top))
        self.assertAlmostEqual(box.ZMin, 0.0, delta=0.02)
        self.assertAlmostEqual(top, 24.0, delta=0.02)
        self.assertAlmostEqual(box.ZLength, 32.0, delta=0.02)
        circles = [g for g in boss_section.Geometry if g.TypeId == "Part::GeomCircle"]
        self.assertEqual(len(circles), 1)
        boss_centre = boss_section.Placement.multVec(circles[0].Center)
        hole = [g for g in outline.Geometry if g.TypeId == "Part::GeomCircle"][0]
        FreeCAD.Console.PrintMessage(
            "rebuilt body: %.4f x %.4f mm, hole diameter %.4f mm, boss diameter %.4f mm at (%.4f, %.4f)\n" % (
                box.XLength, box.YLength, 2 * hole.Radius, 2 * circles[0].Radius, boss_centre.x, boss_centre.y))
        self.assertAlmostEqual(box.XLength, 50.0, delta=0.02)
        self.assertAlmostEqual(box.YLength, 36.0, delta=0.02)
        self.assertAlmostEqual(2 * hole.Radius, 10.0, delta=0.02)
        self.assertAlmostEqual(2 * circles[0].Radius, 14.0, delta=0.02)
        self.assertAlmostEqual(boss_centre.x, 12.0, delta=0.02)
        self.assertAlmostEqual(boss_centre.y, -2.0, delta=0.02)
        seen = self.doc.addObject("Points::Feature", "ScanPoints")
        seen.Points = Points.Points([tuple(p) for p in self.seen_points(scan)[0]])
        # Misplaced by 2 degrees and 1.4 mm, as a scan in its own frame would be: best fit puts it back.
        seen.Placement = FreeCAD.Placement(FreeCAD.Vector(1.0, -0.8, 0.5), FreeCAD.Rotation(FreeCAD.Vector(0.2, 0.3, 1), 2.0))
        fit = alignment.best_fit(seen, body)
        left = seen.Placement
        FreeCAD.Console.PrintMessage("best fit: %d steps, rms %.4f mm; left %.5f deg, %.5f mm\n" % (
            fit.iterations, fit.rms_mm, math.degrees(left.Rotation.Angle), left.Base.Length))
        self.assertLess(math.degrees(left.Rotation.Angle), 0.01)
        self.assertLess(left.Base.Length, 0.01)
        result = deviation_map.create(self.doc, seen, body, tolerance_mm=0.05)
        FreeCAD.Console.PrintMessage("scan against the rebuilt body: %s\n" % result.Summary)
        self.assertLess(result.MeanAbsDeviation.Value, 0.02)  # the 20 um vertex noise, nothing more
        self.assertGreater(result.WithinTolerance, 95)
        within = result.WithinTolerance
        # Parametric: a boss 1 mm too tall leaves the scan's boss top 1 mm inside the model.
        self.pad_between(boss, boss_section, bottom + top, bottom + boss_top + 1)
        self.doc.recompute()
        self.assertTrue(boss.isValid() and result.isValid())
        FreeCAD.Console.PrintMessage("boss 1 mm taller: %s\n" % result.Summary)
        self.assertAlmostEqual(result.MaxDeviation.Value, 1.0, delta=0.1)
        self.assertLess(result.MeanDeviation.Value, -0.01)  # the boss top, about 2 % of the points, 1 mm inside
        self.assertLessEqual(result.WithinTolerance, within - 2)

    def test_rebuild_from_sections_refitted_with_parallel_cuts(self):
        """The issue's targets for the rebuilt demo part: the outline and the boss refitted with
        parallel cuts over their prismatic heights (Band), every dimension of the sketches within
        20 um, each line's direction within 0.05 degrees, and the deviation of the scan from the
        rebuilt body next to its deviation from the true part (the noise floor). The heights come from
        planes fitted to the scan's bottom, block top and boss top (as in the walkthrough)."""
        sigma = 0.02
        scan = self.noisy_part(sigma)
        bottom, top, boss_top = self.fitted_heights(scan, sigma)
        started = time.monotonic()
        outline = section.cross_section(self.doc, scan, axis="Z", offset_mm=12.0, name="Outline", band_mm=10.0)
        boss_section = section.cross_section(self.doc, scan, axis="Z", offset_mm=28.0, name="BossSection", band_mm=3.0)
        FreeCAD.Console.PrintMessage("two fitted sections with 16 parallel cuts each: %.1f s\n" % (time.monotonic() - started))
        self.assertEqual(outline.FitBand.Value, 10.0)
        lines = [g for g in outline.Geometry if g.TypeId == "Part::GeomLineSegment"]
        circles = [g for g in outline.Geometry if g.TypeId == "Part::GeomCircle"]
        self.assertEqual((len(lines), len(circles)), (5, 1), outline.FitReport)
        worst_angle = 0.0
        for line in lines:
            error = self.direction_error(line)
            FreeCAD.Console.PrintMessage("  outline line of %.3f mm: direction error %.4f deg\n" % (line.length(), error))
            worst_angle = max(worst_angle, error)
        body = self.doc.addObject("PartDesign::Body", "Body")
        body.addObject(outline)
        body.addObject(boss_section)
        block = body.newObject("PartDesign::Pad", "Block")
        block.Profile = outline
        self.pad_between(block, outline, bottom, bottom + top)
        boss = body.newObject("PartDesign::Pad", "Boss")
        boss.Profile = boss_section
        self.pad_between(boss, boss_section, bottom + top, bottom + boss_top)
        self.doc.recompute()
        self.assertTrue(body.Shape.isValid())
        box = body.Shape.BoundBox
        hole = circles[0]
        hole_centre = outline.Placement.multVec(hole.Center)
        boss_circle = [g for g in boss_section.Geometry if g.TypeId == "Part::GeomCircle"][0]
        boss_centre = boss_section.Placement.multVec(boss_circle.Center)
        ends = [outline.Placement.multVec(p) for line in lines for p in (line.StartPoint, line.EndPoint)]
        chamfer_x = box.XMax - max(p.x for p in ends if abs(p.y - box.YMax) < 1e-4)  # the chamfer's leg along x
        chamfer_y = box.YMax - max(p.y for p in ends if abs(p.x - box.XMax) < 1e-4)  # and along y
        measured = [("length", box.XLength, 50.0), ("width", box.YLength, 36.0), ("hole diameter", 2 * hole.Radius, 10.0),
                    ("hole x", hole_centre.x, -11.0), ("hole y", hole_centre.y, 0.0),
                    ("boss diameter", 2 * boss_circle.Radius, 14.0), ("boss x", boss_centre.x, 12.0),
                    ("boss y", boss_centre.y, -2.0), ("chamfer along x", chamfer_x, 8.0), ("chamfer along y", chamfer_y, 8.0),
                    ("bottom z", box.ZMin, 0.0), ("block height", top, 24.0), ("boss height", boss_top - top, 8.0),
                    ("overall height", box.ZLength, 32.0)]
        for name, value, true in measured:
            FreeCAD.Console.PrintMessage("  rebuilt %s: %.4f mm (truth %.1f, error %+.1f um)\n" % (
                name, value, true, 1000 * (value - true)))
        # The deviation of the scan's visible vertices from the rebuilt body, and from the true part:
        # the vertex noise alone gives the second (mean |d| = 0.8 sigma).
        seen = self.doc.addObject("Points::Feature", "ScanPoints")
        seen.Points = Points.Points([tuple(p) for p in self.seen_points(scan)[0]])
        true_part = self.doc.addObject("Mesh::Feature", "TruePart")
        true_part.Mesh = scan_mesh.freecad_mesh(picoscan.mechanical_part())
        against_body = deviation_map.create(self.doc, seen, body, tolerance_mm=0.05)
        against_truth = deviation_map.create(self.doc, seen, true_part, tolerance_mm=0.05)
        FreeCAD.Console.PrintMessage("scan against the rebuilt body: %s\nscan against the true part: %s\n" % (
            against_body.Summary, against_truth.Summary))
        # Asserted: the issue's 20 um and 0.05 degrees, and the rebuilt body adding at most 1 um of
        # mean |d| to the noise floor. (The 15 um target of mean |d| is below this scan's floor of 16 um.)
        for name, value, true in measured:
            self.assertAlmostEqual(value, true, delta=0.02, msg=name)
        self.assertLess(worst_angle, 0.05)
        self.assertLess(against_body.MeanAbsDeviation.Value, against_truth.MeanAbsDeviation.Value + 0.001)
        self.assertAlmostEqual(against_truth.MeanAbsDeviation.Value, 0.8 * sigma, delta=0.15 * sigma)
        # The issue's condition: the same body against a simulated scan (sigma = 1 DN), best fitted
        # onto it from the scan's true placement, and those points against the true part.
        started = time.monotonic()
        points, source = simulated_demo_scan()
        simulated = self.doc.addObject("Points::Feature", "SimulatedScan")
        simulated.Points = Points.Points([tuple(p) for p in points])
        fit = alignment.best_fit(simulated, body)
        moved = simulated.Placement
        simulated_body = deviation_map.create(self.doc, simulated, body, tolerance_mm=0.05)
        body_summary, body_mean_abs = simulated_body.Summary, simulated_body.MeanAbsDeviation.Value
        self.doc.removeObject(simulated_body.Name)  # the next map puts the scan back where it was
        simulated.Placement = FreeCAD.Placement()
        simulated_truth = deviation_map.create(self.doc, simulated, true_part, tolerance_mm=0.05)
        FreeCAD.Console.PrintMessage(
            "simulated scan, %s, %d points (%.1f s): best fit %d steps, moved %.5f deg, %.5f mm\n"
            "  against the rebuilt body: %s\n  against the true part: %s\n" % (
                source, len(points), time.monotonic() - started, fit.iterations, math.degrees(moved.Rotation.Angle),
                moved.Base.Length, body_summary, simulated_truth.Summary))
        self.assertLessEqual(body_mean_abs, 0.015)  # the issue's target
        self.assertLess(body_mean_abs, simulated_truth.MeanAbsDeviation.Value + 0.001)


def simulated_demo_scan(views=(0, 4, 8), stride=4):
    """Every `stride`-th point of the demo part's `views` (two sides and the top) as the core's
    turntable session scans it (simulate_turntable_scan: 16 phase shifts, camera noise sigma = 1 DN,
    cleaned views), each view moved into the part's frame by its true pose. The C++ suites cache the
    same views (same recipe and noise seeds) under PICOSCAN_TEST_CACHE_DIR/turntable-v3-exact: they
    are read when present; otherwise the first view alone is simulated here. (Three views and a
    quarter of their points keep the test within its time.) Returns (N x 3 points, what they are)."""
    plan = picoscan.TurntablePlan()
    poses = picoscan.turntable_part_poses(plan)
    cache = os.path.join(os.environ.get("PICOSCAN_TEST_CACHE_DIR", ""), "turntable-v3-exact")
    files = [os.path.join(cache, "view_%d.ply" % i) for i in views]
    found = []
    if os.environ.get("PICOSCAN_TEST_CACHE_DIR") and all(os.path.isfile(f) for f in files):
        found = [(picoscan.read_view_ply(f), poses[i]) for f, i in zip(files, views)]
        source = "views %s cached (%s), every %dth point" % (", ".join(map(str, views)), cache, stride)
    else:
        options = picoscan.TurntableScanOptions()
        plan.turntable_views, plan.top_view = 1, False  # the first view's pose and noise seed
        options.plan = plan
        picoscan.simulate_turntable_scan(picoscan.mechanical_part(), picoscan.seed_rig_calibration(), options,
                                         lambda simulated: found.append((simulated.view, simulated.part_to_camera)))
        source = "view 0 simulated (no cache at %s), every %dth point" % (cache, stride)
    parts = []
    for view, part_to_camera in found:
        points = numpy.asarray(picoscan.to_point_cloud(view).points, dtype=numpy.float64)[::stride]
        to_part = numpy.linalg.inv(numpy.asarray(part_to_camera))
        parts.append(points @ to_part[:3, :3].T + to_part[:3, 3])
    return numpy.concatenate(parts), source


def sampled_demo_part(count, sigma_mm, seed=3):
    """Points spread evenly over the demo part's true surface with their outward normals and
    Gaussian noise along them: what a scan of every side would give, in the part's frame."""
    part = picoscan.mechanical_part()
    triangles = numpy.array(part.vertices, dtype=numpy.float64)[numpy.array(part.faces)]
    normals = numpy.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    areas = numpy.linalg.norm(normals, axis=1)
    keep = areas > 1e-9
    triangles, normals, areas = triangles[keep], normals[keep] / areas[keep, None], areas[keep]
    random = numpy.random.default_rng(seed)
    chosen = random.choice(len(areas), count, p=areas / areas.sum())
    a, b = random.random(count), random.random(count)
    flip = a + b > 1
    a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
    t = triangles[chosen]
    points = t[:, 0] + a[:, None] * (t[:, 1] - t[:, 0]) + b[:, None] * (t[:, 2] - t[:, 0])
    points += normals[chosen] * random.normal(0.0, sigma_mm, count)[:, None]
    return points, normals[chosen]


class PicoScanDatumTest(unittest.TestCase):
    """3-2-1 datum alignment of a scan of the demo part, seen turned 30 degrees and 400 mm away as a
    camera would see it: its bottom, back and left faces fitted as planes put it into the part's own
    frame (corner (-25, -18, 0) at the origin), and the model onto the scan."""

    # Where the scanner saw the part: its frame -> scan coordinates.
    POSE = FreeCAD.Placement(FreeCAD.Vector(20.0, -35.0, 400.0), FreeCAD.Rotation(FreeCAD.Vector(1, -2, 0.5), 30.0))
    CORNER = FreeCAD.Vector(-25, -18, 0)

    @classmethod
    def setUpClass(cls):
        cls.doc = FreeCAD.newDocument("PicoScanDatumTest")
        points, normals = sampled_demo_part(60000, 0.02)
        matrix = numpy.array(cls.POSE.toMatrix().A).reshape(4, 4)
        cloud = picoscan.PointCloud()
        cloud.points = (points @ matrix[:3, :3].T + matrix[:3, 3]).astype(numpy.float32)
        cloud.normals = (normals @ matrix[:3, :3].T).astype(numpy.float32)
        cls.cloud = cloud
        cls.group, created = primitives.fit_primitives(cls.doc, cloud, primitives.detection_options(epsilon_mm=0.1, min_points=300))
        # The fitted planes whose outward normal is the part's -z, -y, -x, +z (the top, for a parallel pair).
        cls.planes = {}
        for obj, shape in created:
            if obj.TypeId != "Part::Plane":
                continue
            normal = cls.POSE.Rotation.inverted().multVec(obj.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1)))
            for name, axis in (("bottom", (0, 0, -1)), ("back", (0, -1, 0)), ("left", (-1, 0, 0)), ("top", (0, 0, 1))):
                if normal.dot(FreeCAD.Vector(*axis)) > 0.99 and name not in cls.planes:
                    cls.planes[name] = obj
        cls.cylinders = [obj for obj, _ in created if obj.TypeId == "Part::Cylinder"]

    @classmethod
    def tearDownClass(cls):
        FreeCAD.closeDocument(cls.doc.Name)

    def scan_object(self):
        scan = self.doc.addObject("Points::Feature", "DemoScan")
        scan.Points = Points.Points([tuple(p) for p in self.cloud.points.tolist()])
        return scan

    def restore(self, objects, placements):
        for obj, placement in zip(objects, placements):
            obj.Placement = placement

    def test_scan_into_the_part_frame(self):
        self.assertEqual(sorted(self.planes), ["back", "bottom", "left", "top"], [o.Label for o in self.group.Group])
        scan = self.scan_object()
        carried = list(self.group.Group)
        before = [o.Placement for o in carried]
        features = [(self.planes["bottom"], ""), (self.planes["back"], ""), (self.planes["left"], "")]
        frame, _, move = datum.align(scan, features, carried=carried)
        FreeCAD.Console.PrintMessage("datum frame of the scan: %s\n" % datum.frame_report(frame))
        # The move must be the true one: scan -> part frame -> shifted so the corner is the origin.
        truth = FreeCAD.Placement(-self.CORNER, FreeCAD.Rotation()).multiply(self.POSE.inverse())
        error = truth.inverse().multiply(move)
        centre = move.multVec(self.POSE.multVec(FreeCAD.Vector(0, 0, 12))) - truth.multVec(self.POSE.multVec(FreeCAD.Vector(0, 0, 12)))
        FreeCAD.Console.PrintMessage("datum alignment left %.5f deg, %.5f mm at the part's middle\n" % (
            math.degrees(error.Rotation.Angle), centre.Length))
        self.assertLess(math.degrees(error.Rotation.Angle), 0.02)
        self.assertLess(centre.Length, 0.01)
        self.assertAlmostEqual(frame.primary_secondary_deg, 90.0, delta=0.02)
        box = scan.Points.BoundBox  # the part now spans [0, 50] x [0, 36] x [0, 32]
        for low, high, size in ((box.XMin, box.XMax, 50), (box.YMin, box.YMax, 36), (box.ZMin, box.ZMax, 32)):
            self.assertAlmostEqual(low, 0.0, delta=0.15)
            self.assertAlmostEqual(high, size, delta=0.15)
        # The fitted hole (10 mm, at (-11, 0) in the part's drawing) followed: vertical, at (14, 18).
        holes = [c for c in self.cylinders if abs(c.Radius.Value - 5.0) < 0.05]
        self.assertEqual(len(holes), 1, [c.Radius.Value for c in self.cylinders])
        axis = holes[0].Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        self.assertGreater(abs(axis.z), math.cos(math.radians(0.05)))
        self.assertAlmostEqual(holes[0].Placement.Base.x, 14.0, delta=0.02)
        self.assertAlmostEqual(holes[0].Placement.Base.y, 18.0, delta=0.02)
        self.restore(carried, before)
        self.doc.removeObject(scan.Name)

    def test_model_onto_the_scan_and_parallel_datums_refused(self):
        scan = self.scan_object()
        model = self.doc.addObject("Part::Box", "Model")
        model.Length, model.Width, model.Height = 50, 36, 24
        model.Placement.Base = self.CORNER
        self.doc.recompute()
        faces = {}
        for index, face in enumerate(model.Shape.Faces):
            normal = face.normalAt(0, 0)
            for name, axis in (("bottom", (0, 0, -1)), ("back", (0, -1, 0)), ("left", (-1, 0, 0))):
                if normal.dot(FreeCAD.Vector(*axis)) > 0.999:
                    faces[name] = (model, "Face%d" % (index + 1))
        scan_features = [(self.planes[n], "") for n in ("bottom", "back", "left")]
        model_features = [faces[n] for n in ("bottom", "back", "left")]
        datum.align(model, model_features, scan_features)
        error = self.POSE.inverse().multiply(model.Placement)
        FreeCAD.Console.PrintMessage("model onto scan: left %.5f deg, %.5f mm\n" % (
            math.degrees(error.Rotation.Angle), (error.Base - self.CORNER).Length))
        self.assertLess(math.degrees(error.Rotation.Angle), 0.02)
        middle = self.POSE.inverse().multVec(model.Placement.multVec(FreeCAD.Vector(25, 18, 12)))  # the box's middle
        self.assertLess((middle - FreeCAD.Vector(0, 0, 12)).Length, 0.01)
        # The origin from a point: the model's corner vertex nearest the part's (-25, -18, 0).
        corner = min(range(len(model.Shape.Vertexes)), key=lambda i: (model.Shape.Vertexes[i].Point -
                                                                       model.Placement.multVec(FreeCAD.Vector())).Length)
        by_point = datum.datum_frame(model_features[:2] + [(model, "Vertex%d" % (corner + 1))])
        by_plane = datum.datum_frame(model_features)
        self.assertLess(numpy.linalg.norm(numpy.asarray(by_point.origin) - numpy.asarray(by_plane.origin)), 1e-6)
        # Parallel datums (bottom and top) fix no line: refused with the reason, nothing moves.
        placements = (scan.Placement, model.Placement)
        with self.assertRaisesRegex(picoscan.Error, r"secondary plane is 0\.\d+ degrees from parallel to the primary"):
            datum.align(scan, [(self.planes["bottom"], ""), (self.planes["top"], ""), (self.planes["left"], "")])
        with self.assertRaisesRegex(picoscan.Error, "is not planar"):
            datum.align(scan, [(self.cylinders[0], "Face1"), (self.planes["back"], ""), (self.planes["left"], "")])
        with self.assertRaisesRegex(picoscan.Error, "has 6 faces; pick one face"):
            datum.align(scan, [(model, ""), (self.planes["back"], ""), (self.planes["left"], "")])
        self.assertEqual((scan.Placement, model.Placement), placements)
        self.doc.removeObject(scan.Name)
        self.doc.removeObject(model.Name)

    def test_measurements_between_fitted_features(self):
        """Hole to boss, plane to plane and hole axis to base on the fitted demo part, against its
        drawing; the table follows the features and is written as CSV."""
        features = [o for o in self.group.Group if getattr(o, "FitKind", "") in ("Plane", "Cylinder")]

        def in_part(obj):  # a feature's middle and direction in the part's drawing frame
            inverse = self.POSE.inverse()
            middle = obj.Shape.CenterOfMass if obj.TypeId == "Part::Plane" else obj.Placement.Base
            return inverse.multVec(middle), inverse.Rotation.multVec(obj.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1)))

        def find(kind, test):
            found = [o for o in features if o.FitKind == kind and test(*in_part(o))]
            self.assertEqual(len(found), 1, [(o.Label, in_part(o)) for o in features if o.FitKind == kind])
            return found[0]

        hole = find("Cylinder", lambda m, d: abs(m.x + 11) < 0.5 and abs(m.y) < 0.5)
        boss = find("Cylinder", lambda m, d: abs(m.x - 12) < 0.5 and abs(m.y + 2) < 0.5)
        bottom = find("Plane", lambda m, d: abs(m.z) < 0.2 and abs(d.z) > 0.99)
        block_top = find("Plane", lambda m, d: abs(m.z - 24) < 0.2 and abs(d.z) > 0.99)
        left = find("Plane", lambda m, d: abs(m.x + 25) < 0.2 and abs(d.x) > 0.99)
        right = find("Plane", lambda m, d: abs(m.x - 25) < 0.2 and abs(d.x) > 0.99)
        back = find("Plane", lambda m, d: abs(m.y + 18) < 0.2 and abs(d.y) > 0.99)
        csv_path = os.path.join(tempfile.gettempdir(), "picoscan_measurements_test.csv")
        table = measurements.create(self.doc, features, csv_file=csv_path)
        self.assertTrue(table.isValid(), table.getStatusString())
        import csv as csv_module

        with open(csv_path) as stream:
            rows = list(csv_module.reader(stream))
        os.remove(csv_path)
        self.assertEqual(rows[0], ["Feature A", "Feature B", "Measure", "Value", "Unit", "Uncertainty"])
        self.assertEqual(len(rows) - 1, len(table.Table))
        values = {}
        for a, b, what, value, unit, sigma in rows[1:]:
            values[(a, b, what)] = values[(b, a, what)] = (float(value), float(sigma))
        expectations = [
            ((hole.Label, "", "diameter"), 10.0, 0.02),
            ((boss.Label, "", "diameter"), 14.0, 0.02),
            ((hole.Label, boss.Label, "axis distance"), math.hypot(23, 2), 0.02),
            ((hole.Label, boss.Label, "axis angle"), 0.0, 0.1),
            ((bottom.Label, block_top.Label, "distance"), 24.0, 0.02),
            ((left.Label, right.Label, "distance"), 50.0, 0.02),
            ((bottom.Label, left.Label, "angle"), 90.0, 0.02),
            ((back.Label, left.Label, "angle"), 90.0, 0.02),
            ((hole.Label, bottom.Label, "axis to plane angle"), 90.0, 0.1),
        ]
        for key, truth, tolerance in expectations:
            self.assertIn(key, values, sorted(k for k in values if key[0] in k))
            value, sigma = values[key]
            FreeCAD.Console.PrintMessage("%s: %.4f (truth %.4f, error %+.4f, uncertainty %.4f)\n" % (
                " / ".join(k for k in key if k), value, truth, value - truth, sigma))
            self.assertAlmostEqual(value, truth, delta=tolerance)
            self.assertGreater(sigma, 0.0)
            self.assertLess(sigma, tolerance)
        # Parametric: the boss moved 1 mm along x moves the hole-to-boss distance after recompute.
        before = boss.Placement
        boss.Placement = FreeCAD.Placement(self.POSE.Rotation.multVec(FreeCAD.Vector(1, 0, 0)), FreeCAD.Rotation()).multiply(boss.Placement)
        self.doc.recompute()
        moved = [row for row in table.Table if row.startswith("%s - %s: axis distance" % (hole.Label, boss.Label))]
        self.assertEqual(len(moved), 1, table.Table)
        self.assertAlmostEqual(float(moved[0].split("axis distance ")[1].split()[0]), math.hypot(24, 2), delta=0.02)
        boss.Placement = before
        # A hole fitted before FitRms had a unit (a plain FitRmsMm) keeps its uncertainty.
        diameter = [row for row in table.Table if row.startswith("%s: diameter" % hole.Label)]
        rms = hole.FitRms.Value
        hole.removeProperty("FitRms")
        hole.addProperty("App::PropertyFloat", "FitRmsMm", "Fit", "")
        hole.FitRmsMm = rms
        table.touch()
        self.doc.recompute()
        self.assertEqual([row for row in table.Table if row.startswith("%s: diameter" % hole.Label)], diameter)
        hole.removeProperty("FitRmsMm")  # as it was, for the other tests of the fitted part
        hole.addProperty("App::PropertyLength", "FitRms", "Fit", "")
        hole.FitRms = rms
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "needs two or more fitted features"):
            measurements.create(self.doc, features[:1])
        self.assertEqual([o.Name for o in self.doc.Objects], names)
        self.doc.removeObject(table.Name)


def outline_block_mesh(sigma_mm, spacing_mm=0.5, seed=5):
    """A closed mesh of the demo part's block, 24 mm high: its outline (50 x 36 mm, the 8 mm
    chamfer) with the (-25, -18) vertical edge rounded to a 5 mm radius, facets about spacing_mm
    across, Gaussian noise of sigma_mm on every vertex: a stand-in for a closed scan mesh. (The
    demo part's own mesh is not watertight, and a Poisson mesh of it has 0.2 mm lumps.) Returns a
    picoscan.Mesh."""
    corners = [(25, -18), (25, 10), (17, 18), (-25, 18), (-25, -13)]
    outline = []  # counter-clockwise seen from +z, about spacing_mm apart
    for a, b in zip(corners, corners[1:]):
        steps = max(1, int(round(math.dist(a, b) / spacing_mm)))
        outline += [(a[0] + (b[0] - a[0]) * i / steps, a[1] + (b[1] - a[1]) * i / steps) for i in range(steps)]
    steps = int(round(5 * math.pi / 2 / spacing_mm))
    outline += [(-20 + 5 * math.cos(math.pi + math.pi / 2 * i / steps), -13 + 5 * math.sin(math.pi + math.pi / 2 * i / steps))
                for i in range(steps)]
    steps = int(round(45 / spacing_mm))
    outline += [(-20 + 45 * i / steps, -18) for i in range(steps)]
    outline = numpy.array(outline)
    count = len(outline)
    # Arc-length parameter of the outline, for rings of fewer points nearer the centre.
    lengths = numpy.linalg.norm(numpy.roll(outline, -1, axis=0) - outline, axis=1)
    along = numpy.concatenate([[0], numpy.cumsum(lengths)[:-1]]) / lengths.sum()
    centre = numpy.array([0.0, 0.0])
    rings = max(2, int(round(20 / spacing_mm)))
    height_steps = max(1, int(round(24 / spacing_mm)))
    vertices, faces = [], []

    def add(point):
        vertices.append(point)
        return len(vertices) - 1

    def at(t, scale):  # the outline point at parameter t, scaled towards the centre
        i = numpy.searchsorted(along, t, side="right") - 1
        f = (t - along[i]) / (lengths[i] / lengths.sum())
        p = outline[i] + f * (outline[(i + 1) % count] - outline[i])
        return centre + scale * (p - centre)

    # Sides: the outline lifted in height_steps rows.
    side = [[add((x, y, 24.0 * k / height_steps)) for x, y in outline] for k in range(height_steps + 1)]
    for k in range(height_steps):
        for i in range(count):
            j = (i + 1) % count
            faces += [(side[k][i], side[k][j], side[k + 1][j]), (side[k][i], side[k + 1][j], side[k + 1][i])]
    # Caps: rings scaled towards the centre, their points spread by arc length, zipped together.
    for z, top in ((0.0, False), (24.0, True)):
        ring_rows = [list(zip(along, side[-1 if top else 0]))]
        for r in range(rings - 1, 0, -1):
            n = max(6, int(round(count * r / rings)))
            ts = numpy.arange(n) / n
            ring_rows.append([(t, add((*at(t, r / rings), z))) for t in ts])
        middle = add((centre[0], centre[1], z))
        for outer, inner in zip(ring_rows, ring_rows[1:]):
            i = j = 0
            while i < len(outer) or j < len(inner):
                a, b = outer[i % len(outer)][1], inner[j % len(inner)][1]
                t_outer = outer[i + 1][0] if i + 1 < len(outer) else 1.0
                t_inner = inner[j + 1][0] if j + 1 < len(inner) else 1.0
                if (t_outer <= t_inner and i < len(outer)) or j >= len(inner):
                    tri = (a, outer[(i + 1) % len(outer)][1], b)
                    i += 1
                else:
                    tri = (a, inner[(j + 1) % len(inner)][1], b)
                    j += 1
                faces.append(tri if top else tri[::-1])
        inner = ring_rows[-1]
        for k in range(len(inner)):
            tri = (inner[k][1], inner[(k + 1) % len(inner)][1], middle)
            faces.append(tri if top else tri[::-1])
    positions = numpy.array(vertices) + numpy.random.default_rng(seed).normal(0.0, sigma_mm, (len(vertices), 3))
    mesh = picoscan.Mesh()
    mesh.vertices = positions.astype(numpy.float32)
    mesh.faces = numpy.array(faces, dtype=numpy.int32)
    return mesh


class PicoScanMeshHandOverTest(unittest.TestCase):
    """scan_mesh.core_mesh, the way Cross-section, Make solid and Deviation map hand a FreeCAD mesh to
    the core."""

    def test_core_mesh_is_the_placed_mesh_and_hears_cancel_while_reading(self):
        mesh = Mesh.createSphere(10.0, 200)  # 39 802 points and 79 600 facets: the reader reports once inside
        mesh.Placement = FreeCAD.Placement(FreeCAD.Vector(100, -20, 5), FreeCAD.Rotation(FreeCAD.Vector(1, 2, 3), 40))
        points, facets = mesh.Topology  # with the placement applied
        core = scan_mesh.core_mesh(mesh)
        numpy.testing.assert_allclose(numpy.asarray(core.vertices), numpy.array([tuple(p) for p in points]), atol=1e-5)
        numpy.testing.assert_array_equal(numpy.asarray(core.faces), numpy.array(facets))

        reports = []

        def cancel_at_once(fraction, stage):
            reports.append((fraction, stage))
            return False

        with self.assertRaises(picoscan.Error) as raised:
            scan_mesh.core_mesh(mesh, cancel_at_once)
        self.assertTrue(str(raised.exception).startswith("cancelled"), str(raised.exception))
        self.assertEqual(reports, [(65536 / (39802 + 79600), "reading the mesh")])

    def test_freecad_mesh_keeps_the_core_triangles_corner_for_corner(self):
        """The other way (core -> FreeCAD, through a PLY): the same points and triangles, each from the
        same corner. (FreeCAD's STL reader started every triangle at its third corner, and that alone
        reversed the sections' loops.)"""
        part = picoscan.mechanical_part()
        points, facets = scan_mesh.freecad_mesh(part).Topology
        numpy.testing.assert_array_equal(numpy.array([tuple(p) for p in points], dtype=numpy.float32),
                                         numpy.asarray(part.vertices))
        numpy.testing.assert_array_equal(numpy.array(facets), numpy.asarray(part.faces))

    def test_big_properties_through_their_content(self):
        """property_content's bytes give FreeCAD's properties exactly the values, and a moved Points
        object's points read back in document coordinates."""
        from picoscan_wb.property_content import colour_list_content, float_list_content, points_content, points_from_content

        doc = FreeCAD.newDocument("PicoScanContent")
        try:
            obj = doc.addObject("Points::FeaturePython", "Map")
            obj.addProperty("App::PropertyColorList", "Color", "Test", "")
            obj.addProperty("App::PropertyFloatList", "Distances", "Test", "")
            rng = numpy.random.default_rng(2)
            points = rng.normal(0.0, 50.0, (1000, 3)).astype(numpy.float32)
            colours = rng.integers(0, 256, (1000, 3)).astype(numpy.uint8)
            distances = rng.normal(0.0, 0.1, 1000)
            obj.restorePropertyContent("Points", points_content(points))
            obj.restorePropertyContent("Color", colour_list_content(colours))
            obj.restorePropertyContent("Distances", float_list_content(distances))
            numpy.testing.assert_array_equal(numpy.array([tuple(p) for p in obj.Points.Points], dtype=numpy.float32), points)
            numpy.testing.assert_allclose(numpy.array([c[:3] for c in obj.Color]), colours / 255.0, atol=1e-6)
            self.assertEqual([c[3] for c in obj.Color], [0.0] * 1000)  # opaque
            numpy.testing.assert_array_equal(numpy.array(obj.Distances), distances)
            moved = doc.addObject("Points::Feature", "Moved")
            moved.Points = Points.Points([tuple(map(float, p)) for p in points])
            moved.Placement = FreeCAD.Placement(FreeCAD.Vector(10, -20, 30), FreeCAD.Rotation(FreeCAD.Vector(1, 2, 3), 40))
            doc.recompute()
            numpy.testing.assert_allclose(points_from_content(moved.dumpPropertyContent("Points", Compression=0)),
                                          numpy.array([tuple(p) for p in moved.Points.Points]), atol=1e-3)  # float32
        finally:
            FreeCAD.closeDocument(doc.Name)

    def test_reference_tessellated_in_its_own_process_and_cancelled_there(self):
        """The reference shape's triangles from tessellate_shape.py's process are those FreeCAD makes
        in its own, at the placed shape; Cancel ends the process. A shape of planes only is
        tessellated in FreeCAD's process."""
        from picoscan_wb.operations import deviation

        doc = FreeCAD.newDocument("PicoScanTessellate")
        try:
            model = doc.addObject("Part::Cylinder", "Model")
            model.Radius, model.Height = 12.5, 80.0
            model.Placement = FreeCAD.Placement(FreeCAD.Vector(0, -40, 400), FreeCAD.Rotation(FreeCAD.Vector(1, 0, 0), 90))
            doc.recompute()
            reference = deviation.reference_reader(model, 0.01)(None)
            vertices, facets = model.Shape.copy().tessellate(0.01)
            self.assertEqual(numpy.asarray(reference.faces).shape, (len(facets), 3))
            ordered = lambda points: points[numpy.lexsort(numpy.round(points, 3).T)]  # noqa: E731 (the faces come in another order)
            numpy.testing.assert_allclose(ordered(numpy.asarray(reference.vertices, dtype=float)),
                                          ordered(numpy.array([tuple(v) for v in vertices])), atol=1e-4)
            reports = []

            def cancel(fraction, stage):
                reports.append(stage)
                return len(reports) < 3
            with self.assertRaisesRegex(picoscan.Error, "^cancelled: tessellating the reference"):
                deviation.reference_reader(model, 0.01)(cancel)
            # Planes only: tessellated at once on the calling thread (12 triangles, no process to cancel).
            box = doc.addObject("Part::Box", "Box")
            doc.recompute()
            self.assertEqual(numpy.asarray(deviation.reference_reader(box, 0.01)(lambda fraction, stage: False).faces).shape, (12, 3))
        finally:
            FreeCAD.closeDocument(doc.Name)


class PicoScanBigSolidTest(unittest.TestCase):
    """Make solid merges coplanar facets: a noisy closed mesh of the demo part's block becomes a valid
    solid whose flat faces are one B-rep face each, with the mesh's volume."""

    # The block's planar faces: outward normal -> true area (mm2).
    FLAT_FACES = {
        (0, 0, -1): 50 * 36 - 32 - 25 * (1 - math.pi / 4), (0, 0, 1): 50 * 36 - 32 - 25 * (1 - math.pi / 4),
        (0, -1, 0): 45 * 24, (0, 1, 0): 42 * 24, (-1, 0, 0): 31 * 24, (1, 0, 0): 28 * 24,
        (math.sqrt(0.5), math.sqrt(0.5), 0): 8 * math.sqrt(2) * 24,
    }

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanBigSolidTest")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)

    def test_noisy_block_mesh_becomes_a_few_planar_faces(self):
        for sigma in (0.0, 0.02, 0.05):
            obj = self.doc.addObject("Mesh::Feature", "BlockMesh")
            obj.Mesh = scan_mesh.freecad_mesh(outline_block_mesh(sigma, spacing_mm=1.0))
            facets = obj.Mesh.CountFacets
            shape, model, note = solid.solid_with_model(obj.Mesh, obj.Label, check_valid=True)
            self.assertEqual(note, "")  # the planar faces kept the volume
            FreeCAD.Console.PrintMessage("block mesh, noise %.3f mm: %s; solid volume %.3f mm3, mesh %.3f mm3\n" % (
                sigma, model.summary(), shape.Volume, obj.Mesh.Volume))
            self.assertTrue(shape.isValid())
            self.assertEqual(shape.ShapeType, "Solid")
            self.assertAlmostEqual(shape.Volume, obj.Mesh.Volume, delta=1e-3 * obj.Mesh.Volume)
            self.assertLess(len(shape.Faces), facets / 20)
            for normal, area in self.FLAT_FACES.items():
                matching = [f for f in shape.Faces if f.Surface.TypeId == "Part::GeomPlane"
                            and f.normalAt(0, 0).dot(FreeCAD.Vector(*normal)) > 0.9999 and f.Area > 0.5 * area]
                self.assertEqual(len(matching), 1, (sigma, normal, [f.Area for f in matching]))
                # The faces beside the rounded edge may take in its first strips (the polygon's facets
                # there turn by 3 degrees, within the noise of the plane): up to 1.5 mm x 24 mm more.
                self.assertGreater(matching[0].Area, 0.99 * area)
                self.assertLess(matching[0].Area, area + 36)
            # The feature reports how the faces were made.
            feature = solid.make_solid(self.doc, obj)
            self.assertIn("planar regions", feature.SolidReport)
            self.doc.removeObject(feature.Name)
            self.doc.removeObject(obj.Name)

    @staticmethod
    def sliver_chamfer_block(chamfer_mm, sigma_mm, seed):
        """A 20 x 10 x 20 mm block along y, its (+x, +z) edge chamfered `chamfer_mm` wide (one facet
        across, as a sharpened edge leaves it), every vertex moved by Gaussian noise."""
        corners = [(0, 0), (20, 0), (20, 10 - chamfer_mm), (20 - chamfer_mm, 10), (0, 10)]
        ring = []
        for k, cut in enumerate((20, 10, 1, 20, 10)):
            a, b = numpy.array(corners[k]), numpy.array(corners[(k + 1) % 5])
            ring += [a + (b - a) * s / cut for s in range(cut)]
        n, rows = len(ring), 20
        vertices = [(x, 20.0 * j / rows, z) for j in range(rows + 1) for x, z in ring]
        centre = numpy.mean(ring, axis=0)
        vertices += [(centre[0], 0.0, centre[1]), (centre[0], 20.0, centre[1])]
        front, back = len(vertices) - 2, len(vertices) - 1
        at = lambda j, i: j * n + i % n
        facets = []
        for j in range(rows):
            for i in range(n):
                facets += [(at(j, i), at(j, i + 1), at(j + 1, i + 1)), (at(j, i), at(j + 1, i + 1), at(j + 1, i))]
        for i in range(n):
            facets += [(front, at(0, i + 1), at(0, i)), (back, at(rows, i), at(rows, i + 1))]
        mesh = picoscan.Mesh()
        points = numpy.array(vertices) + numpy.random.default_rng(seed).normal(0.0, sigma_mm, (len(vertices), 3))
        mesh.vertices = points.astype(numpy.float32)
        mesh.faces = numpy.array(facets, dtype=numpy.int32)
        return mesh

    def test_sliver_chamfer_merged_without_the_face_check_is_invalid_and_with_it_valid(self):
        """A chamfer narrower than the noise (0.005 mm, noise 0.01 mm): the core's unchecked merge
        (check_faces off, as before) writes a B-rep OpenCASCADE rejects; with the check, the core's
        B-rep is valid, of the mesh's volume, with as many planes merged. (This folded mesh also
        intersects itself, which Make solid refuses first; the core must not rely on that.) Then
        Make solid on a 0.02 mm chamfer, which does not intersect itself: valid, no fallback."""
        def read_back(model, folder, name):
            path = os.path.join(folder, name)
            picoscan.write_brep(model, path)
            shape = Part.Shape()
            shape.read(path)
            return shape

        unchecked = solid.face_options()
        unchecked.check_faces = False
        # Seeds where the chamfer itself breaks the unchecked merge: in seeds 2, 4 and 8 only an end's fan
        # did (a sliver from the chamfer to the end's centre, folded by the noise), which the planar merge
        # now takes into the end's plane as a region takes what it encloses.
        for seed in (1, 3):
            mesh = self.sliver_chamfer_block(0.005, 0.01, seed)
            old = picoscan.planar_face_model(mesh, unchecked)
            model = picoscan.planar_face_model(mesh, solid.face_options())
            with tempfile.TemporaryDirectory() as folder:
                old_shape, shape = read_back(old, folder, "old.brep"), read_back(model, folder, "checked.brep")
            FreeCAD.Console.PrintMessage("sliver chamfer 0.005 mm, seed %d: unchecked merge valid %s (%d face defects); "
                                         "checked valid %s: %s\n" % (seed, old_shape.isValid(),
                                                                    len(picoscan.merged_face_defects(old, unchecked)),
                                                                    shape.isValid(), model.summary()))
            self.assertFalse(old_shape.isValid())
            self.assertGreater(len(picoscan.merged_face_defects(old, unchecked)), 0)  # the check agrees
            self.assertTrue(shape.isValid())
            self.assertGreater(len(model.refused_merges), 0)
            self.assertEqual(picoscan.merged_face_defects(model, solid.face_options()), [])
            self.assertEqual(model.merged_faces, old.merged_faces)
            self.assertAlmostEqual(shape.Volume, model.mesh_volume_mm3, delta=1e-3 * model.mesh_volume_mm3)
        obj = self.doc.addObject("Mesh::Feature", "SliverBlock")
        obj.Mesh = scan_mesh.freecad_mesh(self.sliver_chamfer_block(0.02, 0.01, 1))
        shape, model, note = solid.solid_with_model(obj.Mesh, obj.Label, check_valid=True)
        FreeCAD.Console.PrintMessage("sliver chamfer 0.02 mm: %s\n" % model.summary())
        self.assertEqual(note, "")  # no fallback to the mesh's triangles
        self.assertTrue(shape.isValid())
        self.assertEqual(model.merged_faces, 4)
        self.assertAlmostEqual(shape.Volume, obj.Mesh.Volume, delta=1e-3 * obj.Mesh.Volume)

    def test_without_merging_every_facet_is_a_face(self):
        obj = self.doc.addObject("Mesh::Feature", "Sphere")
        obj.Mesh = Mesh.createSphere(10.0, 30)
        shape = solid.solid_of_mesh(obj.Mesh, "sphere", merge_planes=False)
        self.assertEqual(len(shape.Faces), obj.Mesh.CountFacets)
        self.assertTrue(shape.isValid())


BUSHING_CENTRE = (12.3, -7.1, 2.5)


def bushing_plate_mesh(sigma_mm, seed=5, oval_mm=0.0, tilt_deg=0.0):
    """A closed mesh of a 30 x 30 x 6 mm plate with a boss (radius 8 mm, 4 mm high) on it and a
    hole (radius 4 mm) through both, about the vertical axis through BUSHING_CENTRE (the part the
    core's tests/solid/test_cylinder_faces.cpp builds): 96 segments round, Gaussian noise of
    sigma_mm on every vertex. oval_mm: the hole's radius varies by +- this, twice round; tilt_deg:
    the hole is a round cylinder leaning by this (the plate's faces cut it obliquely). Returns a
    picoscan.Mesh."""
    segments, rings = 96, 4
    half, thickness, boss_radius, boss_height, hole_radius = 15.0, 6.0, 8.0, 4.0, 4.0
    cx, cy, cz = BUSHING_CENTRE
    tilt = math.radians(tilt_deg)
    positions, index_of, faces = [], {}, []

    def vertex(p):
        if p not in index_of:
            index_of[p] = len(positions)
            positions.append(p)
        return index_of[p]

    def square(a, z):
        reach = half / max(abs(math.cos(a)), abs(math.sin(a)))
        return (cx + reach * math.cos(a), cy + reach * math.sin(a), cz + z)

    def boss(a, z):
        return (cx + boss_radius * math.cos(a), cy + boss_radius * math.sin(a), cz + z)

    def hole(a, z):
        radius = hole_radius + oval_mm * math.cos(2 * a)
        return (cx + z * math.tan(tilt) + radius * math.cos(a) / math.cos(tilt), cy + radius * math.sin(a), cz + z)

    def ring(curve, z):
        return [vertex(curve(2 * math.pi * (k % segments) / segments, z)) for k in range(segments + 1)]

    def strip(a, b):  # outward when ring a runs counter-clockwise below ring b
        for k in range(segments):
            faces.extend([(a[k], a[k + 1], b[k + 1]), (a[k], b[k + 1], b[k])])

    def annulus(inner, outer, z, up):
        steps = [ring(inner, z)]
        for i in range(1, rings):
            def between(a, h, t=i / rings):
                p, q = inner(a, h), outer(a, h)
                return tuple(p[j] + (q[j] - p[j]) * t for j in range(3))
            steps.append(ring(between, z))
        steps.append(ring(outer, z))
        for i in range(rings):
            strip(steps[i + 1], steps[i]) if up else strip(steps[i], steps[i + 1])

    def wall(curve, z0, z1, outward):
        rows = int(round(z1 - z0))
        for j in range(rows):
            below, above = ring(curve, z0 + (z1 - z0) * j / rows), ring(curve, z0 + (z1 - z0) * (j + 1) / rows)
            strip(below, above) if outward else strip(above, below)

    top = thickness + boss_height
    annulus(hole, square, 0.0, False)
    wall(square, 0.0, thickness, True)
    annulus(boss, square, thickness, True)
    wall(boss, thickness, top, True)
    annulus(hole, boss, top, True)
    wall(hole, 0.0, top, False)
    mesh = picoscan.Mesh()
    points = numpy.array(positions) + numpy.random.default_rng(seed).normal(0.0, sigma_mm, (len(positions), 3))
    mesh.vertices = points.astype(numpy.float32)
    mesh.faces = numpy.array(faces, dtype=numpy.int32)
    return mesh


class PicoScanCylinderSolidTest(unittest.TestCase):
    """Make solid gives a hole and a boss as cylindrical faces bounded by circles (what a designer
    selects, dimensions and refers to), and keeps a hole that is not a true cylinder square to the
    plate as triangles, saying why."""

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanCylinderSolidTest")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)

    def solid_of(self, mesh, name):
        obj = self.doc.addObject("Mesh::Feature", name)
        obj.Mesh = scan_mesh.freecad_mesh(mesh)
        shape, model, note = solid.solid_with_model(obj.Mesh, obj.Label, check_valid=True)
        FreeCAD.Console.PrintMessage("%s: %s; solid volume %.4f mm3, mesh %.4f mm3\n" % (
            name, model.summary(), shape.Volume, obj.Mesh.Volume))
        self.assertEqual(note, "")
        self.assertEqual(shape.ShapeType, "Solid")
        self.assertTrue(shape.isValid())
        self.assertAlmostEqual(shape.Volume, obj.Mesh.Volume, delta=1e-3 * obj.Mesh.Volume)
        return obj, shape, model

    @staticmethod
    def scanned_mesh_of(shape, seed):
        """The shape meshed by FreeCAD's mesher in triangles of at most 0.8 mm (about 1 mm all over, as a
        scan's mesh has: a mesh within a deflection has planes of a few long triangles, which no plane
        fit can tell from noise), every vertex moved by 5 um of Gaussian noise."""
        import MeshPart

        points, facets = MeshPart.meshFromShape(Shape=shape, MaxLength=0.8).Topology
        scanned = picoscan.Mesh()
        scanned.vertices = numpy.array([tuple(p) for p in points], dtype=numpy.float32) + \
            numpy.random.default_rng(seed).normal(0, 0.005, (len(points), 3)).astype(numpy.float32)
        scanned.faces = numpy.array(facets, dtype=numpy.int32)
        return scanned

    @staticmethod
    def cylinders_of(shape):
        return sorted((f for f in shape.Faces if isinstance(f.Surface, Part.Cylinder)), key=lambda f: f.Surface.Radius)

    def test_hole_and_boss_become_cylinders(self):
        for sigma in (0.0, 0.01):
            obj, shape, model = self.solid_of(bushing_plate_mesh(sigma), "Bushing%d" % round(sigma * 1000))
            self.assertEqual(model.cylinder_faces, 2)
            hole, boss = self.cylinders_of(shape)
            for face, radius in ((hole, 4.0), (boss, 8.0)):
                self.assertLess(abs(face.Surface.Radius - radius), 0.02, (sigma, face.Surface.Radius))
                self.assertGreater(abs(face.Surface.Axis.z), 1 - 1e-6)  # square to the plate within 0.08 degrees
                centre = face.Surface.Center
                self.assertLess(math.hypot(centre.x - BUSHING_CENTRE[0], centre.y - BUSHING_CENTRE[1]), 0.02)
                # Bounded by two circles of its radius (and its seam): a designer's edges to dimension.
                circles = [e for e in face.Edges if isinstance(e.Curve, Part.Circle)]
                self.assertEqual(len(circles), 2)
                for edge in circles:
                    self.assertAlmostEqual(edge.Curve.Radius, face.Surface.Radius, delta=1e-9)
            # The hole's face looks into the hole; the boss's out of it.
            self.assertLess(hole.normalAt(0, 0).dot(hole.valueAt(0, 0) - hole.Surface.Center), 0)
            self.assertGreater(boss.normalAt(0, 0).dot(boss.valueAt(0, 0) - boss.Surface.Center), 0)
            # The hole's area is its circumference times the plate and boss (10 mm).
            self.assertAlmostEqual(hole.Area, 2 * math.pi * hole.Surface.Radius * 10.0, delta=0.05)
            # Usable in modelling: a box cut off a corner through the boss and the hole leaves a valid solid.
            corner = Part.makeBox(20, 20, 20, FreeCAD.Vector(BUSHING_CENTRE[0], BUSHING_CENTRE[1], 0))
            cut = shape.cut(corner)
            self.assertTrue(cut.isValid())
            self.assertLess(cut.Volume, shape.Volume)
            feature = solid.make_solid(self.doc, obj)
            self.assertIn("2 cylinders", feature.SolidReport)
            # The hole's edge as Sketcher external geometry: a circle about the hole's axis.
            hole_edge = next(i for i, e in enumerate(feature.Shape.Edges)
                             if isinstance(e.Curve, Part.Circle) and abs(e.Curve.Radius - 4.0) < 0.02)
            sketch = self.doc.addObject("Sketcher::SketchObject", "HoleSketch")
            sketch.addExternal(feature.Name, "Edge%d" % (hole_edge + 1))
            self.doc.recompute()
            self.assertEqual(sketch.State, ["Up-to-date"])
            centre = sketch.getPoint(-3, 3)  # the first external geometry's centre
            self.assertLess(math.hypot(centre.x - BUSHING_CENTRE[0], centre.y - BUSHING_CENTRE[1]), 0.02)
            self.doc.removeObject(sketch.Name)
            self.doc.removeObject(feature.Name)

    def test_oval_or_oblique_hole_stays_triangles_with_the_reason(self):
        for name, oval, tilt in (("OvalHole", 0.03, 0.0), ("ObliqueHole", 0.0, 2.0)):
            obj, shape, model = self.solid_of(bushing_plate_mesh(0.005, oval_mm=oval, tilt_deg=tilt), name)
            cylinders = self.cylinders_of(shape)
            self.assertEqual(len(cylinders), 1, name)
            self.assertLess(abs(cylinders[0].Surface.Radius - 8.0), 0.02)
            feature = solid.make_solid(self.doc, obj)
            self.assertIn("not a cylinder square to its planes", feature.SolidReport)
            self.doc.removeObject(feature.Name)

    def test_countersink_and_chamfered_boss_become_cones(self):
        """A plate with a tapered (countersink-like) hole through it and a 45-degree chamfered boss on
        it, meshed finely as a scan is, 5 um of noise on every vertex: each becomes one conical face
        bounded by two circles, with the truth's half-angle. Built to fool it, on the same plate: a
        drilled hole (a cylinder, which a cone fit also fits with a half-angle near 0) must stay a
        cylinder, and a 12-sided pyramid frustum (its corners on a cone, its faces flat) must stay planes."""
        import collections

        v = FreeCAD.Vector
        tapered = Part.makeCone(4, 8, 10, v(15, 20, 0))  # radius 4 at the bottom, 8 at the top: 21.80 degrees
        chamfered = Part.makeCone(7, 4, 3, v(45, 20, 10))  # 45 degrees
        drilled = Part.makeCylinder(3, 10, v(30, 8, 0))
        bottom, top = ([v(30 + r * math.cos(math.radians(30 * k)), 31 + r * math.sin(math.radians(30 * k)), z) for k in range(12)]
                       for r, z in ((5, 10), (3, 14)))
        sides = [Part.Face(Part.makePolygon([bottom[k], bottom[k - 1], top[k - 1], top[k], bottom[k]])) for k in range(12)]
        pyramid = Part.makeSolid(Part.makeShell(sides + [Part.Face(Part.makePolygon(ring + ring[:1])) for ring in (bottom, top)]))
        truth = Part.makeBox(60, 40, 10).cut(tapered).cut(drilled).fuse(chamfered).fuse(pyramid).removeSplitter()
        kinds = lambda shape: collections.Counter(type(f.Surface).__name__ for f in shape.Faces)  # noqa: E731
        self.assertEqual(kinds(truth), {"Plane": 7 + 12 + 1, "Cone": 2, "Cylinder": 1})
        obj = self.doc.addObject("Mesh::Feature", "ConePlate")
        obj.Mesh = scan_mesh.freecad_mesh(self.scanned_mesh_of(truth, 3))
        started = time.perf_counter()
        shape, model, note = solid.solid_with_model(obj.Mesh, obj.Label, check_valid=True)
        FreeCAD.Console.PrintMessage("cone plate (%d facets, %.1f s): %s\n" % (
            obj.Mesh.CountFacets, time.perf_counter() - started, model.summary()))
        self.assertEqual(note, "")
        self.assertEqual(shape.ShapeType, "Solid")
        self.assertTrue(shape.isValid())
        self.assertAlmostEqual(shape.Volume, obj.Mesh.Volume, delta=1e-3 * obj.Mesh.Volume)
        self.assertEqual(kinds(shape), kinds(truth))
        self.assertEqual((model.cone_faces, model.cylinder_faces), (2, 1))
        cones = sorted((f for f in shape.Faces if isinstance(f.Surface, Part.Cone)), key=lambda f: f.Surface.Apex.x)
        for face, (x, y), half_angle, radii in ((cones[0], (15, 20), 21.801, (4, 8)), (cones[1], (45, 20), 45.0, (4, 7))):
            self.assertLess(abs(math.degrees(abs(face.Surface.SemiAngle)) - half_angle), 0.1)
            self.assertGreater(abs(face.Surface.Axis.z), 1 - 1e-6)
            self.assertLess(math.hypot(face.Surface.Center.x - x, face.Surface.Center.y - y), 0.02)
            circles = sorted(e.Curve.Radius for e in face.Edges if isinstance(e.Curve, Part.Circle))
            self.assertEqual(len(circles), 2)
            for radius, expected in zip(circles, radii):
                self.assertLess(abs(radius - expected), 0.02, (half_angle, circles))
        drilled_face = next(f for f in shape.Faces if isinstance(f.Surface, Part.Cylinder))
        self.assertLess(abs(drilled_face.Surface.Radius - 3), 0.02)
        self.assertIn("2 cones replacing", model.summary())  # what SolidReport says

    def test_chamfer_rings_become_a_cone_and_a_cylinder_sharing_a_circle(self):
        """A plate with a drilled hole whose mouth is chamfered (radius 4 mm, 1 mm at 45 degrees), a
        drilled hole under an 82-degree countersink (radius 3 to 5.5 mm) and a boss whose top edge is
        chamfered (radius 7 mm, 1 mm at 45 degrees), made with Part, meshed by FreeCAD's mesher in
        triangles of at most 0.8 mm with 5 um of noise: each chamfer ring becomes a cone and its
        bore or boss a cylinder, the two sharing one circle, the faces' kinds the Part model's."""
        import collections

        v = FreeCAD.Vector
        chamfer_deg, countersink_deg = 45.0, 41.0
        countersink_depth = 2.5 / math.tan(math.radians(countersink_deg))
        chamfered = Part.makeCylinder(4, 12, v(15, 20, -1)).fuse(Part.makeCone(4, 6, 2, v(15, 20, 9)))
        countersunk = Part.makeCylinder(3, 12, v(30, 20, -1)).fuse(
            Part.makeCone(3, 3 + 2 * 2.5, 2 * countersink_depth, v(30, 20, 10 - countersink_depth)))
        boss = Part.makeCylinder(7, 3.5, v(45, 20, 9.5)).fuse(Part.makeCone(7, 6, 1, v(45, 20, 13)))
        truth = Part.makeBox(60, 40, 10).cut(chamfered).cut(countersunk).fuse(boss).removeSplitter()
        kinds = lambda shape: collections.Counter(type(f.Surface).__name__ for f in shape.Faces)  # noqa: E731
        self.assertEqual(kinds(truth), {"Plane": 7, "Cone": 3, "Cylinder": 3})
        # The mesher leaves slivers on the planes beside the small circles that 5 um of noise folds
        # into self-intersections with most seeds (Make solid then refuses the mesh); with this one none.
        obj = self.doc.addObject("Mesh::Feature", "ChamferPlate")
        obj.Mesh = scan_mesh.freecad_mesh(self.scanned_mesh_of(truth, 2))
        shape, model, note = solid.solid_with_model(obj.Mesh, obj.Label, check_valid=True)
        FreeCAD.Console.PrintMessage("chamfer plate (%d facets): %s\n" % (obj.Mesh.CountFacets, model.summary()))
        self.assertEqual(note, "")
        self.assertEqual(shape.ShapeType, "Solid")
        self.assertTrue(shape.isValid())
        self.assertAlmostEqual(shape.Volume, obj.Mesh.Volume, delta=1e-3 * obj.Mesh.Volume)
        self.assertEqual(kinds(shape), kinds(truth))
        cones = sorted((f for f in shape.Faces if isinstance(f.Surface, Part.Cone)), key=lambda f: f.Surface.Center.x)
        cylinders = sorted((f for f in shape.Faces if isinstance(f.Surface, Part.Cylinder)), key=lambda f: f.Surface.Center.x)
        for cone, cylinder, x, half_angle, radius in ((cones[0], cylinders[0], 15, chamfer_deg, 4), (cones[1], cylinders[1], 30, countersink_deg, 3),
                                                      (cones[2], cylinders[2], 45, chamfer_deg, 7)):
            FreeCAD.Console.PrintMessage("  at x %g: cone %.4f degrees, cylinder radius %.5f mm\n" % (
                x, math.degrees(abs(cone.Surface.SemiAngle)), cylinder.Surface.Radius))
            self.assertLess(abs(math.degrees(abs(cone.Surface.SemiAngle)) - half_angle), 0.1)
            self.assertLess(abs(cylinder.Surface.Radius - radius), 0.02)
            for face in (cone, cylinder):
                self.assertGreater(abs(face.Surface.Axis.z), 1 - 1e-6)
                self.assertLess(math.hypot(face.Surface.Center.x - x, face.Surface.Center.y - 20), 0.02)
            # One circle of the cylinder's radius is an edge of both.
            shared = [e for e in cone.Edges if isinstance(e.Curve, Part.Circle) and any(e.isSame(g) for g in cylinder.Edges)]
            self.assertEqual(len(shared), 1)
            self.assertLess(abs(shared[0].Curve.Radius - radius), 0.02)
        self.assertIn("3 cones replacing", model.summary())


def scanned_column_mesh(sides, radius_mm, sigma_mm, height_mm=10.0, spacing_mm=0.5, seed=2):
    """A column on the z axis sampled as a scanner samples it: rows every spacing_mm, each row
    spacing_mm apart round the perimeter from an offset that puts no vertex on a crease, the ends in
    rings to a centre, every vertex moved by Gaussian noise. sides 0: a cylinder of radius_mm;
    otherwise a regular prism of that many sides, its corners on that circle."""
    perimeter = 2 * math.pi * radius_mm if sides == 0 else sides * 2 * radius_mm * math.sin(math.pi / sides)
    around, rows = round(perimeter / spacing_mm), round(height_mm / spacing_mm)
    rings = math.ceil(radius_mm / spacing_mm)
    t = (numpy.arange(around) + 0.3) / around  # share of the way round
    if sides == 0:
        rim = numpy.stack([numpy.cos(2 * math.pi * t), numpy.sin(2 * math.pi * t)], axis=1)
    else:
        side, along = numpy.divmod(t * sides, 1.0)
        corner = lambda k: numpy.stack([numpy.cos(2 * math.pi * k / sides), numpy.sin(2 * math.pi * k / sides)], axis=1)  # noqa: E731
        rim = (1 - along)[:, None] * corner(side) + along[:, None] * corner(side + 1)
    points, facets = [], []

    def ring(scale, z):
        first = len(points)
        points.extend((scale * radius_mm * x, scale * radius_mm * y, z) for x, y in rim)
        return list(range(first, first + around))

    def quads(low, high):  # outward when low runs counter-clockwise below high
        for k in range(around):
            k1 = (k + 1) % around
            facets.extend([(low[k], low[k1], high[k1]), (low[k], high[k1], high[k])])

    wall = [ring(1.0, height_mm * j / rows) for j in range(rows + 1)]
    for j in range(rows):
        quads(wall[j], wall[j + 1])
    for top in (False, True):
        z, outer = (height_mm, wall[-1]) if top else (0.0, wall[0])
        for i in range(rings - 1, 0, -1):
            inner = ring(i / rings, z)
            quads(outer, inner) if top else quads(inner, outer)
            outer = inner
        points.append((0.0, 0.0, z))
        for k in range(around):
            k1 = (k + 1) % around
            facets.append((outer[k], outer[k1], len(points) - 1) if top else (outer[k1], outer[k], len(points) - 1))
    mesh = picoscan.Mesh()
    mesh.vertices = (numpy.array(points) + numpy.random.default_rng(seed).normal(0, sigma_mm, (len(points), 3))).astype(numpy.float32)
    mesh.faces = numpy.array(facets, dtype=numpy.int32)
    return mesh


class PicoScanFacetedColumnSolidTest(unittest.TestCase):
    """Make solid on inputs built to fool its cylinder rule: regular prisms of 12, 16 and 24 flat sides
    and a cylinder, all of radius 10 mm (the prisms' corners on that circle), 10 mm high,
    sampled every 0.5 mm as a scan is with 5 um of noise. With 24 sides, a prism's RMS from the
    best cylinder is within the roundness the rule allows (before its normals were checked, Make
    solid took it for a cylinder; test_solid's CylinderFaces.APrismOfManyFlatSidesIsNoCylinder
    adds 32 sides). The cylinder must become one cylindrical face; each prism must keep its flat sides
    as planar faces, with no cylinder or cone, and the solid the volume of the true prism."""

    RADIUS_MM, HEIGHT_MM = 10.0, 10.0

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanFacetedColumnSolidTest")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)

    def truth(self, sides, radius_mm=RADIUS_MM):
        if sides == 0:
            return Part.makeCylinder(radius_mm, self.HEIGHT_MM)
        ring = [FreeCAD.Vector(radius_mm * math.cos(2 * math.pi * k / sides),
                               radius_mm * math.sin(2 * math.pi * k / sides), 0) for k in range(sides)]
        return Part.Face(Part.makePolygon(ring + ring[:1])).extrude(FreeCAD.Vector(0, 0, self.HEIGHT_MM))

    def test_prisms_keep_their_flat_sides_and_a_cylinder_is_one(self):
        import collections
        for sides in (0, 12, 16, 24):
            obj = self.doc.addObject("Mesh::Feature", "Column%d" % sides)
            obj.Mesh = scan_mesh.freecad_mesh(scanned_column_mesh(sides, self.RADIUS_MM, 0.005, self.HEIGHT_MM))
            shape, model, note = solid.solid_with_model(obj.Mesh, obj.Label, check_valid=True)
            report, truth = model.summary(), self.truth(sides)
            kinds = collections.Counter(type(f.Surface).__name__ for f in shape.Faces)
            FreeCAD.Console.PrintMessage("column of %d sides: %s; solid volume %.3f mm3, true part %.3f mm3 (%+.4f %%); %s\n" % (
                sides, dict(kinds), shape.Volume, truth.Volume, 100 * (shape.Volume / truth.Volume - 1), report))
            self.assertEqual(note, "")
            self.assertEqual(shape.ShapeType, "Solid")
            self.assertTrue(shape.isValid())
            # Within 0.1 % of the true part (a cylinder for the 24-sided prism would be 0.14 % over it).
            self.assertLess(abs(shape.Volume / truth.Volume - 1), 1e-3, sides)
            if sides == 0:
                self.assertEqual(kinds, {"Plane": 2, "Cylinder": 1})
                wall = next(f for f in shape.Faces if isinstance(f.Surface, Part.Cylinder))
                self.assertLess(abs(wall.Surface.Radius - self.RADIUS_MM), 0.02)
                continue
            self.assertEqual(kinds["Cylinder"] + kinds["Cone"], 0, (sides, report))
            self.assertIn("stay as they were", report)  # what SolidReport says
            if sides == 24:
                self.assertIn("normals bunch", report)
            # Its sides as planar faces: for all but at most one side, planar faces with its normal
            # (merged regions, larger than 1 mm2: a facet is 0.125 mm2) holding at least 75 % of its
            # area (the rest: the triangles where the scan cut its creases, a sample spacing wide).
            side_area = 2 * self.RADIUS_MM * math.sin(math.pi / sides) * self.HEIGHT_MM
            shares = []
            for k in range(sides):
                normal = FreeCAD.Vector(math.cos(2 * math.pi * (k + 0.5) / sides), math.sin(2 * math.pi * (k + 0.5) / sides), 0)
                shares.append(sum(f.Area for f in shape.Faces
                                  if f.Area > 1.0 and f.normalAt(0, 0).getAngle(normal) < math.radians(0.5)) / side_area)
            kept = sum(share > 0.75 for share in shares)
            FreeCAD.Console.PrintMessage("  %d of its %d sides planar faces (%.2f to %.2f of their area)\n" % (
                kept, sides, min(shares), max(shares)))
            self.assertGreaterEqual(kept, sides - 1)

    def test_a_prism_of_small_sides_is_no_cylinder(self):
        """32 sides round a radius of 6 mm: sides 1.2 mm wide, 2 or 3 facets across, bowing in by
        0.029 mm. Their normals bunch no more than a scanned cylinder's, and Make solid took the prism
        for a cylinder; its vertices' distances from the axis follow the sides (polygon_pattern)."""
        import collections
        obj = self.doc.addObject("Mesh::Feature", "Column32")
        obj.Mesh = scan_mesh.freecad_mesh(scanned_column_mesh(32, 6.0, 0.005, self.HEIGHT_MM))
        shape, model, note = solid.solid_with_model(obj.Mesh, obj.Label, check_valid=True)
        report, truth = model.summary(), self.truth(32, 6.0)
        kinds = collections.Counter(type(f.Surface).__name__ for f in shape.Faces)
        FreeCAD.Console.PrintMessage("column of 32 sides, radius 6 mm: %s; solid volume %.3f mm3, true part %.3f mm3 (%+.4f %%); %s\n" % (
            dict(kinds), shape.Volume, truth.Volume, 100 * (shape.Volume / truth.Volume - 1), report))
        self.assertEqual(note, "")
        self.assertTrue(shape.isValid())
        self.assertEqual(kinds["Cylinder"] + kinds["Cone"], 0, report)
        self.assertIn("follow a prism of 32 flat sides", report)  # what SolidReport says
        # The mesh's volume; the true prism's within 0.2 % (the scan cuts each crease by a chord).
        self.assertLess(abs(shape.Volume / obj.Mesh.Volume - 1), 1e-3)
        self.assertLess(abs(shape.Volume / truth.Volume - 1), 2e-3)


class PicoScanRegionFitTest(unittest.TestCase):
    """Fitting where the user points, on 60 000 points spread over the demo part with 20 um noise:
    the hole from a point picked on its wall, the chamfer as a plane (Fit primitives used to call it
    a 22 m cylinder), constraints to a fitted bottom plane, nominal sizes."""

    @classmethod
    def setUpClass(cls):
        from picoscan_wb.operations import region_fit
        cls.region_fit = region_fit
        cls.doc = FreeCAD.newDocument("PicoScanRegionFitTest")
        points, normals = sampled_demo_part(60000, 0.02, seed=8)
        cloud = picoscan.PointCloud()
        cloud.points = points.astype(numpy.float32)
        cloud.normals = normals.astype(numpy.float32)
        cls.cloud = cloud

    @classmethod
    def tearDownClass(cls):
        FreeCAD.closeDocument(cls.doc.Name)

    def fit_at(self, seed, radius_mm=30.0, **options):
        """The face around a picked point, grown over the surface up to its edges, fitted."""
        region = self.region_fit.pick_region(self.cloud, seed, radius_mm=radius_mm)
        return self.region_fit.fit_region(self.doc, self.cloud, region, self.region_fit.region_options(**options))

    def test_hole_from_a_picked_point(self):
        hole, fit = self.fit_at((-16.0, 0.0, 12.0))
        FreeCAD.Console.PrintMessage("hole picked at (-16, 0, 12): %s, diameter %.4f mm; %s\n" % (
            fit.shape.kind, 2 * fit.shape.radius_mm, fit.report))
        self.assertEqual(hole.TypeId, "Part::Cylinder")
        self.assertAlmostEqual(2 * hole.Radius.Value, 10.0, delta=0.02)
        axis = hole.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        self.assertLess(math.degrees(math.acos(min(1.0, abs(axis.z)))), 0.2)
        base = hole.Placement.Base
        self.assertLess(math.hypot(base.x + 11, base.y), 0.02)
        # Snapped to a 0.5 mm nominal step: exactly 10 mm, only because the points allow it.
        snapped, fit = self.fit_at((-16.0, 0.0, 12.0), snap_step_mm=0.5, snap_tolerance_mm=0.05)
        self.assertTrue(fit.snapped, fit.report)
        self.assertEqual(snapped.Radius.Value, 5.0)

    def test_chamfer_is_a_plane_at_45_degrees(self):
        chamfer, fit = self.fit_at((21.0, 14.0, 12.0))
        normal = chamfer.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        angle = math.degrees(math.acos(min(1.0, abs(normal.x))))
        FreeCAD.Console.PrintMessage("chamfer picked at (21, 14, 12): %s, %.4f deg to the right face; %s\n" % (
            fit.shape.kind, angle, fit.report))
        self.assertEqual(chamfer.TypeId, "Part::Plane", fit.report)
        self.assertAlmostEqual(angle, 45.0, delta=0.05)
        self.assertLess(abs(normal.z), 1e-3)
        # Fit primitives on the whole scan no longer takes the chamfer for a huge cylinder.
        group, created = primitives.fit_primitives(self.doc, self.cloud,
                                                   primitives.detection_options(epsilon_mm=0.1, min_points=300))
        radii = [obj.Radius.Value for obj, _ in created if obj.TypeId == "Part::Cylinder"]
        FreeCAD.Console.PrintMessage("Fit primitives on the demo part: cylinder radii %s\n" % radii)
        self.assertTrue(all(r < 10 for r in radii), radii)
        chamfers = [obj for obj, _ in created if obj.TypeId == "Part::Plane" and abs(
            obj.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1)).dot(FreeCAD.Vector(1, 1, 0).normalize())) > 0.999]
        self.assertEqual(len(chamfers), 1, [o.Label for o, _ in created])
        for obj in group.Group:
            self.doc.removeObject(obj.Name)
        self.doc.removeObject(group.Name)

    def test_constraints_to_a_fitted_bottom_plane(self):
        bottom, _ = self.fit_at((0.0, 5.0, 0.0))
        self.assertEqual(bottom.TypeId, "Part::Plane")
        up = bottom.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        boss, fit = self.fit_at((12.0, -9.0, 28.0), constraint="parallel", reference=bottom)
        self.assertEqual(boss.TypeId, "Part::Cylinder", fit.report)
        axis = boss.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        self.assertAlmostEqual(abs(axis.dot(up)), 1.0, delta=1e-9)
        self.assertAlmostEqual(2 * boss.Radius.Value, 14.0, delta=0.02)
        chamfer, fit = self.fit_at((21.0, 14.0, 12.0), constraint="perpendicular", reference=bottom)
        normal = chamfer.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        self.assertAlmostEqual(normal.dot(up), 0.0, delta=1e-9)
        # Coaxial with the boss: the hole's wall cannot be (23 mm away): the fit says so in its RMS.
        hole, fit = self.fit_at((-16.0, 0.0, 12.0), kind="cylinder", constraint="coaxial", reference=boss)
        self.assertGreater(fit.shape.rms_mm, 1.0)
        names = [o.Name for o in self.doc.Objects]
        with self.assertRaisesRegex(picoscan.Error, "cannot be coaxial"):
            self.fit_at((21.0, 14.0, 12.0), kind="plane", constraint="coaxial", reference=boss)
        # Two faces at once, with the noise known: no single primitive fits; nothing added.
        with self.assertRaisesRegex(picoscan.Error, "pick one surface only"):
            self.region_fit.fit_region(self.doc, self.cloud, self.region_fit.pick_region(
                self.cloud, (0.0, -18.0, 24.0), radius_mm=3.0, grow=False), self.region_fit.region_options(noise_mm=0.02))
        self.assertEqual([o.Name for o in self.doc.Objects], names)


class PicoScanMakeSolidSizeTest(unittest.TestCase):
    """Make solid of big meshes: a noisy closed mesh of the demo part's block gives a solid
    OpenCASCADE's isValid() accepts, of the mesh's volume within 0.1 %; and a curved mesh (a sphere,
    where nothing merges into planes) is valid too. In CTest the block has about 50 000 facets
    (spacing 0.54 mm) to keep the suite quick; the issue's 200 000 (0.27 mm) run with
    PICOSCAN_SOLID_SPACING_MM=0.27 (and are timed by benchmarks/freecad_make_solid.py)."""

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanSolidSizeTest")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)

    def check_solid(self, obj, expect_planes):
        started = time.monotonic()
        feature = solid.make_solid(self.doc, obj)  # the command's path: isValid() runs only up to 20 000 faces
        made = time.monotonic() - started
        started = time.monotonic()
        valid = feature.Shape.isValid()  # so it is run here whatever the face count
        FreeCAD.Console.PrintMessage(
            "Make solid of %s: %d facets -> %d faces in %.1f s, isValid() %s (%.1f s), volume %.3f mm3 against the "
            "mesh's %.3f mm3 (%+.4f %%); %s\n" % (
                obj.Label, obj.Mesh.CountFacets, len(feature.Shape.Faces), made, valid, time.monotonic() - started,
                feature.Shape.Volume, obj.Mesh.Volume, 100 * (feature.Shape.Volume / obj.Mesh.Volume - 1),
                feature.SolidReport))
        self.assertTrue(valid)
        self.assertEqual(feature.Shape.ShapeType, "Solid")
        self.assertAlmostEqual(feature.Shape.Volume, obj.Mesh.Volume, delta=1e-3 * obj.Mesh.Volume)
        if expect_planes:  # the merged planar faces kept, not the fallback to the mesh's triangles
            self.assertNotIn("planar faces not merged", feature.SolidReport)
        return feature

    def test_big_block_mesh_is_a_valid_solid_of_its_volume(self):
        spacing = float(os.environ.get("PICOSCAN_SOLID_SPACING_MM", "0.54"))
        obj = self.doc.addObject("Mesh::Feature", "BlockMesh")
        obj.Mesh = scan_mesh.freecad_mesh(outline_block_mesh(0.02, spacing))
        expected = {0.54: 49000, 0.27: 195000}.get(spacing)
        if expected:
            self.assertGreater(obj.Mesh.CountFacets, expected)
        feature = self.check_solid(obj, expect_planes=True)
        self.assertLess(len(feature.Shape.Faces), obj.Mesh.CountFacets / 20)  # the flat sides merged
        # Each face carries its own facets as its triangulation, and OpenCASCADE's mesher (what
        # FreeCAD's view provider runs to draw it) keeps them: it hands back the mesh's facets, where
        # the same solid without them gives a few triangles for each planar face.
        kept = len(feature.Shape.tessellate(1.0)[1])
        remeshed = len(feature.Shape.copy().tessellate(1.0)[1])
        FreeCAD.Console.PrintMessage("Make solid of %s: OpenCASCADE's mesher gives %d triangles (%d without the "
                                     "B-rep's triangulations)\n" % (obj.Label, kept, remeshed))
        # The B-rep's facets: the planar faces' as in the mesh, the curved regions' (the rounded
        # edge, the hole) simplified to far fewer.
        self.assertEqual(kept, solid_facets(feature))
        self.assertLess(kept, obj.Mesh.CountFacets)
        self.assertLess(remeshed, kept / 2)

    def test_curved_mesh_is_a_valid_solid_of_its_volume(self):
        obj = self.doc.addObject("Mesh::Feature", "SphereMesh")
        sphere = Mesh.createSphere(10.0, 30)  # 1 740 facets: isValid() of its triangle faces is slow
        # 400 mm from the origin, as a scan in its camera's frame: the faces' triangulations must
        # hold the edges' points to their 1e-7 mm tolerances there too (isValid() checks them).
        sphere.translate(0, 0, 400)
        obj.Mesh = sphere
        feature = self.check_solid(obj, expect_planes=False)
        # Curved: triangles, simplified to a fraction of the mesh's facets (the volume checked above).
        self.assertLess(len(feature.Shape.Faces), obj.Mesh.CountFacets / 3)
        self.assertIn("curved regions simplified", feature.SolidReport)


def solid_facets(feature):
    """The facets a Make solid feature's B-rep was built of (its SolidReport: "N faces from M facets")."""
    return int(re.search(r" faces from (\d+) facets", feature.SolidReport).group(1))


def stored_scan_view(doc, path, name):
    """A ScanView whose decoded view is the view PLY at `path`, kept in the document as a saved
    .FCStd keeps it (StoredView), its capture folder gone: the workbench reads the stored view, as
    it does for a reopened document. Lets a test use cached views without their captures."""
    obj = doc.addObject("Points::FeaturePython", name)
    scan_view.ScanView(obj)
    obj.Clean = True
    obj.CaptureFolder = os.path.join(os.path.dirname(path), "captures gone")
    obj.StoredView = path  # FreeCAD copies the file into the document
    obj.StoredDecoding = scan_view._decoding(obj)
    obj.recompute()
    return obj


def flipped_demo_views(cache_dir):
    """The demo part laid on its side (its +y face up, the face it stood on facing the camera's way
    at some turn) and turned 20 degrees about the table, one turntable round of 8 views: the core's
    turntable session as for turntable-v3-exact (full-resolution seed rig, 16 phase shifts, camera
    noise sigma = 1 DN, noise seeds 101...), cleaned. Simulated once into
    cache_dir/rebuild-v1-on-its-side. Returns (view files, the plan)."""
    options = picoscan.TurntableScanOptions()
    plan = options.plan
    plan.top_view = False
    plan.placement = picoscan.PartPlacement.OnItsSide
    plan.placement_turn_deg = 20
    options.plan = plan
    camera = options.camera
    camera.seed = 101
    options.camera = camera
    folder = os.path.join(cache_dir, "rebuild-v1-on-its-side")
    files = [os.path.join(folder, "view_%d.ply" % i) for i in range(plan.turntable_views)]
    if not all(os.path.isfile(f) for f in files):
        os.makedirs(folder, exist_ok=True)

        def write(simulated):  # to a temporary name, renamed: a stopped run leaves no half file
            path = os.path.join(folder, simulated.name + ".ply")
            picoscan.write_view_ply(simulated.view, path + ".part.ply")
            os.replace(path + ".part.ply", path)

        FreeCAD.Console.PrintMessage("simulating the demo part on its side into %s (once)\n" % folder)
        picoscan.simulate_turntable_scan(picoscan.mechanical_part(), picoscan.seed_rig_calibration(), options, write)
    return files, plan


class PicoScanRebuildFromScanTest(unittest.TestCase):
    """Issue 14 item 4 from the simulated scan itself, in two placements, as a user scans a part
    whose bottom matters: the demo part standing (the turntable-v3-exact views 0-7 the C++ suites
    cache: one round at 25 degrees elevation) and laid on its side (8 more views, simulated here
    once: flipped_demo_views), every view of the core's turntable session (16 phase shifts, camera
    noise sigma = 1 DN, cleaned). The views are joined by the workbench's own Stitch (Mode
    'Automatic', the user's default, PlacementOfView 1 and 2: the standing round aligns by features;
    the round on its side, a box's flat faces, does not (3 of 8 views: they could slide) and its
    turntable round with the step estimated takes over; the placements joined by shape; no true pose
    is used), and its poses are checked against the simulator's truth. The
    scan goes into the part's coordinate system by datum alignment on three fitted planes (the
    bottom, now measured, the front and the left side), so every height is measured from the
    bottom's data. The outline is a fitted Cross-section (Band) of a Poisson mesh of the scan,
    padded from the bottom to the fitted top plane; the hole a Pocket and the boss a Pad of the
    cylinders Fit at picked point fits to the faces grown from a point on each, the boss up to its
    fitted top; the chamfer a PartDesign Chamfer
    whose legs come from three fitted planes; then the deviation map of the scan against that
    body. Each dimension is compared with the simulator's truth."""

    STANDING = range(8)

    @classmethod
    def setUpClass(cls):
        cls.cache_dir = os.environ.get("PICOSCAN_TEST_CACHE_DIR", "")
        cache = os.path.join(cls.cache_dir, "turntable-v3-exact")
        cls.standing_files = [os.path.join(cache, "view_%d.ply" % i) for i in cls.STANDING]
        cls.missing = "" if cls.cache_dir and all(os.path.isfile(f) for f in cls.standing_files) else (
            "the demo part's turntable views are not cached at %s (the C++ suites write them)" % cache)

    def setUp(self):
        if self.missing:
            self.skipTest(self.missing)
        self.doc = FreeCAD.newDocument("PicoScanRebuildTest")

    def tearDown(self):
        if not self.missing:
            FreeCAD.closeDocument(self.doc.Name)

    @staticmethod
    def thinned(cloud, stride):
        result = picoscan.PointCloud()
        result.points = numpy.ascontiguousarray(numpy.asarray(cloud.points)[::stride])
        result.normals = numpy.ascontiguousarray(numpy.asarray(cloud.normals)[::stride])
        return result

    def fit_face(self, seed, label):
        """The face grown from a point picked on the scan, of the kind that fits it (Fit at picked
        point's defaults: the core's grow_face, then fit_at_point), added as a Part primitive."""
        picked = region_fit.fit_at_point(self.cloud_in_frame, seed, region_fit.picked_options())
        feature = region_fit.add_fitted(self.doc, self.cloud_in_frame, picked.fit, label=label)
        FreeCAD.Console.PrintMessage("  fitted %s: %d points; %s\n" % (label, len(picked.region), picked.fit.report))
        return feature

    def fit(self, seed, kind, label):
        """A plane fitted at a point picked on the scan (the core's fit_at_point, as Fit at picked point
        does) to the points within 4 mm of it (the merged views' normals turn smoothly over the edges,
        so a face grown from the point runs over them). Added as a Part primitive."""
        options = region_fit.picked_options(kind=kind, noise_mm=0.02, region="ball", radius_mm=4.0)
        picked = region_fit.fit_at_point(self.cloud_in_frame, seed, options)
        feature = region_fit.add_fitted(self.doc, self.cloud_in_frame, picked.fit, label=label)
        FreeCAD.Console.PrintMessage("  fitted %s: %s, %d points, rms %.4f mm\n" % (
            label, kind, len(picked.region), picked.fit.shape.rms_mm))
        return feature

    @staticmethod
    def line_2d(feature):
        """(point, unit direction) in the document's XY of a fitted vertical plane's trace."""
        point = feature.Placement.Base
        normal = feature.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        return numpy.array([point.x, point.y]), numpy.array([-normal.y, normal.x]) / math.hypot(normal.x, normal.y)

    @staticmethod
    def crossing(a, b):
        (p, u), (q, v) = a, b
        t = numpy.linalg.solve(numpy.column_stack([u, -v]), q - p)[0]
        return p + t * u

    @staticmethod
    def worst_pose_error(poses, truths, centres):
        """Worst (degrees, mm) of view -> model poses against the true ones, at each view's points."""
        errors = [picoscan.pose_difference(pose, truth, centre) for pose, truth, centre in zip(poses, truths, centres)]
        return max(e.rotation_deg for e in errors), max(e.translation_mm for e in errors)

    def stitched_scan(self):
        """The two placements' views stitched by the Stitch object; returns (the Stitch, the true
        part -> model transform). Asserts every view's pose against the simulator's truth."""
        flipped_files, flipped_plan = flipped_demo_views(self.cache_dir)
        standing_plan = picoscan.TurntablePlan()
        standing_plan.top_view = False
        true_poses = [numpy.asarray(p) for p in picoscan.turntable_part_poses(standing_plan)] + [
            numpy.asarray(p) for p in picoscan.turntable_part_poses(flipped_plan)]
        files = self.standing_files + flipped_files
        views = [stored_scan_view(self.doc, f, "%s_%d" % (placement, i)) for placement, group in (
            ("Standing", self.standing_files), ("OnItsSide", flipped_files)) for i, f in enumerate(group)]
        started = time.monotonic()
        merged = stitch.create(self.doc, views, placement_of_view=[1] * len(self.standing_files) + [2] * len(flipped_files))
        FreeCAD.Console.PrintMessage("stitched %d views in %.1f s: %s\n  %s\n" % (
            len(files), time.monotonic() - started, "; ".join(merged.PlacementReport), "\n  ".join(merged.AlignmentReport)))
        self.assertEqual(merged.AlignedCount, len(files), merged.Report)
        # Each view's pose (view -> model, the model being the first view's camera frame) against the
        # truth, at the view's points: a placement joined wrongly (its near-twin turned over) or a
        # round that drifted fails here.
        poses = [numpy.array(pose.toMatrix().A).reshape(4, 4) for pose in merged.ViewPoses]
        centres = [numpy.asarray(cloud_of(view).points).mean(axis=0) for view in views]
        truths = [true_poses[0] @ numpy.linalg.inv(part_to_camera) for part_to_camera in true_poses]
        worst = self.worst_pose_error(poses, truths, centres)
        FreeCAD.Console.PrintMessage("  worst pose error of the %d views: %.4f deg, %.4f mm\n" % ((len(views),) + worst))
        self.assertLess(worst[0], 0.05)
        self.assertLess(worst[1], 0.05)
        # Built to fool the check: the second placement tilted by 0.1 degrees about the part's middle
        # (the bottom 44 um off at its ends: the heights and the map would move by that) must fail it.
        tilt = numpy.eye(4)
        tilt[:3, :3] = numpy.asarray(FreeCAD.Rotation(FreeCAD.Vector(1, 0, 0), 0.1).toMatrix().A).reshape(4, 4)[:3, :3]
        middle = numpy.eye(4)
        middle[:3, 3] = (true_poses[0] @ numpy.array([0.0, 0.0, 16.0, 1.0]))[:3]
        tilted = middle @ tilt @ numpy.linalg.inv(middle)
        wrong = poses[:len(self.standing_files)] + [tilted @ pose for pose in poses[len(self.standing_files):]]
        self.assertGreater(self.worst_pose_error(wrong, truths, centres)[0], 0.05)
        return merged, true_poses[0]

    def check_outline_holds_only_the_part(self, outline, at):
        """What the part has at z = 12 mm: four sides, the chamfer and the hole (5 lines and a circle).
        The sketch may hold nothing else but short pieces (under 2 mm) at corners the Poisson surface
        rounds; no arc, and a circle only of the hole's size where the hole is. The hole's trace is
        either that circle or listed in LeftOut (on this mesh its points scatter by 0.087 mm, beyond
        the section's tolerance: an own tolerance of 0.44 mm made it an arc and a line), and nothing
        but the hole's trace is left out."""
        to_sketch = lambda x, y: outline.Placement.inverse().multVec(FreeCAD.Vector(*at(x, y, 12.0)))  # noqa: E731
        corners = [to_sketch(x, y) for x, y in ((-25, -18), (25, -18), (25, 10), (17, 18), (-25, 18))]
        hole = to_sketch(-11.0, 0.0)
        flat = lambda v: FreeCAD.Vector(v.x, v.y, 0)  # noqa: E731
        report = "\n".join(list(outline.FitReport) + list(outline.LeftOut))
        lines = [g for g in outline.Geometry if g.TypeId == "Part::GeomLineSegment"]
        self.assertEqual(len([g for g in lines if g.length() > 2]), 5, report)
        for piece in (g for g in lines if g.length() <= 2):
            self.assertLess(min(max((flat(piece.StartPoint) - flat(c)).Length, (flat(piece.EndPoint) - flat(c)).Length)
                                for c in corners), 2.0, report)
        curves = [g for g in outline.Geometry if g.TypeId != "Part::GeomLineSegment"]
        for curve in curves:
            self.assertEqual(curve.TypeId, "Part::GeomCircle", report)
            self.assertAlmostEqual(curve.Radius, 5.0, delta=0.02, msg=report)
            self.assertLess((flat(curve.Center) - flat(hole)).Length, 0.05, report)
        left_at = [tuple(float(v) for v in re.search(r"around \(([-\d.]+), ([-\d.]+)\) mm", line).groups())
                   for line in outline.LeftOut]
        for x, y in left_at:
            self.assertLess(math.hypot(x - hole.x, y - hole.y), 2.0, report)
        self.assertEqual(len(curves) + len(left_at), 1, report)

    def test_rebuild_from_two_placements_stitched(self):
        # Wall-clock and CPU seconds (all threads) of each stage: CPU depends less on the machine's load.
        clock = lambda: (time.monotonic(), time.process_time())  # noqa: E731
        started = clock()
        merged, part_to_model = self.stitched_scan()
        stitched = clock()
        model_cloud = cloud_of(merged)  # the Stitch's own frame (view 0's camera); its Placement: the part frame

        def move_to_document():
            to_document = numpy.array(merged.Placement.toMatrix().A).reshape(4, 4)
            cloud = picoscan.PointCloud()  # the scan in the document's coordinates
            cloud.points = (numpy.asarray(model_cloud.points, dtype=numpy.float64) @ to_document[:3, :3].T
                            + to_document[:3, 3]).astype(numpy.float32)
            cloud.normals = (numpy.asarray(model_cloud.normals, dtype=numpy.float64) @ to_document[:3, :3].T).astype(
                numpy.float32)
            self.cloud_in_frame = cloud
            # Where a user would click, given in the part's true coordinates (truth only says where).
            to_click = to_document @ part_to_model
            return lambda x, y, z: tuple(to_click[:3, :3] @ (x, y, z) + to_click[:3, 3])

        # Datum alignment (3-2-1) on the bottom (seen by the second placement), the front and the
        # left side: Z up from the fitted bottom, X along the front, the origin at the left front
        # bottom corner. (Truth: 50 x 36 x 24 block, hole 10 mm at (-11, 0), boss 14 mm at (12, -2)
        # up to 32 mm, chamfer 8 x 8 mm at the (+x, +y) edge; the part's middle at x = y = 0.)
        at = move_to_document()
        datums = [self.fit(at(*point), "plane", label) for point, label in (
            ((0.0, -10.0, 0.0), "Bottom"), ((-4.0, -18.0, 12.0), "Front"), ((-25.0, 6.0, 12.0), "Left"))]
        frame, _, _ = datum.align(merged, [(d, "") for d in datums], carried=datums)
        FreeCAD.Console.PrintMessage("  datum frame: %s\n" % datum.frame_report(frame))
        at = move_to_document()
        for feature in datums:
            self.doc.removeObject(feature.Name)
        cloud = self.cloud_in_frame
        scan = self.doc.addObject("Points::Feature", "Scan")
        scan.Points = scan_view.points_of(self.thinned(cloud, 8))
        FreeCAD.Console.PrintMessage("rebuild from the stitched scan: %d points\n" % len(cloud))
        # Mesh (Poisson, as Mesh does for a Stitch) of every 8th point, and the fitted outline section
        # (Cross-section across Z at mid height, Band 10 mm).
        options = picoscan.MeshOptions()
        options.method = picoscan.MeshMethod.Poisson
        options.sample_spacing_mm = 1.0
        surface = self.doc.addObject("Mesh::Feature", "ScanMesh")
        surface.Mesh = scan_mesh.freecad_mesh(picoscan.mesh_points(self.thinned(cloud, 8), options, None))
        outline = section.cross_section(self.doc, surface, axis="Z", offset_mm=12.0, name="Outline", band_mm=10.0)
        FreeCAD.Console.PrintMessage("  outline section (noise %.4f mm, tolerance %.4f mm):\n    %s\n    %s\n" % (
            outline.FitNoise.Value, outline.FitTolerance.Value, "\n    ".join(outline.FitReport), "\n    ".join(outline.LeftOut)))
        self.check_outline_holds_only_the_part(outline, at)
        meshed = clock()
        bottom = self.fit(at(0.0, -10.0, 0.0), "plane", "Bottom")
        top = self.fit(at(-18.0, 8.0, 24.0), "plane", "Top")
        boss_top = self.fit(at(12.0, -2.0, 32.0), "plane", "Boss top")
        right = self.fit(at(25.0, -4.0, 12.0), "plane", "Right")
        back = self.fit(at(-4.0, 18.0, 12.0), "plane", "Back")
        chamfer = self.fit(at(21.0, 14.0, 12.0), "plane", "Chamfer")
        # The cylinders by Fit at picked point with its defaults (the face grown from a point on the
        # boss's short side and on the hole's partly seen wall, its kind chosen automatically).
        hole = self.fit_face(at(-16.0, 0.0, 21.0), "Hole")
        boss = self.fit_face(at(19.0, -2.0, 28.0), "Boss")
        self.assertEqual((hole.TypeId, boss.TypeId), ("Part::Cylinder", "Part::Cylinder"))
        # Heights of the fitted planes where their points are (their faces' centres).
        bottom_z, top_z, boss_top_z = (plane.Shape.CenterOfMass.z for plane in (bottom, top, boss_top))

        # The block: the fitted outline, edited as a user does in Sketcher: the hole's trace and the
        # chamfer go (a Pocket and a Chamfer make them; the Poisson surface rounds the corners, so a
        # corner may hold a short extra element too), and the four sides are drawn to meet where the
        # fitted sides cross.
        segments = [g for g in outline.Geometry if g.TypeId == "Part::GeomLineSegment"]
        sides = [g for g in segments if g.length() > 20]  # in the outline's order
        self.assertEqual(len(sides), 4, outline.FitReport)
        base = numpy.array([outline.Placement.Base.x, outline.Placement.Base.y])
        fitted_sides = [(numpy.array([g.StartPoint.x, g.StartPoint.y]) + base,
                         numpy.array([g.EndPoint.x - g.StartPoint.x, g.EndPoint.y - g.StartPoint.y]) / g.length())
                        for g in sides]
        lengths = [g.length() for g in sides]
        corners = [self.crossing(fitted_sides[k - 1], fitted_sides[k]) - base for k in range(4)]
        import Sketcher
        outline.deleteAllGeometry()
        for k in range(4):
            outline.addGeometry(Part.LineSegment(FreeCAD.Vector(*corners[k], 0), FreeCAD.Vector(*corners[(k + 1) % 4], 0)))
        for k in range(4):
            outline.addConstraint(Sketcher.Constraint("Coincident", k, 2, (k + 1) % 4, 1))
        self.assertEqual(outline.solve(), 0)
        by_length = sorted(range(4), key=lambda k: -lengths[k])  # the fitted 50, 42, 36 and 28 mm sides
        front_line, back_line_fit, left_line, right_line_fit = [fitted_sides[k] for k in by_length]
        body = self.doc.addObject("PartDesign::Body", "Body")
        body.addObject(outline)
        block = body.newObject("PartDesign::Pad", "Block")
        block.Profile = outline
        PicoScanSectionFitTest.pad_between(block, outline, bottom_z, top_z)  # from the fitted bottom to the top
        # The hole and the boss: circles of the fitted cylinders on the top plane.
        def circle_sketch(name, cylinder):
            sketch = body.newObject("Sketcher::SketchObject", name)
            axis = cylinder.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
            base = cylinder.Placement.Base
            centre = base + axis * ((top_z - base.z) / axis.z)
            sketch.Placement = FreeCAD.Placement(FreeCAD.Vector(0, 0, top_z), FreeCAD.Rotation())
            sketch.addGeometry(Part.Circle(FreeCAD.Vector(centre.x, centre.y, 0), FreeCAD.Vector(0, 0, 1),
                                           cylinder.Radius.Value))
            return sketch
        hole_sketch = circle_sketch("HoleSketch", hole)
        pocket = body.newObject("PartDesign::Pocket", "HolePocket")
        pocket.Profile = hole_sketch
        pocket.Type = "ThroughAll"
        boss_sketch = circle_sketch("BossSketch", boss)
        boss_pad = body.newObject("PartDesign::Pad", "BossPad")
        boss_pad.Profile = boss_sketch
        boss_pad.Length = boss_top_z - top_z
        self.doc.recompute()
        # The chamfer: its legs along the right and back faces, from the three fitted planes.
        right_line, back_line, chamfer_line = self.line_2d(right), self.line_2d(back), self.line_2d(chamfer)
        edge_xy = self.crossing(right_line, back_line)
        leg_right = numpy.linalg.norm(self.crossing(right_line, chamfer_line) - edge_xy)
        leg_back = numpy.linalg.norm(self.crossing(back_line, chamfer_line) - edge_xy)
        vertical = [(math.hypot(e.Vertexes[0].Point.x - edge_xy[0], e.Vertexes[0].Point.y - edge_xy[1]), k)
                    for k, e in enumerate(boss_pad.Shape.Edges, start=1)
                    if len(e.Vertexes) == 2 and abs(e.Vertexes[0].Point.z - e.Vertexes[1].Point.z) > 20]
        distance, edge = min(vertical)
        self.assertLess(distance, 0.1)
        chamfer_feature = body.newObject("PartDesign::Chamfer", "Chamfer")
        chamfer_feature.Base = (boss_pad, ["Edge%d" % edge])
        chamfer_feature.ChamferType = "Two distances"
        chamfer_feature.Size, chamfer_feature.Size2 = leg_right, leg_back
        self.doc.recompute()

        def chamfer_legs():
            """The legs of the body's chamfer face, measured along the right and back faces."""
            face = [f for f in body.Shape.Faces if f.Surface.TypeId == "Part::GeomPlane" and abs(
                f.normalAt(0, 0).dot(chamfer.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1)))) > 0.999][0]
            points = [numpy.array([v.Point.x, v.Point.y]) for v in face.Vertexes]
            on_right = min(points, key=lambda p: abs(numpy.cross(right_line[1], p - right_line[0])))
            on_back = min(points, key=lambda p: abs(numpy.cross(back_line[1], p - back_line[0])))
            return numpy.linalg.norm(on_right - edge_xy), numpy.linalg.norm(on_back - edge_xy)

        if abs(chamfer_legs()[0] - leg_right) > abs(chamfer_legs()[0] - leg_back):
            chamfer_feature.FlipDirection = True  # Size went along the other face
            self.doc.recompute()
        self.assertTrue(body.Shape.isValid())
        built = clock()

        # The body's dimensions, measured on it as a drawing gives them, against the simulator's truth.
        distance_to = lambda line, point: abs(numpy.cross(line[1], numpy.asarray(point) - line[0]))  # noqa: E731
        hole_centre = numpy.array([hole_sketch.Geometry[0].Center.x, hole_sketch.Geometry[0].Center.y])
        boss_centre = numpy.array([boss_sketch.Geometry[0].Center.x, boss_sketch.Geometry[0].Center.y])
        legs = chamfer_legs()
        box = body.Shape.BoundBox
        measured = [("length", distance_to(left_line, right_line_fit[0]), 50.0),
                    ("width", distance_to(front_line, back_line_fit[0]), 36.0),
                    ("block height", top_z - box.ZMin, 24.0), ("overall height", box.ZMax - box.ZMin, 32.0),
                    ("hole diameter", 2 * hole.Radius.Value, 10.0),
                    ("hole from the left side", distance_to(left_line, hole_centre), 14.0),
                    ("hole from the front side", distance_to(front_line, hole_centre), 18.0),
                    ("boss diameter", 2 * boss.Radius.Value, 14.0),
                    ("boss from the left side", distance_to(left_line, boss_centre), 37.0),
                    ("boss from the front side", distance_to(front_line, boss_centre), 16.0),
                    ("boss height", boss_top_z - top_z, 8.0),
                    ("chamfer along the right side", legs[0], 8.0), ("chamfer along the back side", legs[1], 8.0)]
        for name, value, true in measured:
            FreeCAD.Console.PrintMessage("  rebuilt %s: %.4f mm (truth %.1f, error %+.1f um)\n" % (
                name, value, true, 1000 * (value - true)))
        deviation = deviation_map.create(self.doc, scan, body, tolerance_mm=0.05)
        done = clock()
        FreeCAD.Console.PrintMessage("  scan against the rebuilt body: %s\n  times (wall, CPU): %s\n" % (
            deviation.Summary, ", ".join("%s %.1f s, %.1f s" % (stage, end[0] - begin[0], end[1] - begin[1]) for stage, begin, end in (
                ("views and stitch", started, stitched), ("datums, mesh and section", stitched, meshed),
                ("fits and body", meshed, built), ("map", built, done)))))
        for name, value, true in measured:
            self.assertAlmostEqual(value, true, delta=0.02, msg=name)
        self.assertLessEqual(deviation.MeanAbsDeviation.Value, 0.015)


class PicoScanFuseFilesTest(unittest.TestCase):
    """Posed view files (as MeshLab's Save Views for Project writes them) fused into a Mesh feature
    by the core reading them one at a time, against the same views held whole."""

    VIEWS = (0, 2, 4, 6)  # the demo part's turntable views 90 degrees apart, as the C++ suites cache them

    @classmethod
    def setUpClass(cls):
        cache = os.path.join(os.environ.get("PICOSCAN_TEST_CACHE_DIR", ""), "turntable-v3-exact")
        cached = [os.path.join(cache, "view_%d.ply" % i) for i in cls.VIEWS]
        if not (os.environ.get("PICOSCAN_TEST_CACHE_DIR") and all(os.path.isfile(f) for f in cached)):
            raise unittest.SkipTest("no cached turntable views at %s (the C++ suites write them)" % cache)
        poses = [numpy.asarray(pose) for pose in picoscan.turntable_part_poses(picoscan.TurntablePlan())]
        cls.folder = tempfile.mkdtemp(prefix="picoscan_fuse_files_")
        cls.paths, cls.views = [], []
        for source, index in zip(cached, cls.VIEWS):
            view = picoscan.read_view_ply(source)
            view.pose = poses[0] @ numpy.linalg.inv(poses[index])  # into view 0's frame
            cls.paths.append(os.path.join(cls.folder, "view_%d.ply" % index))
            picoscan.write_view_ply(view, cls.paths[-1])
            cls.views.append(view)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder, ignore_errors=True)

    def setUp(self):
        self.doc = FreeCAD.newDocument("PicoScanFuseFilesTest")

    def tearDown(self):
        FreeCAD.closeDocument(self.doc.Name)

    def test_view_files_fuse_as_the_views_held_whole(self):
        from picoscan_wb.operations import fuse

        options = picoscan.MeshOptions()
        options.method = picoscan.MeshMethod.AdvancingFront
        options.sample_spacing_mm = 1.0
        whole = picoscan.fuse_views(self.views, options)
        feature, fused = fuse.fuse_view_files(self.doc, self.paths, method="AdvancingFront", sample_spacing_mm=1.0)
        FreeCAD.Console.PrintMessage("fused %d view files: %d points, %d facets (views held whole: %d points, %d faces)\n"
                                     % (len(self.paths), len(fused.merged), feature.Mesh.CountFacets, len(whole.merged),
                                        len(whole.mesh.faces)))
        self.assertEqual(len(fused.merged), sum(view.valid_count() for view in self.views))
        self.assertTrue(numpy.array_equal(fused.merged.points, whole.merged.points))
        self.assertEqual(feature.Mesh.CountFacets, len(fused.mesh.faces))
        # The advancing front does not repeat itself exactly on the same cloud (a vertex or two).
        self.assertAlmostEqual(len(fused.mesh.faces), len(whole.mesh.faces), delta=0.01 * len(whole.mesh.faces))
        # Posed, the four sides surround the part: the mesh spans the true part across (x) and in
        # depth (z) in view 0's camera frame; the views left in their own frames would not.
        pose = numpy.asarray(picoscan.turntable_part_poses(picoscan.TurntablePlan())[0])
        truth = numpy.asarray(picoscan.mechanical_part().vertices, dtype=numpy.float64) @ pose[:3, :3].T + pose[:3, 3]
        box = feature.Mesh.BoundBox
        for axis, low, high in ((0, box.XMin, box.XMax), (2, box.ZMin, box.ZMax)):
            self.assertAlmostEqual(low, truth[:, axis].min(), delta=1.0)
            self.assertAlmostEqual(high, truth[:, axis].max(), delta=1.0)

    def test_a_missing_file_is_named_and_nothing_is_added(self):
        from picoscan_wb.operations import fuse

        missing = os.path.join(self.folder, "gone.ply")
        with self.assertRaisesRegex(picoscan.Error, "gone.ply"):
            fuse.fuse_view_files(self.doc, self.paths[:1] + [missing])
        with self.assertRaisesRegex(picoscan.Error, "fill must be one of"):
            fuse.fuse_view_files(self.doc, self.paths, fill="Cap")
        self.assertEqual(self.doc.Objects, [])
