"""GUI tests of the PicoScan workbench, run inside FreeCAD under Xvfb (tests/freecad/run_gui_tests.py):
the workbench activates, every command is registered with an icon and is active when it should be,
the Calibrate panel opens and calibrates, bad input shows a message box and leaves the document
unchanged, and a screenshot of a scanned mesh is saved."""
import math
import os
import re
import shutil
import subprocess
import tempfile
import time
import unittest

import numpy
import FreeCAD
import FreeCADGui
from PySide2 import QtWidgets

import picoscan
from picoscan_wb.commands import COMMANDS, analysis
from picoscan_wb.objects import cloud_of, scan_mesh, scan_view
from picoscan_wb.operations import simulate

ALWAYS_ACTIVE = {"PicoScan_Calibrate", "PicoScan_Scan", "PicoScan_ImportCaptures", "PicoScan_ShowRig"}
FOR_SCAN_VIEWS = {"PicoScan_Clean", "PicoScan_Mesh", "PicoScan_FitPrimitives", "PicoScan_EncodingView", "PicoScan_PartFrame"}
FOR_MESHES = {"PicoScan_MakeSolid", "PicoScan_CrossSection"}


def process_events():
    FreeCADGui.updateGui()
    QtWidgets.QApplication.processEvents()


class PicoScanGuiTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        FreeCADGui.activateWorkbench("PicoScanWorkbench")
        cls.folder = tempfile.mkdtemp(prefix="picoscan_gui_")
        cls.captures = os.path.join(cls.folder, "shaft")
        cls.calibration = simulate.simulate_scan(cls.captures, simulate.shaft_scene(), camera_scale=0.5)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.folder, ignore_errors=True)

    def setUp(self):
        # Message boxes are recorded instead of blocking the test.
        self.messages = []
        self.saved = {}
        for name in ("critical", "warning", "information"):
            self.saved[name] = getattr(QtWidgets.QMessageBox, name)
            setattr(QtWidgets.QMessageBox, name, self.recorder(name))
        self.saved_dialogs = (QtWidgets.QFileDialog.getExistingDirectory, QtWidgets.QFileDialog.getOpenFileName,
                              QtWidgets.QInputDialog.getItem, QtWidgets.QInputDialog.getDouble)
        self.doc = FreeCAD.newDocument("GuiTest")
        FreeCADGui.Selection.clearSelection()

    def tearDown(self):
        if FreeCADGui.Control.activeDialog():
            FreeCADGui.Control.closeDialog()
        for name, function in self.saved.items():
            setattr(QtWidgets.QMessageBox, name, function)
        (QtWidgets.QFileDialog.getExistingDirectory, QtWidgets.QFileDialog.getOpenFileName,
         QtWidgets.QInputDialog.getItem, QtWidgets.QInputDialog.getDouble) = self.saved_dialogs
        FreeCAD.closeDocument(self.doc.Name)
        process_events()

    def recorder(self, kind):
        def record(parent, title, text, *args, **kwargs):
            self.messages.append((kind, title, text))
            return QtWidgets.QMessageBox.Ok
        return record

    def object_names(self):
        return [o.Name for o in self.doc.Objects]

    def answer_dialogs(self, folder, calibration=""):
        QtWidgets.QFileDialog.getExistingDirectory = lambda *args, **kwargs: folder
        QtWidgets.QFileDialog.getOpenFileName = lambda *args, **kwargs: (calibration, "")

    def test_a_workbench_active_with_toolbar_and_menu(self):
        self.assertEqual(FreeCADGui.activeWorkbench().name(), "PicoScanWorkbench")
        window = FreeCADGui.getMainWindow()
        toolbars = [bar for bar in window.findChildren(QtWidgets.QToolBar) if bar.windowTitle() == "PicoScan"]
        self.assertEqual(len(toolbars), 1)
        actions = [action for action in toolbars[0].actions() if not action.isSeparator()]
        self.assertEqual(len(actions), len(COMMANDS))
        for action in actions:
            self.assertFalse(action.icon().isNull(), action.text())
        menus = [menu.title() for menu in window.menuBar().findChildren(QtWidgets.QMenu)]
        self.assertIn("PicoScan", [title.replace("&", "") for title in menus])

    def test_b_commands_registered_with_icons(self):
        registered = FreeCADGui.listCommands()
        for name in COMMANDS:
            self.assertIn(name, registered)
            info = FreeCADGui.Command.get(name).getInfo()
            self.assertTrue(os.path.isfile(info["pixmap"]), info["pixmap"])
            self.assertTrue(info["pixmap"].endswith(".svg"))
            self.assertFalse(FreeCADGui.Command.get(name).getAction()[0].icon().isNull(), name)
        # One icon per command: Part frame and Datum alignment shared one, two alike buttons side by side.
        icons = [FreeCADGui.Command.get(name).getInfo()["pixmap"] for name in COMMANDS]
        self.assertEqual(len(set(icons)), len(icons), icons)

    def expect_active(self, active):
        for name, command in COMMANDS.items():
            self.assertEqual(bool(command.IsActive()), name in active, name)

    def test_c_commands_active_when_they_should_be(self):
        self.expect_active(ALWAYS_ACTIVE)
        view = scan_view.create(self.doc, self.captures, self.calibration)
        FreeCADGui.Selection.addSelection(view)
        self.expect_active(ALWAYS_ACTIVE | FOR_SCAN_VIEWS)
        second = scan_view.create(self.doc, self.captures, self.calibration)
        FreeCADGui.Selection.addSelection(second)
        self.expect_active(ALWAYS_ACTIVE | FOR_SCAN_VIEWS | {"PicoScan_Stitch"})
        # Several placements: a group of ScanViews per placement, the groups selected in order.
        standing, side = self.doc.addObject("App::DocumentObjectGroup", "Standing"), self.doc.addObject(
            "App::DocumentObjectGroup", "OnItsSide")
        standing.addObject(view)
        side.addObject(second)
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(standing)
        FreeCADGui.Selection.addSelection(side)
        self.assertTrue(COMMANDS["PicoScan_Stitch"].IsActive())
        views, placements = analysis.selected_placements()
        self.assertEqual(([v.Name for v in views], placements), ([view.Name, second.Name], [1, 2]))
        mesh = scan_mesh.create(self.doc, view, pixel_step=4)
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(mesh)
        self.expect_active(ALWAYS_ACTIVE | FOR_MESHES)
        # A reopened document's view whose capture folder and calibration are gone: Encoding view, Show
        # rig and Clean (it decodes again) read them, so they are greyed out (they ran into a message box).
        second.CaptureFolder = os.path.join(self.folder, "deleted_captures")
        second.CalibrationFile = os.path.join(self.folder, "deleted_captures", "calibration.yml")
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(second)
        self.expect_active((ALWAYS_ACTIVE | FOR_SCAN_VIEWS) - {"PicoScan_EncodingView", "PicoScan_ShowRig", "PicoScan_Clean"})
        view.Clean = True  # cleaned already: nothing for Clean to do
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(view)
        self.expect_active((ALWAYS_ACTIVE | FOR_SCAN_VIEWS) - {"PicoScan_Clean"})

    def test_d_calibrate_panel_opens_reports_bad_input_and_calibrates(self):
        FreeCADGui.runCommand("PicoScan_Calibrate")
        process_events()
        self.assertTrue(FreeCADGui.Control.activeDialog())
        panel = COMMANDS["PicoScan_Calibrate"].panel
        missing = os.path.join(self.folder, "no_such_pose")
        panel.poses.addItem(missing)
        panel.output.setText(os.path.join(self.folder, "rig.yml"))
        self.assertFalse(panel.accept())
        self.assertEqual(len(self.messages), 1)
        self.assertIn("no_such_pose: capture folder does not exist", self.messages[0][2])
        self.assertTrue(FreeCADGui.Control.activeDialog())  # still open for corrections
        panel.board.setText("chessboard:9x6")
        panel.poses.clear()
        panel.poses.addItem(self.captures)
        self.assertFalse(panel.accept())
        self.assertIn("--board", self.messages[1][2])
        folders, board, truth = simulate.simulate_board_poses(os.path.join(self.folder, "board"))
        panel.board.setText(board)
        panel.poses.clear()
        for folder in folders:
            panel.poses.addItem(folder)
        self.assertTrue(panel.accept(), self.messages)
        self.assertEqual(len(self.messages), 2)
        report = "\n".join(panel.report_lines)
        self.assertIn("camera RMS", report)
        self.assertIn("pose_00: 54 corners", report)
        calibration = picoscan.read_calibration(os.path.join(self.folder, "rig.yml"))
        baseline_error = numpy.linalg.norm(calibration.T - truth.T)
        FreeCAD.Console.PrintMessage("calibrated baseline error %.3f mm\n" % baseline_error)
        self.assertLess(baseline_error, 1.0)
        self.assertEqual(self.object_names(), [])

    def test_e_import_missing_folder_shows_message(self):
        before = self.object_names()
        self.answer_dialogs(os.path.join(self.folder, "missing_captures"))
        FreeCADGui.runCommand("PicoScan_ImportCaptures")
        process_events()
        self.assertEqual(len(self.messages), 1)
        self.assertIn("missing_captures: capture folder does not exist", self.messages[0][2])
        self.assertEqual(self.object_names(), before)

    def test_f_import_wrong_calibration_shows_message(self):
        scan_view.create(self.doc, self.captures, self.calibration)
        before = self.object_names()
        copy = os.path.join(self.folder, "copy_without_calibration")
        if not os.path.isdir(copy):
            shutil.copytree(self.captures, copy, ignore=shutil.ignore_patterns("calibration.yml"))
        wrong = os.path.join(self.folder, "full_size.yml")
        picoscan.write_calibration(picoscan.seed_rig_calibration(), wrong)  # 1600 x 1200, captures are 800 x 600
        self.answer_dialogs(copy, wrong)
        FreeCADGui.runCommand("PicoScan_ImportCaptures")
        process_events()
        self.assertEqual(len(self.messages), 1)
        self.assertIn("000_white.png: image is 800x600 but the calibration's camera_size is 1600x1200", self.messages[0][2])
        self.assertEqual(self.object_names(), before)
        self.assertTrue(all(o.isValid() for o in self.doc.Objects))

    def test_f_stereo_scan_panel_and_import_ask_for_the_second_folder(self):
        # The Scan panel simulates two cameras (at a quarter of the seed resolution: 400 x 300).
        FreeCADGui.runCommand("PicoScan_Scan")
        process_events()
        panel = COMMANDS["PicoScan_Scan"].panel
        panel.scene.setCurrentText("Shaft")
        panel.cameras.setCurrentText("Two cameras (stereo)")
        panel.camera_scale.setValue(0.25)
        first, second = os.path.join(self.folder, "stereo_1"), os.path.join(self.folder, "stereo_2")
        panel.folder.setText(first)
        panel.second_folder.setText(second)
        panel.source.setCurrentText("Camera + projector")  # two real cameras are `picoscan capture`'s
        self.assertFalse(panel.accept())
        self.assertEqual(len(self.messages), 1)
        self.assertIn("Cameras: this panel captures with one camera", self.messages[0][2])
        self.assertFalse(os.path.exists(second))
        self.messages.clear()
        panel.source.setCurrentText("Simulate")
        self.assertTrue(panel.accept(), self.messages)
        view = panel.created
        self.assertEqual((view.CaptureFolder, view.SecondCaptureFolder), (first, second))
        self.assertGreater(view.PointCount, 50000)  # the shaft and the wall, of 120 000 pixels
        self.assertIn("left-right consistency", view.StereoReport)
        # Import: the folder holds stereo.yml, so the command asks for the second camera's folder.
        answers = [first, os.path.join(self.folder, "no_second_camera")]
        QtWidgets.QFileDialog.getExistingDirectory = lambda *args, **kwargs: answers.pop(0)
        before = self.object_names()
        FreeCADGui.runCommand("PicoScan_ImportCaptures")
        process_events()
        self.assertEqual(len(self.messages), 1)
        self.assertIn("no_second_camera: second capture folder does not exist", self.messages[0][2])
        self.assertEqual(self.object_names(), before)
        answers = [first, second]
        FreeCADGui.runCommand("PicoScan_ImportCaptures")
        process_events()
        self.assertEqual(len(self.messages), 1, self.messages)
        added = [self.doc.getObject(name) for name in self.object_names() if name not in before]
        self.assertEqual(len(added), 1)
        self.assertEqual(added[0].SecondCaptureFolder, second)
        self.assertEqual(added[0].PointCount, view.PointCount)
        # SecondCaptureFolder cleared in the GUI: the object is refused in one line, no traceback in the Report view.
        report = FreeCADGui.getMainWindow().findChild(QtWidgets.QTextEdit, "Report view")
        shown = len(report.toPlainText())
        added[0].SecondCaptureFolder = ""
        self.doc.recompute()
        process_events()
        self.assertFalse(added[0].isValid())
        new_lines = report.toPlainText()[shown:]
        self.assertIn("SecondCaptureFolder: %s is a stereo calibration" % added[0].CalibrationFile, new_lines)
        self.assertNotIn("Traceback", new_lines)
        self.assertNotIn('File "', new_lines)
        # Both cameras of the stereo calibration with the scan, for docs/freecad.md.
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(view)
        FreeCADGui.runCommand("PicoScan_ShowRig")
        process_events()
        self.assertIsNotNone(self.doc.getObject("SecondCameraFrustum"), self.messages)
        self.doc.removeObject(added[0].Name)
        mesh = scan_mesh.create(self.doc, view, pixel_step=1)  # shaded, so the shaft stands out from the wall
        self.assertGreater(mesh.Mesh.CountFacets, 50000)
        view.ViewObject.Visibility = False
        # Seen from behind the cameras (their y points down), turned to show the depth.
        behind_cameras = FreeCAD.Rotation(FreeCAD.Vector(0, 1, 0), 35).multiply(FreeCAD.Rotation(FreeCAD.Vector(1, 0, 0), 160))
        self.screenshot(self.doc.getObject("Rig"), "freecad-stereo.png", orientation=behind_cameras)

    def test_g_cancelled_scan_shows_message(self):
        before = self.object_names()
        FreeCADGui.runCommand("PicoScan_Scan")
        process_events()
        panel = COMMANDS["PicoScan_Scan"].panel
        panel.folder.setText(os.path.join(self.folder, "cancelled"))
        panel.should_cancel = lambda: True  # as if the user pressed Stop at once
        self.assertFalse(panel.accept())
        self.assertEqual(len(self.messages), 1)
        self.assertIn("cancelled", self.messages[0][2])
        self.assertEqual(self.object_names(), before)

    def test_h_encoding_view_and_fit_primitives_commands(self):
        view = scan_view.create(self.doc, self.captures, self.calibration)
        FreeCADGui.Selection.addSelection(view)
        mdi = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea)
        windows_before = len(mdi.subWindowList())
        FreeCADGui.runCommand("PicoScan_EncodingView")
        process_events()
        self.assertEqual(self.messages, [])
        encoding_windows = [w for w in mdi.subWindowList() if "encoding" in w.windowTitle()]
        self.assertEqual(len(mdi.subWindowList()) - windows_before, 4)
        self.assertEqual(len(encoding_windows), 4)
        for window in encoding_windows:
            window.close()
        FreeCADGui.runCommand("PicoScan_FitPrimitives")
        process_events()
        self.assertEqual(self.messages, [])
        cylinders = [o for o in self.doc.Objects if o.TypeId == "Part::Cylinder"]
        self.assertEqual(len(cylinders), 1)
        self.assertAlmostEqual(cylinders[0].Radius.Value, 12.5, delta=0.02)
        # Undo removes what the command added, in one step.
        self.doc.undo()
        self.assertEqual([o for o in self.doc.Objects if o.TypeId == "Part::Cylinder"], [])
        self.fit_at_picked_point_panel(view)

    def fit_at_picked_point_panel(self, view):
        """Fit at picked point on the shaft (radius 12.5 mm, axis along y through x = 0, z = 400 mm, in
        the camera's frame) in front of the wall (z = 460 mm): the panel opens on a point picked
        programmatically, Cancel leaves the document as it was, OK fits with the fields set."""
        import numpy
        from picoscan_wb.taskpanels import region_fit as panel_module

        def open_panel(point):
            FreeCADGui.Selection.clearSelection()
            # FreeCAD keeps the picked point (PickedPoints) only with a sub-element name.
            FreeCADGui.Selection.addSelection(self.doc.Name, view.Name, "Point", *point)
            self.assertTrue(COMMANDS["PicoScan_FitRegion"].IsActive())
            FreeCADGui.runCommand("PicoScan_FitRegion")
            process_events()
            panel = COMMANDS["PicoScan_FitRegion"].panel
            self.assertIs(FreeCADGui.Control.activeDialog(), True)
            return panel

        def axis_error(cylinder):
            axis = cylinder.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
            angle = numpy.degrees(numpy.arccos(min(1.0, abs(axis.y))))
            base = cylinder.Placement.Base
            offset = numpy.hypot(base.x - 0.0, base.z - 400.0)  # a point on the axis, off the true axis
            return angle, offset

        started = time.monotonic()
        names, undo_count = self.object_names(), self.doc.UndoCount
        panel = open_panel((0.0, 0.0, 387.5))  # the shaft's front
        panel.update_preview()
        count = int(panel.region_count.text())
        self.assertGreater(count, 5000)
        self.assertIsNotNone(panel.preview)  # the region shown in the 3D view
        panel.set_kind("cylinder")
        panel.noise.setValue(0.02)
        self.assertEqual(panel.noise.suffix(), " mm")
        panel.snap_step.setValue(1.0)
        panel.reject()  # Cancel: nothing added, nothing to undo, no preview left
        process_events()
        self.assertEqual(self.object_names(), names)
        self.assertEqual(self.doc.UndoCount, undo_count)
        self.assertIsNone(panel.preview)
        self.assertFalse(FreeCADGui.Control.activeDialog())

        # The wall, automatic, within 10 mm of the point: a plane with its normal along z (towards the camera).
        panel = open_panel((40.0, 0.0, 460.0))
        panel.radius.setValue(10.0)
        self.assertTrue(panel.accept(), self.messages)
        wall = panel.created
        self.assertEqual(wall.TypeId, "Part::Plane", wall.FitReport)
        normal = wall.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        self.assertLess(numpy.degrees(numpy.arccos(min(1.0, abs(normal.z)))), 0.05)
        self.assertAlmostEqual(wall.Placement.Base.z, 460.0, delta=0.02)

        # The shaft: a cylinder perpendicular to the wall's normal, diameter snapped to 25 mm.
        panel = open_panel((0.0, 0.0, 387.5))
        panel.set_kind("cylinder")
        panel.noise.setValue(0.02)
        panel.set_constraint("perpendicular", wall)
        panel.snap_step.setValue(1.0)
        panel.snap_tolerance.setValue(0.1)
        self.assertTrue(panel.accept(), self.messages)
        shaft = panel.created
        fit = panel.fit
        FreeCAD.Console.PrintMessage("fit at picked point panel: shaft radius %.4f mm before snapping (truth 12.5), "
                                     "%s\n" % (fit.fitted_radius_mm, fit.report))
        self.assertEqual(shaft.TypeId, "Part::Cylinder", shaft.FitReport)
        self.assertTrue(fit.snapped, fit.report)
        self.assertAlmostEqual(shaft.Radius.Value, 12.5, places=9)
        self.assertAlmostEqual(fit.fitted_radius_mm, 12.5, delta=0.02)
        axis = shaft.Placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        self.assertLess(abs(axis.dot(normal)), 1e-9)  # the constraint holds exactly
        angle, offset = axis_error(shaft)
        self.assertLess(angle, 0.2)
        self.assertLess(offset, 0.05)
        shaft_name = shaft.Name
        self.doc.undo()  # one undo step removes it
        self.assertNotIn(shaft_name, self.object_names())

        # A lasso over the shaft's front, drawn in the 3D view looking along +z like the camera.
        FreeCADGui.Selection.clearSelection()
        panel = open_panel((0.0, 0.0, 387.5))
        view3d = FreeCADGui.ActiveDocument.ActiveView
        view3d.viewBottom()
        view3d.fitAll()
        process_events()
        # Drawn as a user does: Draw lasso, a left click at each corner, a right click to close, sent
        # as Coin mouse events through the viewer. The corners are placed with FreeCAD's own projection
        # (pixels, y up like Coin's events), which the panel's projection (from the camera's view
        # volume) must match for the fit to find the shaft.
        from pivy import coin

        panel.set_region("lasso")
        panel.draw_lasso.click()
        events = view3d.getViewer().getSoEventManager()
        corners = [view3d.getPointOnScreen(FreeCAD.Vector(x, y, 387.5)) for x, y in ((-8, -20), (8, -20), (8, 20), (-8, 20))]
        clicks = [(coin.SoMouseButtonEvent.BUTTON1, c, state) for c in corners
                  for state in (coin.SoButtonEvent.DOWN, coin.SoButtonEvent.UP)]
        for button, corner, state in clicks + [(coin.SoMouseButtonEvent.BUTTON2, corners[-1], coin.SoButtonEvent.DOWN)]:
            event = coin.SoMouseButtonEvent()
            event.setButton(button)
            event.setState(state)
            event.setPosition(coin.SbVec2s(int(corner[0]), int(corner[1])))
            events.processEvent(event)
        self.assertFalse(panel.draw_lasso.isChecked())  # the right click closed it
        self.assertEqual(len(panel.lasso), 4)
        panel.update_preview()
        lasso_count = int(panel.region_count.text())
        self.assertGreater(lasso_count, 2000)
        self.assertTrue(panel.accept(), self.messages)
        strip = panel.created
        FreeCAD.Console.PrintMessage("fit at picked point panel: lasso of %d points: radius %.4f mm (truth 12.5), %s; "
                                     "the panel's steps took %.1f s\n" % (lasso_count, strip.Radius.Value, strip.FitReport,
                                                                         time.monotonic() - started))
        self.assertEqual(strip.TypeId, "Part::Cylinder", strip.FitReport)
        self.assertAlmostEqual(strip.Radius.Value, 12.5, delta=0.05)
        angle, offset = axis_error(strip)
        self.assertLess(angle, 0.5)
        self.assertLess(offset, 0.1)

    def test_h2_stitch_panel_shows_the_views_sets_the_mode_and_adds_the_stitch(self):
        """Two half-resolution turntable views of the speckled part, 45 degrees apart: the Stitch views
        panel lists them, a known axis without a direction is refused (message, panel open, document
        unchanged), then Features aligns both off the GUI thread and the Stitch appears, one undo step."""
        scans, truth = simulate.simulate_turntable(os.path.join(self.folder, "stitch"), (0, 1), camera_scale=0.5)
        views = [scan_view.create(self.doc, folder, calibration, clean=True) for folder, calibration in scans]
        for view in views:
            view.MinModulation = 15  # the part is bright: reject its dim, grazing edges (as the headless stitch test)
        self.doc.recompute()
        for view in views:
            FreeCADGui.Selection.addSelection(view)
        FreeCADGui.runCommand("PicoScan_Stitch")
        process_events()
        panel = COMMANDS["PicoScan_Stitch"].panel
        self.assertTrue(FreeCADGui.Control.activeDialog())
        self.assertEqual(panel.found.text(), "Placement 1 (2 views): %s, %s" % (views[0].Label, views[1].Label))
        self.assertEqual(panel.mode.currentText(), "Automatic")
        self.assertFalse(panel.direction[0].isEnabled())  # the axis is for the known-axis mode only
        panel.mode.setCurrentText("Turntable axis")
        self.assertTrue(panel.direction[0].isEnabled())
        self.assertEqual(panel.point[0].suffix(), " mm")
        before, undo_before = self.object_names(), self.doc.UndoCount
        self.assertFalse(panel.accept())
        self.assertIn("TurntableAxisDirection must not be zero", self.messages[-1][2])
        self.assertEqual(self.object_names(), before)
        self.assertEqual(self.doc.UndoCount, undo_before)
        self.assertTrue(FreeCADGui.Control.activeDialog())
        self.messages.clear()
        panel.mode.setCurrentText("Features")
        self.assertTrue(panel.accept(), self.messages)
        process_events()
        made = panel.created
        self.assertEqual(made.Mode, "Features")
        self.assertEqual(made.AlignedCount, 2, made.Report)
        self.assertEqual(list(made.AlignmentReport), ["features aligned 2 of 2 views; kept"])
        error = picoscan.pose_difference(numpy.array(made.ViewPoses[1].toMatrix().A).reshape(4, 4), truth[1],
                                         numpy.array([0.0, 0.0, 400.0]))
        FreeCAD.Console.PrintMessage("Stitch panel (features, 2 half-resolution views): pose error %.4f deg, %.4f mm\n" % (
            error.rotation_deg, error.translation_mm))
        self.assertLess(error.rotation_deg, 0.1)
        self.assertLess(error.translation_mm, 0.1)
        self.assertFalse(FreeCADGui.Control.activeDialog())
        self.check_shading(made, "freecad-stitch-shaded.png")
        name = made.Name
        self.doc.undo()  # one step
        self.assertIsNone(self.doc.getObject(name))

    def check_shading(self, cloud, screenshot, tilt_deg=0.0, min_spread=40):
        """A cloud with normals (a Stitch, a ScanView) is drawn lit by them: on screen, the brightness of
        its points spreads with the orientation of the faces they lie on, where the flat look
        (FreeCAD's plain Points mode, all the workbench showed before) is one grey. Seen as the first
        camera saw it, turned by tilt_deg about its x axis; the figures go to the Report view and the
        view to `screenshot`."""
        from picoscan_wb.property_content import normals_from_content

        normals = normals_from_content(cloud.dumpPropertyContent("Normal", Compression=0))
        self.assertEqual(len(normals), cloud.PointCount)
        unit = numpy.abs(numpy.linalg.norm(normals, axis=1) - 1) < 1e-3  # False for NaN
        self.assertGreater(unit.mean(), 0.999, "normals not of unit length")
        self.assertEqual(cloud.ViewObject.DisplayMode, "Shaded")
        FreeCADGui.Selection.clearSelection()
        view3d = FreeCADGui.ActiveDocument.ActiveView
        # Seen as the (first) camera saw it (its x right, y down, looking along its z), so the faces
        # in sight are those scanned, turned to the viewer: their brightness is their angle.
        view3d.setCameraOrientation(cloud.Placement.Rotation.multiply(FreeCAD.Rotation(FreeCAD.Vector(1, 0, 0), 180 + tilt_deg)))
        view3d.fitAll()

        def brightness(mode):
            cloud.ViewObject.Visibility = False
            background = self.grab_3d_view().astype(int)
            cloud.ViewObject.Visibility = True
            cloud.ViewObject.DisplayMode = mode
            image = self.grab_3d_view().astype(int)
            drawn = numpy.abs(image - background).max(axis=2) > 30
            self.assertGreater(drawn.sum(), 2000, mode)
            return image[drawn].mean(axis=1)

        flat, shaded = brightness("Points"), brightness("Shaded")
        spread = lambda values: numpy.percentile(values, 90) - numpy.percentile(values, 10)  # noqa: E731
        FreeCAD.Console.PrintMessage("%s on screen: brightness p10-p90 spread %.1f grey levels shaded (%d pixels), "
                                     "%.1f flat (%d pixels)\n" % (cloud.Label, spread(shaded), len(shaded),
                                                                   spread(flat), len(flat)))
        self.assertLess(spread(flat), 5)
        self.assertGreater(spread(shaded), min_spread)
        self.screenshot(cloud, screenshot, orientation=view3d.getCameraOrientation())

    @unittest.skipUnless(os.environ.get("PICOSCAN_CLI"), "PICOSCAN_CLI (the built picoscan command) not set")
    def test_i_scan_through_picoscan_capture_with_the_virtual_camera(self):
        calibration = os.path.join(self.folder, "seed_rig.yml")
        picoscan.write_calibration(picoscan.seed_rig_calibration(), calibration)
        FreeCADGui.runCommand("PicoScan_Scan")
        process_events()
        panel = COMMANDS["PicoScan_Scan"].panel
        panel.source.setCurrentText("Camera + projector")
        panel.camera.setText("virtual")
        panel.projector_screen.setValue(-1)
        panel.calibration.setText(os.path.join(self.folder, "no_such_rig.yml"))
        panel.folder.setText(os.path.join(self.folder, "captured"))
        before = self.object_names()
        self.assertFalse(panel.accept())
        self.assertIn("no_such_rig.yml: calibration file does not exist", self.messages[0][2])
        self.assertEqual(self.object_names(), before)
        panel.calibration.setText(calibration)
        self.assertTrue(panel.accept(), self.messages)
        self.assertEqual(len(self.messages), 1)
        self.assertGreater(panel.created.PointCount, 400000)
        self.assertEqual(panel.created.CaptureFolder, os.path.join(self.folder, "captured"))
        # The scan is one undo step.
        name = panel.created.Name
        self.doc.undo()
        self.assertIsNone(self.doc.getObject(name))

    def test_j_deviation_map_command_colours_the_scan(self):
        view = scan_view.create(self.doc, self.captures, self.calibration)
        model = self.doc.addObject("Part::Cylinder", "ShaftModel")
        model.Radius = 12.5
        model.Height = 80
        model.Placement = FreeCAD.Placement(FreeCAD.Vector(0, -40, 400),
                                            FreeCAD.Rotation(FreeCAD.Vector(0, 0, 1), FreeCAD.Vector(0, 1, 0)))
        self.doc.recompute()
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(model)
        self.assertFalse(COMMANDS["PicoScan_DeviationMap"].IsActive())  # the scan comes first
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(view)
        FreeCADGui.Selection.addSelection(model)
        self.assertTrue(COMMANDS["PicoScan_DeviationMap"].IsActive())
        FreeCADGui.runCommand("PicoScan_DeviationMap")
        process_events()
        self.assertEqual(self.messages, [])
        maps = [o for o in self.doc.Objects if getattr(getattr(o, "Proxy", None), "Type", "") == "PicoScan::DeviationMap"]
        self.assertEqual(len(maps), 1)
        result = maps[0]
        self.assertEqual(result.ViewObject.DisplayMode, "Color")
        self.assertIn("Color", result.ViewObject.listDisplayModes())
        # No MaxDistance by default: the wall behind the shaft (47 mm away) is measured too.
        self.assertGreater(result.MaxDeviation.Value, 40)
        self.assertEqual(result.PointCount, view.PointCount)
        self.assertEqual(len(result.Color), view.PointCount)
        mdi = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea)
        self.assertTrue(any("png" in w.windowTitle() or "vs" in w.windowTitle() for w in mdi.subWindowList()),
                        [w.windowTitle() for w in mdi.subWindowList()])
        self.screenshot(result, "freecad-deviation.png", report=result.ReportFile + ".png")
        self.check_legend(result)
        # One undo step removes the map.
        name = result.Name
        self.doc.undo()
        self.assertIsNone(self.doc.getObject(name))
        # Best fit of a shaft alone to its cylinder cannot fix the slide along the axis: a message.
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(view)
        FreeCADGui.Selection.addSelection(model)
        self.assertTrue(COMMANDS["PicoScan_BestFit"].IsActive())
        FreeCADGui.runCommand("PicoScan_BestFit")
        process_events()
        self.assertEqual(len(self.messages), 1)
        self.assertIn("do not fix all six degrees of freedom", self.messages[0][2])
        self.assertTrue(view.Placement.isIdentity())
        self.messages.clear()
        # A reference with no surface: a message, nothing added.
        FreeCADGui.Selection.clearSelection()
        cloud = self.doc.addObject("Points::Feature", "JustPoints")
        before = self.object_names()
        FreeCADGui.Selection.addSelection(view)
        FreeCADGui.Selection.addSelection(cloud)
        COMMANDS["PicoScan_DeviationMap"].Activated()
        process_events()
        self.assertEqual(len(self.messages), 1)
        self.assertIn("JustPoints: the reference has no faces or triangles", self.messages[0][2])
        self.assertEqual(self.object_names(), before)

    def check_legend(self, result):
        """The map's colour legend in the 3D view: labelled with the map's tolerance and range, its
        bar's pixels (on screen, in any orientation) in the map's own colours at its ends and in the
        tolerance band; gone when the map is hidden; following a recompute with a new tolerance."""
        from picoscan_wb.viewproviders import deviation_legend as legend

        def pixel(image, distance, range_mm):  # the bar's middle at that distance's height
            height, width = image.shape[:2]
            column, row = legend.viewport_pixel(0.5 * (legend.BAR_LEFT + legend.BAR_RIGHT),
                                                legend.bar_y(distance, range_mm), width, height)
            return image[row, column].astype(int)

        def check_bar(image, tolerance, range_mm):
            for fraction in (-0.95, -0.6, 0.0, 0.6, 0.95):  # both ends, the band, between
                expected = numpy.array(picoscan.deviation_colour(fraction * range_mm, tolerance, range_mm))
                seen = pixel(image, fraction * range_mm, range_mm)
                self.assertLess(numpy.abs(seen - expected).max(), 12, (fraction, seen, expected))

        self.assertAlmostEqual(result.ColourRange.Value, 4 * result.Tolerance.Value, places=9)  # the core's range
        labels = result.ViewObject.Proxy.legend.labels
        FreeCAD.Console.PrintMessage("deviation legend: %s\n" % labels)
        self.assertEqual(labels, ["+0.200", "+0.050", "0", "-0.050", "-0.200"])
        view3d = FreeCADGui.ActiveDocument.ActiveView
        view3d.setCameraOrientation(FreeCAD.Rotation(FreeCAD.Vector(1, 0.35, 0), 215))
        view3d.fitAll()
        check_bar(self.grab_3d_view(), 0.05, 0.2)
        view3d.setCameraOrientation(FreeCAD.Rotation(FreeCAD.Vector(0, 1, 0), 60))  # turned: the legend stays
        check_bar(self.grab_3d_view(), 0.05, 0.2)
        result.ViewObject.Visibility = False
        hidden = self.grab_3d_view()
        for fraction in (-0.95, 0.0, 0.95):
            expected = numpy.array(picoscan.deviation_colour(fraction * 0.2, 0.05, 0.2))
            self.assertGreater(numpy.abs(pixel(hidden, fraction * 0.2, 0.2) - expected).max(), 40, fraction)
        result.ViewObject.Visibility = True
        result.Tolerance = 0.1  # recompute: the range follows (0.4 mm)
        self.doc.recompute()
        self.assertEqual(result.ViewObject.Proxy.legend.labels, ["+0.400", "+0.100", "0", "-0.100", "-0.400"])
        check_bar(self.grab_3d_view(), 0.1, 0.4)

    def test_j3_legend_and_shaded_points_after_save_and_reopen(self):
        """A saved document reopened: the Deviation map's legend is there again with its labels and
        colours, and a Stitch's cloud is drawn Shaded (FreeCAD builds that mode when the view
        provider is attached; the object must have its Normal property by then)."""
        from picoscan_wb import property_content
        from picoscan_wb.objects import deviation_map, stitch
        from picoscan_wb.viewproviders import deviation_legend as legend
        from picoscan_wb.viewproviders.view_provider import ShadedPointsViewProvider

        # Half a cylinder of radius 12.5 mm, its points up to 0.3 mm off, against the true cylinder.
        angle, height = numpy.meshgrid(numpy.linspace(0, math.pi, 120), numpy.linspace(1, 39, 60))
        radius = 12.5 + numpy.linspace(-0.3, 0.3, angle.size).reshape(angle.shape)
        points = numpy.stack([radius * numpy.cos(angle), radius * numpy.sin(angle), height], axis=-1).reshape(-1, 3)
        normals = numpy.stack([numpy.cos(angle), numpy.sin(angle), 0 * angle], axis=-1).reshape(-1, 3)
        cloud = self.doc.addObject("Points::Feature", "HalfShaft")
        cloud.Points = scan_view.points_of(points)
        model = self.doc.addObject("Part::Cylinder", "Model")
        model.Radius, model.Height = 12.5, 40
        self.doc.recompute()
        result = deviation_map.create(self.doc, cloud, model)
        shaded = self.doc.addObject("Points::FeaturePython", "StitchLike")
        stitch.Stitch(shaded)  # its properties, Normal among them, before its view provider
        ShadedPointsViewProvider(shaded.ViewObject, "picoscan_stitch")
        shaded.Points = scan_view.points_of(points)
        shaded.restorePropertyContent("Normal", property_content.normal_list_content(normals))
        shaded.ViewObject.DisplayMode = "Shaded"
        shaded.purgeTouched()
        path = os.path.join(self.folder, "reopened.FCStd")
        self.doc.saveAs(path)
        names = (result.Name, shaded.Name)
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(path)
        result, shaded = (self.doc.getObject(name) for name in names)
        self.assertEqual(result.ViewObject.Proxy.legend.labels, ["+0.200", "+0.050", "0", "-0.050", "-0.200"])
        image = self.grab_3d_view()
        height, width = image.shape[:2]
        for distance in (-0.19, 0.0, 0.19):
            column, row = legend.viewport_pixel(0.5 * (legend.BAR_LEFT + legend.BAR_RIGHT), legend.bar_y(distance, 0.2),
                                                width, height)
            expected = numpy.array(picoscan.deviation_colour(distance, 0.05, 0.2))
            self.assertLess(numpy.abs(image[row, column].astype(int) - expected).max(), 12, distance)
        self.assertIn("Shaded", shaded.ViewObject.listDisplayModes())
        self.assertEqual(shaded.ViewObject.DisplayMode, "Shaded")

    def test_j4_scan_view_saved_before_it_was_drawn_lit_is_lit_when_reopened(self):
        """A ScanView saved before views were drawn lit by their normals (no Normal property, the plain
        view provider, DisplayMode Points) is drawn lit when reopened, and opening it leaves the
        document unmodified and the view not touched."""
        from picoscan_wb.viewproviders.view_provider import ViewProvider

        view = scan_view.create(self.doc, self.captures, self.calibration)
        view.removeProperty("Normal")
        ViewProvider(view.ViewObject, "picoscan_scan")  # the view provider those documents saved
        view.ViewObject.DisplayMode = "Points"
        view.purgeTouched()  # removing a property touches the view; such documents were saved recomputed
        path = os.path.join(self.folder, "saved_before_lit_views.FCStd")
        self.doc.saveAs(path)
        name = view.Name
        FreeCAD.closeDocument(self.doc.Name)
        self.doc = FreeCAD.openDocument(path)
        view = self.doc.getObject(name)
        self.assertFalse(FreeCADGui.getDocument(self.doc.Name).Modified)
        self.assertNotIn("Touched", view.State)
        self.assertEqual(view.ViewObject.listDisplayModes().count("Shaded"), 1)
        # The shaft turned 30 degrees: 12 grey levels p10-p90 as a new view, the same reopened, 0 flat.
        self.check_shading(view, "freecad-scanview-reopened-shaded.png", tilt_deg=30, min_spread=8)

    def test_j2_datum_alignment_command_moves_a_model_into_its_part_frame(self):
        """Three faces of a turned box picked in the 3D view (bottom, back, left): the box's corner goes
        to the origin with its edges along the axes, as one undo step; parallel faces give a message."""
        model = self.doc.addObject("Part::Box", "TurnedBox")
        model.Length, model.Width, model.Height = 50, 36, 24
        turned = FreeCAD.Placement(FreeCAD.Vector(20, -35, 400), FreeCAD.Rotation(FreeCAD.Vector(1, -2, 0.5), 30))
        model.Placement = turned
        self.doc.recompute()

        def face(outward):  # the box's face whose outward normal is `outward` in its own frame
            for index, candidate in enumerate(model.Shape.Faces):
                normal = turned.Rotation.inverted().multVec(candidate.normalAt(0, 0))
                if normal.dot(FreeCAD.Vector(*outward)) > 0.999:
                    return "Face%d" % (index + 1)

        FreeCADGui.Selection.clearSelection()
        for outward in ((0, 0, -1), (0, -1, 0), (-1, 0, 0)):
            FreeCADGui.Selection.addSelection(model, face(outward))
        self.assertTrue(COMMANDS["PicoScan_DatumAlign"].IsActive())
        FreeCADGui.runCommand("PicoScan_DatumAlign")
        process_events()
        self.assertEqual(self.messages, [])
        box = model.Shape.BoundBox
        for value, expected in ((box.XMin, 0), (box.YMin, 0), (box.ZMin, 0), (box.XMax, 50), (box.YMax, 36), (box.ZMax, 24)):
            self.assertAlmostEqual(value, expected, delta=1e-6)
        self.doc.undo()
        self.assertLess((model.Placement.Base - turned.Base).Length, 1e-9)  # one undo step
        self.assertLess(abs(model.Placement.Rotation.Angle - turned.Rotation.Angle), 1e-9)
        FreeCADGui.Selection.clearSelection()
        for outward in ((0, 0, -1), (0, 0, 1), (-1, 0, 0)):
            FreeCADGui.Selection.addSelection(model, face(outward))
        FreeCADGui.runCommand("PicoScan_DatumAlign")
        process_events()
        self.assertEqual(len(self.messages), 1)
        self.assertIn("degrees from parallel to the primary plane", self.messages[0][2])
        self.assertNotIn("Traceback", self.messages[0][2])
        self.assertLess((model.Placement.Base - turned.Base).Length, 1e-9)

    def screenshot(self, shown, name, report=None, orientation=FreeCAD.Rotation(FreeCAD.Vector(1, 0.35, 0), 215)):
        """The 3D view on `shown`, saved beside PICOSCAN_SCREENSHOT as `name` (and the report picture)."""
        path = os.environ.get("PICOSCAN_SCREENSHOT")
        if not path:
            return
        folder = os.path.dirname(path)
        os.makedirs(folder, exist_ok=True)
        FreeCADGui.getMainWindow().showMaximized()
        mdi = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea)
        for window in mdi.subWindowList():
            if window.windowTitle().startswith(self.doc.Label):
                mdi.setActiveSubWindow(window)
        process_events()
        view3d = FreeCADGui.ActiveDocument.ActiveView
        view3d.setCameraOrientation(orientation)
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(shown)
        FreeCADGui.SendMsgToActiveView("ViewSelection")
        FreeCADGui.Selection.clearSelection()
        for _ in range(5):
            process_events()
        temporary = os.path.join(folder, name + ".tmp.png")
        subprocess.run(["import", "-window", "root", temporary], check=True)
        os.replace(temporary, os.path.join(folder, name))
        if report:
            shutil.copyfile(report, os.path.join(folder, "deviation-histogram.png"))

    def grab_3d_view(self, width=1000, height=700):
        """The document's 3D view as FreeCAD draws it, through its own Save picture (saveImage, the
        view's scene and camera, background as shown): H x W x 3 uint8 RGB. (A grab of the screen
        under Xvfb shows the view cut: with no window manager FreeCAD's window is larger than the
        screen, and Coin's viewport larger than the widget, so its pixels cannot be located.)"""
        from PySide2 import QtGui

        mdi = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea)
        for window in mdi.subWindowList():
            if window.windowTitle().startswith(self.doc.Label):
                mdi.setActiveSubWindow(window)
        process_events()
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "view.png")
            FreeCADGui.ActiveDocument.ActiveView.saveImage(path, width, height, "Current")
            image = QtGui.QImage(path).convertToFormat(QtGui.QImage.Format_RGB888)
        rows = numpy.frombuffer(image.constBits(), dtype=numpy.uint8, count=image.bytesPerLine() * height)
        return rows.reshape(height, image.bytesPerLine())[:, :3 * width].reshape(height, width, 3).copy()

    def cancel_after(self, seconds, record, fraction=0.05, stage=None):
        """Presses Cancel on the progress dialog (the user's click) once it shows and, given `stage`,
        once its label ends with that stage: `seconds` later, or earlier once the dialog shows
        `fraction` done (None: by time only). A faster machine (more cores) may end the whole work
        before a fixed time, a loaded one may show the dialog late. record["stage seen"] is when the
        stage showed; record["poller"] must be stopped when the work has ended."""
        from PySide2 import QtCore

        started = time.monotonic()
        poller = QtCore.QTimer()

        def press():
            shown = [d for d in FreeCADGui.getMainWindow().findChildren(QtWidgets.QProgressDialog, "PicoScanProgress")
                     if d.isVisible()]
            if not shown:
                return
            now = time.monotonic()
            if stage is not None:
                if "stage seen" not in record and shown[0].labelText().endswith(stage):
                    record["stage seen"] = now
                if "stage seen" not in record:
                    return
            since = record.get("stage seen", started)
            if now - since < seconds and (fraction is None or shown[0].value() < 1000 * fraction):
                return
            poller.stop()
            record["pressed"] = now
            record["fraction"] = shown[0].value() / 1000.0
            record["label"] = shown[0].labelText()
            shown[0].findChildren(QtWidgets.QPushButton)[0].click()  # the Cancel button, as the user would
        poller.timeout.connect(press)
        poller.start(10)
        record["poller"] = poller

    def test_k_long_work_keeps_the_gui_responsive_and_cancels_within_a_second(self):
        from picoscan_wb.progress import run_in_background

        # A real long core call with fine-grained progress: the deviation of 4 M points on the demo
        # part from its mesh (about 8192 points between two progress reports).
        part = picoscan.mechanical_part()
        vertices, faces = numpy.array(part.vertices), numpy.array(part.faces)
        rng = numpy.random.default_rng(3)
        chosen = faces[rng.integers(0, len(faces), 4000000)]
        u, v = rng.random((2, len(chosen), 1))
        flip = (u + v) > 1
        u, v = numpy.where(flip, 1 - u, u), numpy.where(flip, 1 - v, v)
        a, b, c = vertices[chosen[:, 0]], vertices[chosen[:, 1]], vertices[chosen[:, 2]]
        points = (a + u * (b - a) + v * (c - a)).astype(numpy.float32)

        def measure():
            with self.assertRaisesRegex(picoscan.Error, "cancelled"):
                run_in_background("Measuring", lambda progress: picoscan.measure_deviation(
                    points, part, picoscan.DeviationOptions(), progress))
        # Cancel 1 s into the queries, or once half of them are done (about 3 s on an idle 2-core
        # machine; a machine with more cores may be through them in less than a second).
        record = {}
        self.cancel_after(1.0, record, fraction=0.5, stage="deviation")
        try:
            started, ended, times, _, _ = self.gui_ticks_while(measure)
        finally:
            record["poller"].stop()
        self.assertIn("pressed", record, "the progress dialog never showed the queries")
        # The GUI while the core works: from when the queries showed to the end (the dialog's first
        # showing is not the work measured).
        since = record["stage seen"]
        window = times[times >= since]
        gaps = numpy.diff(numpy.concatenate([[since], window, [ended]]))
        FreeCAD.Console.PrintMessage(
            "GUI during the queries: %d timer events (every 20 ms) in %.2f s, longest gap %.3f s; Cancel at progress "
            "%.2f took %.3f s (%.2f s in all)\n" % (len(window), ended - since, gaps.max(), record["fraction"],
                                                   ended - record["pressed"], ended - started))
        # A blocked GUI thread would show one gap as long as the work. The bounds leave room for a
        # machine shared with other builds (at load 10: 34 events a second, longest gap 0.6 s).
        self.assertGreater(len(window), 10 * (ended - since))
        self.assertLess(gaps.max(), 2.0)
        self.assertLess(ended - record["pressed"], 3.0)

    # The Poisson mesh of the shaft's ScanView (462 613 points) at this spacing runs for minutes on
    # the shared 2-core machine (benchmarks/poisson_cancel.py; docs/freecad.md has the figures).
    LONG_POISSON_SPACING_MM = 2.0
    # The core's Poisson stages after the points are triangulated, each of which can be cancelled.
    RECONSTRUCTION_STAGES = ("refining the triangulation", "assembling the system", "solving the implicit function",
                             "meshing the surface")

    def test_k2_long_poisson_answers_events_and_cancel_leaves_the_document_as_it_was(self):
        """The issue's target: while a long Poisson runs from the Mesh panel, a 50 ms GUI timer keeps
        firing for 30 s; Cancel, pressed then (in CGAL's Delaunay refinement, which reports through
        the core's geometric traits, or a later stage), stops it within 1 s, and the document is as
        it was."""
        from PySide2 import QtCore

        view = scan_view.create(self.doc, self.captures, self.calibration, name="BigView")
        self.doc.recompute()
        before = self.object_names()
        undo_before = self.doc.UndoCount
        points_before = view.PointCount
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(view)
        FreeCADGui.runCommand("PicoScan_Mesh")
        process_events()
        panel = COMMANDS["PicoScan_Mesh"].panel
        panel.method.setCurrentText("Poisson")
        panel.sample_spacing.setValue(self.LONG_POISSON_SPACING_MM)
        panel.target_faces.setValue(0)
        ticks, record = [], {"stages": []}
        timer = QtCore.QTimer()
        timer.timeout.connect(lambda: ticks.append(time.monotonic()))
        timer.start(50)
        started = time.monotonic()

        def watch():
            # The user watches the dialog and presses Cancel 30 s into the work (the 30 s
            # computation), provided the reconstruction proper has started; at 240 s in any case.
            shown = [d for d in FreeCADGui.getMainWindow().findChildren(QtWidgets.QProgressDialog, "PicoScanProgress")
                     if d.isVisible()]
            if not shown or "pressed" in record:
                return
            label = shown[0].labelText()
            if not record["stages"] or record["stages"][-1][0] != label:
                record["stages"].append((label, time.monotonic()))
            reconstructing = [t for text, t in record["stages"] if any(stage in text for stage in self.RECONSTRUCTION_STAGES)]
            if (reconstructing and time.monotonic() - started > 30) or time.monotonic() - started > 240:
                record["pressed"] = time.monotonic()
                record["label"] = label
                record["fraction"] = shown[0].value() / 1000.0
                shown[0].findChildren(QtWidgets.QPushButton)[0].click()  # the Cancel button, as the user would
        watcher = QtCore.QTimer()
        watcher.timeout.connect(watch)
        watcher.start(50)
        try:
            accepted = panel.accept()
        finally:
            ended = time.monotonic()
            timer.stop()
            watcher.stop()
        process_events()
        self.assertIn("pressed", record, "the progress dialog never showed")
        during = [t for t in ticks if started <= t <= ended]
        gaps = numpy.diff(during)
        FreeCAD.Console.PrintMessage(
            "Poisson from the Mesh panel: %d timer events (every 50 ms) in %.2f s, longest gap %.3f s; Cancel at %.1f s "
            "in '%s' (progress %.2f), stopped %.3f s later; stages: %s\n" % (
                len(during), ended - started, gaps.max(), record["pressed"] - started, record["label"], record["fraction"],
                ended - record["pressed"], ", ".join("%s at %.1f s" % (text.split(": ", 1)[-1], t - started)
                                                     for text, t in record["stages"])))
        self.assertFalse(accepted)
        self.assertTrue(any(stage in record["label"] for stage in self.RECONSTRUCTION_STAGES), record["label"])
        self.assertTrue(any("cancelled" in text for _, _, text in self.messages), self.messages)
        self.assertLess(ended - record["pressed"], 1.0)
        # Events kept coming: a blocked GUI thread shows one gap as long as the computation.
        self.assertGreater(len(during), 0.5 * (ended - started) / 0.05)
        self.assertLess(gaps.max(), 1.0)
        # The document as it was: the same objects, nothing to undo, the view untouched.
        self.assertEqual(self.object_names(), before)
        self.assertEqual(self.doc.UndoCount, undo_before)
        self.assertEqual(view.PointCount, points_before)
        self.assertTrue(view.isValid())
        self.assertTrue(FreeCADGui.Control.activeDialog())  # the panel stays open for another try

    def document_state(self):
        """What Cancel must leave as it was: the objects, their recompute state, the undo stack."""
        return ([(o.Name, tuple(sorted(o.State))) for o in self.doc.Objects], self.doc.UndoCount)

    def gui_ticks_while(self, work):
        """Runs work() while a 20 ms GUI timer records when it fires and what the progress dialog
        says then. Returns (started, ended, tick times, gaps between them from start to end, the
        dialog's label at the start of each gap)."""
        from PySide2 import QtCore

        ticks = []

        def tick():
            shown = [d.labelText() for d in FreeCADGui.getMainWindow().findChildren(
                QtWidgets.QProgressDialog, "PicoScanProgress") if d.isVisible()]
            ticks.append((time.monotonic(), shown[0] if shown else ""))
        timer = QtCore.QTimer()
        timer.timeout.connect(tick)
        timer.start(20)
        started = time.monotonic()
        try:
            work()
        finally:
            ended = time.monotonic()
            timer.stop()
        process_events()
        during = [(t, label) for t, label in ticks if started <= t <= ended]
        times = numpy.array([t for t, _ in during])
        gaps = numpy.diff(numpy.concatenate([[started], times, [ended]]))
        return started, ended, times, gaps, [""] + [label for _, label in during]

    def cancelled_while_the_gui_answers(self, name, start, cancel_after_s, max_cancel_s=1.0, stage=None):
        """Runs start() (a command on the current selection, a panel's OK), presses Cancel on its
        progress dialog (cancel_after: after cancel_after_s or at 5 % done; given `stage`,
        cancel_after_s after its label first ends with that stage) while a 20 ms timer measures how
        the GUI answers; asserts that the work stopped within max_cancel_s with a "cancelled"
        message and left the document as it was. Returns the figures as a line."""

        for _ in range(3):  # what is pending (a new object drawn, a panel laid out) is not the work measured
            process_events()
        before = self.document_state()
        record = {}
        self.cancel_after(cancel_after_s, record, fraction=None if stage else 0.05, stage=stage)
        try:
            started, ended, during, gaps, labels = self.gui_ticks_while(start)
        finally:
            record["poller"].stop()
        self.assertIn("pressed", record, "%s: the progress dialog was not shown" % name)
        figures = ("%s: %d timer events (every 20 ms) in %.2f s, longest gap %.3f s (after '%s'); Cancel at %.2f s "
                   "(progress %.2f, '%s') stopped it %.3f s later" % (
                       name, len(during), ended - started, gaps.max(), labels[gaps.argmax()], record["pressed"] - started,
                       record["fraction"], record["label"], ended - record["pressed"]))
        FreeCAD.Console.PrintMessage(figures + "\n")
        self.assertTrue(any("cancelled" in text for _, _, text in self.messages), (name, self.messages))
        self.assertLess(ended - record["pressed"], max_cancel_s, figures)
        # A blocked GUI thread shows one gap as long as the work; a GUI that answers, none above a second.
        self.assertLess(gaps.max(), 1.0, figures)
        self.assertGreaterEqual(len(during), int(ended - started), figures)
        self.assertEqual(self.document_state(), before)
        return figures

    def sphere_mesh(self, name, subdivisions):
        import Mesh

        sphere = self.doc.addObject("Mesh::Feature", name)
        sphere.Mesh = Mesh.createSphere(10.0, subdivisions)
        sphere.ViewObject.Visibility = False  # drawing it (seconds under Xvfb's software GL) is not the work measured
        self.doc.recompute()
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(sphere)
        return sphere

    def test_k3_make_solid_answers_events_and_cancel_leaves_the_document_as_it_was(self):
        """Make solid of a 64 440-facet sphere (the core's face building and simplification take
        seconds) runs off the GUI thread; Cancel stops it. Then a 7 080-facet sphere, cancelled while
        OpenCASCADE checks its solid (isValid, seconds) in another process: FreeCAD's Part calls hold
        Python's GIL, so in the GUI's process they would freeze it, and nothing could stop them."""
        self.sphere_mesh("BigSphere", 180)
        self.cancelled_while_the_gui_answers("Make solid", lambda: FreeCADGui.runCommand("PicoScan_MakeSolid"), 1.0)
        self.sphere_mesh("CheckedSphere", 60)
        self.cancelled_while_the_gui_answers("Make solid, in OpenCASCADE's check", lambda: FreeCADGui.runCommand(
            "PicoScan_MakeSolid"), 0.0, stage="OpenCASCADE's check (checked in another process)")
        self.assertEqual([o for o in self.doc.Objects if o.TypeId == "Part::Feature"], [])

    def drawn_triangles(self, feature):
        """(triangles, faces) in the face set FreeCAD's view provider drew for a Part feature."""
        from pivy import coin

        search = coin.SoSearchAction()
        search.setType(coin.SoType.fromName("SoBrepFaceSet"))
        search.setInterest(coin.SoSearchAction.ALL)
        search.apply(feature.ViewObject.RootNode)
        face_sets = [search.getPaths()[i].getTail() for i in range(search.getPaths().getLength())]
        self.assertEqual(len(face_sets), 1)
        return face_sets[0].coordIndex.getNum() // 4, face_sets[0].partIndex.getNum()  # a triangle: 3 corners, -1

    def test_k3b_make_solid_to_the_end_answers_events_but_while_freecad_draws_it(self):
        """Make solid of a 21 424-facet sphere to the end: its curved facets simplified into about a
        tenth as many faces (within 4 x the noise estimated from the mesh), so FreeCAD's view
        provider, which runs OpenCASCADE's mesher on every face and edge on the GUI thread (nothing
        can move or stop it), draws it in a fraction of the time it took for 20 000 faces (15 s
        held at load 20, docs/benchmarks.md). The GUI answers events throughout (no gap of a
        second) except while FreeCAD reads the B-rep (FreeCAD's Part read holds Python's GIL) and
        draws the solid; the progress dialog says so meanwhile. FreeCAD draws exactly the B-rep's
        facets. One undo step. The sphere's subdivisions come from PICOSCAN_GUI_SOLID_SUBDIVISIONS
        (default 104; 60 gives 7 080 facets, 112 gives 24 864, docs/freecad.md)."""
        subdivisions = int(os.environ.get("PICOSCAN_GUI_SOLID_SUBDIVISIONS", "104"))
        self.sphere_mesh("DrawnSphere", subdivisions)
        for _ in range(3):
            process_events()
        undo_before = self.doc.UndoCount
        facets = self.doc.getObject("DrawnSphere").Mesh.CountFacets
        started, ended, _, gaps, labels = self.gui_ticks_while(lambda: FreeCADGui.runCommand("PicoScan_MakeSolid"))
        self.assertEqual(self.messages, [])
        solids = [o for o in self.doc.Objects if o.TypeId == "Part::Feature"]
        self.assertEqual(len(solids), 1)
        self.assertEqual(solids[0].Shape.ShapeType, "Solid")
        faces = len(solids[0].Shape.Faces)
        self.assertLess(faces, facets / 5)  # the curved facets simplified
        self.assertAlmostEqual(solids[0].Shape.Volume, self.doc.getObject("DrawnSphere").Mesh.Volume,
                               delta=1e-3 * self.doc.getObject("DrawnSphere").Mesh.Volume)
        brep_facets = int(re.search(r" faces from (\d+) facets", solids[0].SolidReport).group(1))
        self.assertEqual(self.doc.UndoCount, undo_before + 1)
        drawn, parts = self.drawn_triangles(solids[0])
        drawing = numpy.array(["Drawing" in label for label in labels])
        reading = numpy.array(["reading the B-rep" in label for label in labels])
        self.assertTrue(drawing.any(), "the dialog never said it was drawing")
        self.assertTrue(reading.any(), "the dialog never said it was reading the B-rep")
        computing = ~(drawing | reading)
        figures = ("Make solid to the end (%d facets, %d faces): %.2f s; longest gap %.3f s while computing (after '%s'), "
                   "%.3f s while FreeCAD reads the B-rep, %.3f s while it draws the solid (%d triangles); load average "
                   "%.1f" % (facets, faces, ended - started, gaps[computing].max(),
                             labels[int(numpy.argmax(numpy.where(computing, gaps, 0)))], gaps[reading].max(),
                             gaps[drawing].max(), drawn, os.getloadavg()[0]))
        FreeCAD.Console.PrintMessage(figures + "\n")
        self.assertEqual((drawn, parts), (brep_facets, faces), figures)  # the faces' own facets, not meshed again
        self.assertLess(gaps[computing].max(), 1.0, figures)
        if subdivisions == 104:
            # Loose bounds for load 12 to 20 (20 000 faces held it 15 s at load 20; about 2 000 now);
            # they catch the faces no longer simplified, not a slow machine.
            self.assertLess(faces, 3000)
            self.assertLess(gaps[reading].max(), 3.0, figures)
            self.assertLess(gaps[drawing].max(), 5.0, figures)

    def test_k3c_make_solid_draws_the_facets_it_was_made_of(self):
        """Make solid of a closed 1 mm-spaced mesh of the demo part's block (10 um noise): FreeCAD's
        view provider draws the B-rep's facets (the mesh's, its curved ones simplified), which each
        face of the B-rep carries as its triangulation, instead of meshing the faces again (its 8 planar faces would give a few
        triangles each); no gap of a second in the GUI, drawing included."""
        from picoscan_wb.objects import scan_mesh
        from picoscan_wb.tests.test_app import outline_block_mesh

        block = self.doc.addObject("Mesh::Feature", "DrawnBlock")
        block.Mesh = scan_mesh.freecad_mesh(outline_block_mesh(0.01, 1.0))
        block.ViewObject.Visibility = False
        self.doc.recompute()
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(block)
        for _ in range(3):
            process_events()
        started, ended, _, gaps, labels = self.gui_ticks_while(lambda: FreeCADGui.runCommand("PicoScan_MakeSolid"))
        self.assertEqual(self.messages, [])
        solids = [o for o in self.doc.Objects if o.TypeId == "Part::Feature"]
        self.assertEqual(len(solids), 1)
        shape = solids[0].Shape
        self.assertTrue(shape.isValid())
        self.assertAlmostEqual(shape.Volume, block.Mesh.Volume, delta=1e-3 * block.Mesh.Volume)
        self.assertLess(len(shape.Faces), block.Mesh.CountFacets / 10)  # the flat sides merged
        drawn, parts = self.drawn_triangles(solids[0])
        self.assertEqual(parts, len(shape.Faces))
        figures = ("Make solid of the block (%d facets, %d faces): %.2f s, FreeCAD draws %d triangles; longest gap "
                   "%.3f s (after '%s'); load average %.1f" % (
                       block.Mesh.CountFacets, len(shape.Faces), ended - started, drawn, gaps.max(),
                       labels[int(gaps.argmax())], os.getloadavg()[0]))
        FreeCAD.Console.PrintMessage(figures + "\n")
        # The B-rep's own facets: the flat sides' as in the mesh, the rounded edge's simplified.
        brep_facets = int(re.search(r" faces from (\d+) facets", solids[0].SolidReport).group(1))
        self.assertEqual(drawn, brep_facets, figures)
        self.assertLess(drawn, block.Mesh.CountFacets, figures)
        self.assertLess(gaps.max(), 1.0, figures)

    def test_k4_cross_section_with_band_answers_events_and_cancel_leaves_the_document_as_it_was(self):
        """Cross-section with Band of a 460 000-facet sphere (17 cuts of it, each reporting every 65 536
        vertices and triangles) runs off the GUI thread; Cancel stops it, the panel stays open. (A
        205 000-facet sphere was cut within a second on an idle machine, before Cancel was pressed.)"""
        import Mesh

        sphere = self.doc.addObject("Mesh::Feature", "FineSphere")
        sphere.Mesh = Mesh.createSphere(10.0, 480)
        sphere.ViewObject.Visibility = False  # drawing it is not the work measured
        self.doc.recompute()
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(sphere)
        FreeCADGui.runCommand("PicoScan_CrossSection")
        process_events()
        panel = COMMANDS["PicoScan_CrossSection"].panel
        panel.band.setValue(5.0)
        accepted = []
        self.cancelled_while_the_gui_answers("Cross-section", lambda: accepted.append(panel.accept()), 0.6)
        self.assertEqual(accepted, [False])
        self.assertTrue(FreeCADGui.Control.activeDialog())  # the panel stays open for another try
        self.assertEqual([o for o in self.doc.Objects if o.TypeId == "Sketcher::SketchObject"], [])

    def test_k5_fit_primitives_answers_events_and_cancel_leaves_the_document_as_it_was(self):
        """Fit primitives on the shaft's ScanView (462 613 points: CGAL's RANSAC takes 5 to 14 s) runs
        off the GUI thread; Cancel, pressed 1 s into the detection proper (CGAL's octrees, 0.3-2 s,
        come first and cannot be stopped), stops it within a second although CGAL is then scoring
        its first candidates for seconds without asking its callback (the core's shapes hear
        Cancel there; before, Cancel took up to 5 s), and adds nothing."""
        view = scan_view.create(self.doc, self.captures, self.calibration, name="ShaftView")
        view.ViewObject.Visibility = False  # drawing it is not the work measured
        self.doc.recompute()
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(view)
        self.cancelled_while_the_gui_answers("Fit primitives", lambda: FreeCADGui.runCommand("PicoScan_FitPrimitives"),
                                             1.0, stage="Fitting primitives: shapes")
        self.assertEqual([o for o in self.doc.Objects if o.TypeId.startswith("Part::")], [])

    # The longest the GUI thread may stop answering while the Deviation map of a million points is made
    # and drawn: FreeCAD reading the map's three list properties (about 1.3 s at load 7) and its view
    # provider building the coloured points (its own, on the GUI thread). Before the map was built off
    # the GUI thread the longest stop was 15.6 s at load 11 (30.9 s in all), after 0.42 s (docs/freecad.md).
    DEVIATION_MAP_STALL_S = 6.0

    def million_point_scan(self):
        """A Points object of 1 000 000 points on the wall of a 12.5 mm cylinder (10 um noise), the
        Part::Cylinder it was scanned from, and a Part::Sphere (tessellated for seconds)."""
        from picoscan_wb.property_content import points_content

        rng = numpy.random.default_rng(6)
        angle, height = rng.uniform(0.0, 2 * math.pi, 1000000), rng.uniform(1.0, 79.0, 1000000)
        radius = 12.5 + rng.normal(0.0, 0.01, len(angle))
        scan = self.doc.addObject("Points::Feature", "MillionPoints")
        scan.restorePropertyContent("Points", points_content(numpy.stack(
            [radius * numpy.cos(angle), radius * numpy.sin(angle), height], axis=1)))
        cylinder = self.doc.addObject("Part::Cylinder", "CylinderModel")
        cylinder.Radius, cylinder.Height = 12.5, 80.0
        sphere = self.doc.addObject("Part::Sphere", "SphereModel")
        sphere.Radius = 20.0
        self.doc.recompute()
        self.assertEqual(scan.Points.CountPoints, 1000000)
        return scan, cylinder, sphere

    def test_k6_deviation_map_of_a_million_points_stalls_the_gui_briefly(self):
        """Deviation map of 1 M points against a Part model: the model is tessellated in another
        process, the distances, colours and the properties' bytes are made on a worker thread, so the
        GUI thread stops only for FreeCAD to read the properties and draw them; Cancel while a sphere
        is tessellated stops within a second and adds nothing."""
        scan, cylinder, sphere = self.million_point_scan()
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(scan)
        FreeCADGui.Selection.addSelection(sphere)
        self.cancelled_while_the_gui_answers("Deviation map", lambda: FreeCADGui.runCommand("PicoScan_DeviationMap"),
                                             0.3, stage="tessellating the reference: meshing 1 faces")
        self.messages.clear()
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(scan)
        FreeCADGui.Selection.addSelection(cylinder)
        for _ in range(3):
            process_events()
        started, ended, _, gaps, labels = self.gui_ticks_while(lambda: FreeCADGui.runCommand("PicoScan_DeviationMap"))
        maps = [o for o in self.doc.Objects if hasattr(o, "MeanAbsDeviation")]
        figures = "Deviation map of 1 M points: %.2f s in all, the GUI's longest stop %.3f s (after '%s')" % (
            ended - started, gaps.max(), labels[gaps.argmax()])
        FreeCAD.Console.PrintMessage(figures + "\n")
        self.assertEqual(self.messages, [])
        self.assertEqual(len(maps), 1)
        self.assertEqual(maps[0].PointCount, 1000000)
        self.assertEqual(len(maps[0].Color), 1000000)
        self.assertLess(maps[0].MeanAbsDeviation.Value, 0.012, figures)  # the 10 um noise
        self.assertLess(gaps.max(), self.DEVIATION_MAP_STALL_S, figures)

    def test_z_scan_mesh_and_screenshot(self):
        FreeCADGui.runCommand("PicoScan_Scan")
        process_events()
        panel = COMMANDS["PicoScan_Scan"].panel
        panel.scene.setCurrentText("Demo part")
        panel.folder.setText(os.path.join(self.folder, "demo"))
        self.assertTrue(panel.accept(), self.messages)
        view = panel.created
        self.assertGreater(view.PointCount, 100000)
        # Seen from its camera, a single view's faces all face FreeCAD's headlight, most of them (the
        # table) square to it: turned 30 degrees, their angles to it differ (21 grey levels p10-p90
        # where the flat look has 0, in a probe; seen from behind, every point is unlit alike).
        self.check_shading(view, "freecad-scanview-shaded.png", tilt_deg=30, min_spread=12)
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(view)
        FreeCADGui.runCommand("PicoScan_Mesh")
        process_events()
        panel = COMMANDS["PicoScan_Mesh"].panel
        self.assertEqual(panel.method.currentText(), "Grid")
        self.assertFalse(panel.sample_spacing.isEnabled())  # Poisson's parameters are not Grid's
        self.assertFalse(panel.fill.isEnabled())
        self.assertTrue(panel.accept(), self.messages)
        process_events()
        meshes = [o for o in self.doc.Objects if o.TypeId == "Mesh::FeaturePython"]
        self.assertEqual(len(meshes), 1, self.messages)
        self.assertGreater(meshes[0].Mesh.CountFacets, 100000)
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(meshes[0])
        FreeCADGui.runCommand("PicoScan_CrossSection")
        process_events()
        panel = COMMANDS["PicoScan_CrossSection"].panel
        centre = meshes[0].Mesh.BoundBox.Center
        self.assertEqual(panel.axis.currentText(), "Y")
        self.assertAlmostEqual(panel.position.value(), centre.y, delta=1e-3)
        self.assertEqual(panel.position.suffix(), " mm")
        before = self.object_names()
        panel.position.setValue(centre.y + 500)  # misses the mesh: a message, the panel stays open
        self.assertFalse(panel.accept())
        self.assertIn("does not cut the mesh", self.messages[-1][2])
        self.assertEqual(self.object_names(), before)
        self.assertTrue(FreeCADGui.Control.activeDialog())
        self.messages.clear()
        panel.position.setValue(centre.y)
        self.assertTrue(panel.accept(), self.messages)
        process_events()
        sections = [o for o in self.doc.Objects if o.TypeId == "Sketcher::SketchObject"]
        self.assertEqual(len(sections), 1, self.messages)
        self.assertNotIn("Touched", sections[0].State)  # its profile plot, set last, needs no recompute
        self.assertGreaterEqual(len(sections[0].FitReport), 3)  # fitted lines and arcs
        self.assertEqual(len(sections[0].FitReport), sections[0].GeometryCount)
        self.assertTrue(os.path.isfile(sections[0].ProfilePlot))
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.Selection.addSelection(view)
        FreeCADGui.runCommand("PicoScan_ShowRig")
        process_events()
        self.assertEqual(self.messages, [])
        # The scanned mesh seen isometric, from above: the scan lands in the part frame (Z up), where the
        # old view (turned 215 degrees about (1, 0.35, 0), "the scanner's side" of the camera frame) showed
        # its unlit underside, a black shape.
        self.doc.getObject("Rig").ViewObject.Visibility = False
        FreeCADGui.Selection.clearSelection()
        FreeCADGui.getMainWindow().showMaximized()
        # The section's profile plot opened in its own tab: bring the document's 3D view to the front.
        mdi = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea)
        for window in mdi.subWindowList():
            if window.windowTitle().startswith(self.doc.Label):
                mdi.setActiveSubWindow(window)
        process_events()
        view3d = FreeCADGui.ActiveDocument.ActiveView
        self.assertTrue(hasattr(view3d, "setCameraOrientation"), "the 3D view is not active")
        view3d.viewIsometric()
        view3d.fitAll()
        for _ in range(5):
            process_events()
        self.assertGreater(self.lit_brightness(meshes[0]), 70)
        for _ in range(5):
            process_events()
        path = os.environ.get("PICOSCAN_SCREENSHOT")
        if path:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            temporary = path + ".tmp.png"
            subprocess.run(["import", "-window", "root", temporary], check=True)
            os.replace(temporary, path)
            self.assertGreater(os.path.getsize(path), 50000)

    def lit_brightness(self, shown):
        """The mean grey level (0-255) of the pixels `shown` draws in the 3D view as it is turned (those that
        differ from the view without it): a face lit by FreeCAD's headlight is light, one seen from behind
        or below nearly black. Logged to the Report view."""
        shown.ViewObject.Visibility = False
        background = self.grab_3d_view().astype(int)
        shown.ViewObject.Visibility = True
        image = self.grab_3d_view().astype(int)
        drawn = numpy.abs(image - background).max(axis=2) > 30
        self.assertGreater(drawn.sum(), 20000, "%s hardly drawn" % shown.Label)
        brightness = float(image[drawn].mean())
        FreeCAD.Console.PrintMessage("%s on screen: %d pixels, mean grey level %.1f\n" % (shown.Label, drawn.sum(), brightness))
        return brightness

    def walkthrough_screenshot(self, name, select=(), isometric=True):
        """A screenshot of the whole window for docs/freecad.md's walkthrough, 800 pixels wide and
        palette-reduced, into PICOSCAN_WALKTHROUGH_DIR (nothing when it is not set). isometric: the
        active 3D view is turned isometric and fitted first (False for another tab, a spreadsheet)."""
        folder = os.environ.get("PICOSCAN_WALKTHROUGH_DIR")
        if not folder:
            return
        FreeCADGui.Selection.clearSelection()
        for obj in select:
            FreeCADGui.Selection.addSelection(obj)
        if isometric:
            view3d = FreeCADGui.ActiveDocument.ActiveView
            view3d.viewIsometric()
            view3d.fitAll()
        for _ in range(5):
            process_events()
        os.makedirs(folder, exist_ok=True)
        path = os.path.join(folder, "walkthrough-%s.png" % name)
        temporary = path + ".tmp.png"
        subprocess.run(["import", "-window", "root", temporary], check=True)
        subprocess.run(["convert", temporary, "-resize", "800x600", "-strip", "-colors", "128", "PNG8:" + temporary],
                       check=True)
        os.replace(temporary, path)
        self.assertGreater(os.path.getsize(path), 10000)

    def bring_tab_to_front(self, label):
        """Brings the tab whose title starts with `label` to the front, as a click on it does (a tab
        opened by a double click appears only after the events are processed)."""
        mdi = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea)
        for _ in range(5):
            process_events()
        windows = [w for w in mdi.subWindowList() if w.windowTitle().startswith(label)]
        self.assertTrue(windows, [w.windowTitle() for w in mdi.subWindowList()])
        mdi.setActiveSubWindow(windows[0])
        process_events()
        self.assertTrue(mdi.activeSubWindow().windowTitle().startswith(label), mdi.activeSubWindow().windowTitle())

    def run_command(self, command, *selection):
        """Selects as a user would, checks that the command is active, runs it; returns the command."""
        FreeCADGui.Selection.clearSelection()
        for obj in selection:
            FreeCADGui.Selection.addSelection(obj)
        self.assertTrue(FreeCADGui.Command.get(command).isActive(), command)
        FreeCADGui.runCommand(command)
        process_events()
        return COMMANDS[command]

    def test_y_walkthrough_scan_to_cad_every_command_in_order(self):
        """docs/freecad.md's walkthrough as a user runs it, every step through FreeCADGui.runCommand:
        Scan (simulated demo part), Clean scan, Mesh (Grid), Part frame, Cross-section, Fit primitives,
        Mesh (Poisson) and Make solid, Measurements, Deviation map; a screenshot after each."""
        FreeCADGui.getMainWindow().showMaximized()

        run = self.run_command

        panel = run("PicoScan_Scan").panel
        panel.scene.setCurrentText("Demo part")
        panel.folder.setText(os.path.join(self.folder, "walkthrough"))
        self.assertTrue(panel.accept(), self.messages)
        view = panel.created
        points = view.PointCount
        self.assertGreater(points, 100000)
        # Up to date as FreeCAD's own commands leave what they make (the tree showed it as needing a recompute).
        self.assertNotIn("Touched", view.State)
        self.walkthrough_screenshot("1-scan", [view])
        run("PicoScan_Clean", view)
        self.assertTrue(view.Clean)
        self.assertIn("removed", view.CleanReport)
        self.assertLess(view.PointCount, points)
        self.assertNotIn("Touched", view.State)
        panel = run("PicoScan_Mesh", view).panel
        self.assertTrue(panel.accept(), self.messages)
        grid = panel.created
        self.assertGreater(grid.Mesh.CountFacets, 50000)
        self.assertEqual([o.Name for o in self.doc.Objects if "Touched" in o.State], [])
        self.walkthrough_screenshot("2-mesh", [grid])
        run("PicoScan_PartFrame", view)
        self.doc.recompute()
        self.assertIn("base plane", view.PartFrame)
        self.assertAlmostEqual(grid.Placement.Rotation.Angle, view.Placement.Rotation.Angle, delta=1e-9)  # follows
        self.walkthrough_screenshot("3-part-frame", [view])
        panel = run("PicoScan_CrossSection", grid).panel  # across Y through the middle (the defaults)
        self.assertTrue(panel.accept(), self.messages)
        sketch = panel.created
        self.assertGreaterEqual(sketch.GeometryCount, 2, sketch.FitReport)
        self.walkthrough_screenshot("4-cross-section", [sketch])
        run("PicoScan_FitPrimitives", view)
        groups = [o for o in self.doc.Objects if o.TypeId == "App::DocumentObjectGroup" and o.Label.startswith("Primitives")]
        self.assertEqual(len(groups), 1, self.messages)
        fitted = [o for o in groups[0].Group if getattr(o, "FitKind", "") in ("Plane", "Cylinder")]
        self.assertGreaterEqual(len(fitted), 2)
        self.walkthrough_screenshot("5-fit", [groups[0]])
        panel = run("PicoScan_Mesh", view).panel
        panel.method.setCurrentText("Poisson")
        panel.sample_spacing.setValue(2.5)
        panel.target_faces.setValue(4000)
        self.assertTrue(panel.accept(), self.messages)
        surface = panel.created
        self.assertIsNotNone(surface, self.messages)
        self.assertTrue(surface.Mesh.isSolid())
        run("PicoScan_MakeSolid", surface)
        solids = [o for o in self.doc.Objects if hasattr(o, "SolidReport")]
        self.assertEqual(len(solids), 1, self.messages)
        FreeCAD.Console.PrintMessage("walkthrough, Make solid: %s\n" % solids[0].SolidReport)
        self.assertTrue(solids[0].Shape.isValid())
        self.assertAlmostEqual(solids[0].Shape.Volume / surface.Mesh.Volume, 1.0, delta=0.01)
        FreeCAD.Console.PrintMessage("walkthrough, Make solid: volume %.1f mm3 (mesh %.1f mm3)\n" % (
            solids[0].Shape.Volume, surface.Mesh.Volume))
        # Poisson gives the same mesh for the same points whatever ran before it in the process
        # (its refinement's cells numbered, 2026-11-24): the bubble's solid is a fixed figure,
        # 1.875 dm3 alone and in the whole suite (21.4, and 8.3 to 20.5 dm3, with address order).
        self.assertAlmostEqual(solids[0].Shape.Volume / 1874584.0, 1.0, delta=0.01)
        self.walkthrough_screenshot("6-make-solid", [solids[0]])
        solids[0].ViewObject.Visibility = False
        surface.ViewObject.Visibility = False  # the single view's Poisson guess hides the scene
        run("PicoScan_Measurements", groups[0])
        tables = [o for o in self.doc.Objects if hasattr(o, "Table") and hasattr(o, "CsvFile")]
        self.assertEqual(len(tables), 1, self.messages)
        self.assertGreater(len(tables[0].Table), 0)
        self.assertTrue(os.path.isfile(tables[0].CsvFile))
        FreeCAD.Console.PrintMessage("walkthrough, Measurements: %d rows, e.g. %s\n" % (
            len(tables[0].Table), "; ".join(tables[0].Table[:3])))
        # The rows as a user reads them: the CSV imported into a FreeCAD Spreadsheet (Spreadsheet
        # workbench: a new sheet, then its Import).
        mdi = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea)
        windows_before = set(mdi.subWindowList())
        sheets = [self.doc.addObject("Spreadsheet::Sheet", "MeasurementsSheet")]
        sheets[0].importFile(tables[0].CsvFile, ",")
        self.doc.recompute()
        sheets[0].ViewObject.doubleClicked()  # its table in a tab, brought to the front
        self.bring_tab_to_front(sheets[0].Label)
        for row, line in enumerate(tables[0].Table, start=2):  # row 1: the header
            value = float(sheets[0].get("D%d" % row))
            numbers = [float(word) for word in line.replace(":", " ").split() if word.lstrip("-").replace(".", "", 1).isdigit()]
            self.assertTrue(any(abs(n - value) <= 6e-5 for n in numbers), (row, value, line))  # the Table's rows, in order
        self.walkthrough_screenshot("7-measurements", isometric=False)  # selecting in the tree would not change tabs
        self.assertTrue(mdi.activeSubWindow().windowTitle().startswith(sheets[0].Label))
        for window in set(mdi.subWindowList()) - windows_before:
            window.close()
        self.bring_tab_to_front(self.doc.Label)
        # The fitted sphere as the model (a fitted plane as wide as the table tessellates into far too
        # many triangles; the solid is the single view's Poisson guess, not a model of the part).
        reference = [o for o in groups[0].Group if getattr(o, "FitKind", "") == "Sphere"][0]
        run("PicoScan_DeviationMap", view, reference)
        maps = [o for o in self.doc.Objects if hasattr(o, "MeanAbsDeviation")]
        self.assertEqual(len(maps), 1, self.messages)
        # As a user would in the property editor: points farther than 1 mm from the model (the rest
        # of the scene) are not measured (grey); the map recomputes.
        maps[0].MaxDistance = 1.0
        self.doc.recompute()
        FreeCAD.Console.PrintMessage("walkthrough, deviation map of the scan against %s: %s\n" % (
            reference.Label, maps[0].Summary))
        self.assertGreater(maps[0].PointCount, 1000)
        self.assertLess(maps[0].MeanAbsDeviation.Value, 0.05)  # the sphere's points: within the fit's noise
        view.ViewObject.Visibility = False
        self.walkthrough_screenshot("8-deviation-map", [maps[0]])
        self.assertEqual(self.messages, [])

    # Out of the suite: it takes minutes (2026-11-24, branch y2: 103 s at load 3.6 to 6.3, 143 s at
    # load 4.1 to 8.9; the suite's budget leaves it about 60 s, and decoding, stitching, Poisson, Make
    # solid and the map alone took 90-128 s of it). Last result and how to run it: docs/freecad.md,
    # "Eight turntable views in the GUI".
    @unittest.skipUnless("test_y2_" in os.environ.get("PICOSCAN_GUI_TESTS", ""),
                         "run by name (scripts/walkthrough-screenshots): minutes long, beyond the suite's time budget")
    def test_y2_walkthrough_eight_turntable_views_to_cad_every_command_in_order(self):
        """docs/freecad.md's multi-view walkthrough: eight turntable views of the demo part (half
        resolution; the workbench's turntable simulation writes one capture folder per view, as a
        turntable capture would), each read with Import capture set, then Clean, Stitch views (the
        panel's default, Automatic), Part frame, Mesh (Poisson, the panel's Unseen side set to
        Table), Fit primitives, Cross-section, Make solid, Measurements (the sheet's tab in front) and
        Deviation map, every step through FreeCADGui.runCommand with a screenshot after it."""
        FreeCADGui.getMainWindow().showMaximized()
        mdi = FreeCADGui.getMainWindow().findChild(QtWidgets.QMdiArea)
        true_volume_mm3 = 41779.0  # the demo part (picoscan.mechanical_part), from its closed mesh
        started = time.monotonic()

        run = self.run_command

        def step(name):
            FreeCAD.Console.PrintMessage("multi-view walkthrough: %s at %.1f s\n" % (name, time.monotonic() - started))

        scans, truth = simulate.simulate_turntable(os.path.join(self.folder, "turntable"), tuple(range(8)),
                                                   camera_scale=0.5)
        step("8 views simulated")
        views = []
        for folder, _ in scans:  # the folder's calibration.yml is found without asking
            self.answer_dialogs(folder)
            before = set(self.object_names())
            run("PicoScan_ImportCaptures")
            views += [self.doc.getObject(name) for name in self.object_names() if name not in before]
        self.assertEqual(len(views), 8, self.messages)
        points = [view.PointCount for view in views]
        run("PicoScan_Clean", *views)
        for view, count in zip(views, points):
            self.assertTrue(view.Clean)
            self.assertIn("removed", view.CleanReport)
            self.assertLess(view.PointCount, count)
        self.walkthrough_screenshot("multi-1-views", views)
        step("imported and cleaned")

        panel = run("PicoScan_Stitch", *views).panel
        self.assertEqual(panel.mode.currentText(), "Automatic")
        self.assertTrue(panel.accept(), self.messages)
        process_events()
        stitched = panel.created
        self.assertEqual(stitched.AlignedCount, 8, stitched.Report)
        self.assertTrue(stitched.AlignmentReport[0].startswith("features aligned 8 of 8 views; kept"),
                        stitched.AlignmentReport)
        worst = (0.0, 0.0)
        for view, pose, true_pose in zip(views, stitched.ViewPoses, truth):  # at each view's own points
            error = picoscan.pose_difference(numpy.array(pose.toMatrix().A).reshape(4, 4), true_pose,
                                             numpy.asarray(cloud_of(view).points).mean(axis=0))
            worst = (max(worst[0], error.rotation_deg), max(worst[1], error.translation_mm))
        FreeCAD.Console.PrintMessage("multi-view walkthrough, Stitch: %s; worst pose error of 8 views %.4f deg, "
                                     "%.4f mm\n" % (stitched.AlignmentReport[0], worst[0], worst[1]))
        self.assertLess(worst[0], 0.1)
        self.assertLess(worst[1], 0.1)
        self.walkthrough_screenshot("multi-2-stitch", [stitched])
        step("stitched")

        run("PicoScan_PartFrame", stitched)
        self.doc.recompute()
        self.assertIn("turntable axis", stitched.PartFrame)
        plan = picoscan.TurntablePlan()
        plan.top_view = False
        to_document = numpy.array(stitched.Placement.toMatrix().A).reshape(4, 4) @ numpy.asarray(
            picoscan.turntable_part_poses(plan)[0])
        tilt = math.degrees(math.acos(min(1.0, to_document[2, 2])))
        origin = to_document[:3, 3]  # where the part's own origin (its foot, on the axis) landed
        FreeCAD.Console.PrintMessage("multi-view walkthrough, Part frame: %s; Z off %.4f deg, the part's origin at "
                                     "(%.3f, %.3f, %.3f) mm\n" % (stitched.PartFrame, tilt, *origin))
        self.assertLess(tilt, 0.1)
        self.assertLess(math.hypot(origin[0], origin[1]), 0.2)
        self.assertLess(abs(origin[2]), 0.5)
        self.walkthrough_screenshot("multi-3-part-frame", [stitched])
        step("part frame")

        panel = run("PicoScan_Mesh", stitched).panel
        self.assertEqual(panel.method.currentText(), "Poisson")  # a Stitch has no pixel grid
        panel.sample_spacing.setValue(1.0)
        panel.target_faces.setValue(20000)
        self.assertEqual(panel.fill.currentText(), "Poisson")
        # The round never saw the bottom, and the part stood on the table: close it there.
        panel.fill.setCurrentText("Table")
        self.assertTrue(panel.accept(), self.messages)
        surface = panel.created
        self.assertEqual(surface.Fill, "Table")
        # The property editor shows the Poisson's parameters, not the Grid's.
        self.assertEqual((surface.getEditorMode("PixelStep"), surface.getEditorMode("SampleSpacing")), (["Hidden"], []))
        self.assertTrue(surface.Mesh.isSolid(), surface.Check)
        FreeCAD.Console.PrintMessage("multi-view walkthrough, Poisson (Fill Table): %d facets, %.1f mm3 (%+.2f %% "
                                     "of the part's); %s\n" % (surface.Mesh.CountFacets, surface.Mesh.Volume, 100 * (
                                         surface.Mesh.Volume / true_volume_mm3 - 1), surface.Check))
        self.assertIn("watertight", surface.Check)
        # One piece: the cut at the table once left a crumb of 4 faces beside the hole.
        self.assertIn(" 1 component(s)", surface.Check)
        self.assertAlmostEqual(surface.Mesh.Volume / true_volume_mm3, 1.0, delta=0.03)
        self.walkthrough_screenshot("multi-4-mesh", [surface])
        step("meshed")

        run("PicoScan_FitPrimitives", stitched)
        groups = [o for o in self.doc.Objects if o.TypeId == "App::DocumentObjectGroup" and o.Label.startswith("Primitives")]
        self.assertEqual(len(groups), 1, self.messages)
        radii = sorted(o.Radius.Value for o in groups[0].Group if o.TypeId == "Part::Cylinder")
        FreeCAD.Console.PrintMessage("multi-view walkthrough, Fit primitives: %s; cylinder radii %s\n" % (
            ", ".join(o.Label for o in groups[0].Group), ", ".join("%.4f" % r for r in radii)))
        for radius in (5.0, 7.0):  # the through hole and the boss
            self.assertTrue(any(abs(r - radius) < 0.05 for r in radii), radii)
        self.walkthrough_screenshot("multi-5-fit", [groups[0]])
        for primitive in groups[0].Group:  # hidden (Space in the tree), so that the scan shows
            primitive.ViewObject.Visibility = False
        step("primitives")

        panel = run("PicoScan_CrossSection", surface).panel
        panel.axis.setCurrentText("Z")
        panel.position.setValue(12.0)  # half the block's height, in the part frame
        # The panel's default tolerance is 5 x the noise of the Stitch behind the mesh (0.029 mm:
        # 0.146 mm), which also fits the mesh's rounded corner at (-25, -18) as a 1.2 mm arc; 0.1 mm
        # keeps it a corner. At z = 12 mm the mesh's vertical edge at (-25, 18) is cut off 0.58 mm
        # deep (facets across it; 0.40 mm at z = 18, sharp at z = 6, 10, 14): the fit draws that cut
        # as a short line of its own, so the sides of 42 and 36 mm end short of the corner.
        panel.tolerance.setValue(0.1)
        self.assertTrue(panel.accept(), self.messages)
        sketch = panel.created
        FreeCAD.Console.PrintMessage("multi-view walkthrough, Cross-section at z = 12 mm: %s\n" % "; ".join(sketch.FitReport))
        self.assertEqual(len(sketch.FitReport), sketch.GeometryCount)
        # The sketch's origin and axes are the part frame's (its coordinates are the part's).
        self.assertLess((sketch.Placement.Base - FreeCAD.Vector(0, 0, 12)).Length, 1e-9, sketch.Placement)
        number = r"(-?[0-9.]+)"
        lines = []  # (length, start, end) of each line
        for row in sketch.FitReport:
            found = re.search(r": line +length +%s mm.* from \(%s, %s\) to \(%s, %s\)" % ((number,) * 5), row)
            if found:
                values = [float(v) for v in found.groups()]
                lines.append((values[0], numpy.array(values[1:3]), numpy.array(values[3:5])))
        lengths = [line[0] for line in lines]
        # The block's outline at z = 12: the sides of 50 and 28 mm and the chamfer (8 mm legs) whole.
        for length, tolerance in ((50.0, 0.1), (28.0, 0.15), (8 * math.sqrt(2), 0.1)):
            self.assertTrue(any(abs(line - length) < tolerance for line in lengths), (length, lengths))
        # The sides of 42 mm (y = 18) and 36 mm (x = -25): on their true lines (the frame's origin is
        # 0.04 mm off), at most 3 mm short of the corner the mesh cut off (2.3 and 0.7 mm measured).
        for side_length, axis, at in ((42.0, 1, 18.0), (36.0, 0, -25.0)):
            along = [line for line in lines if abs(line[1][axis] - at) < 0.1 and abs(line[2][axis] - at) < 0.1]
            self.assertEqual(len(along), 1, (side_length, lengths))
            self.assertTrue(side_length - 3.0 < along[0][0] <= side_length + 0.15, (side_length, lengths))
        self.walkthrough_screenshot("multi-6-cross-section", [sketch])
        step("section")

        run("PicoScan_MakeSolid", surface)
        solids = [o for o in self.doc.Objects if hasattr(o, "SolidReport")]
        self.assertEqual(len(solids), 1, self.messages)
        made = solids[0]
        FreeCAD.Console.PrintMessage("multi-view walkthrough, Make solid: %.1f mm3 (%+.2f %% of the part's); %s\n" % (
            made.Shape.Volume, 100 * (made.Shape.Volume / true_volume_mm3 - 1), made.SolidReport))
        self.assertTrue(made.Shape.isValid())
        self.assertAlmostEqual(made.Shape.Volume / surface.Mesh.Volume, 1.0, delta=0.001)
        self.assertAlmostEqual(made.Shape.Volume / true_volume_mm3, 1.0, delta=0.03)
        surface.ViewObject.Visibility = False
        self.walkthrough_screenshot("multi-7-make-solid", [made])
        step("solid")

        run("PicoScan_Measurements", groups[0])
        tables = [o for o in self.doc.Objects if hasattr(o, "Table") and hasattr(o, "CsvFile")]
        self.assertEqual(len(tables), 1, self.messages)
        self.assertGreater(len(tables[0].Table), 0)
        FreeCAD.Console.PrintMessage("multi-view walkthrough, Measurements: %d rows: %s\n" % (
            len(tables[0].Table), "; ".join(tables[0].Table)))
        sheet = self.doc.addObject("Spreadsheet::Sheet", "MeasurementsSheet")  # Spreadsheet: new sheet, Import
        sheet.importFile(tables[0].CsvFile, ",")
        self.doc.recompute()
        for row, line in enumerate(tables[0].Table, start=2):  # row 1: the header; column D: each row's value
            value = float(sheet.get("D%d" % row))
            numbers = [float(word) for word in line.replace(":", " ").split() if word.lstrip("-").replace(".", "", 1).isdigit()]
            self.assertTrue(any(abs(n - value) <= 6e-5 for n in numbers), (row, value, line))
        sheet.ViewObject.doubleClicked()  # its table opens in a tab
        self.bring_tab_to_front(sheet.Label)
        self.walkthrough_screenshot("multi-8-measurements", isometric=False)
        self.assertTrue(mdi.activeSubWindow().windowTitle().startswith(sheet.Label))
        self.bring_tab_to_front(self.doc.Label)
        step("measurements")

        run("PicoScan_DeviationMap", stitched, made)
        maps = [o for o in self.doc.Objects if hasattr(o, "MeanAbsDeviation")]
        self.assertEqual(len(maps), 1, self.messages)
        FreeCAD.Console.PrintMessage("multi-view walkthrough, deviation map of the stitched scan against the solid: "
                                     "%s\n" % maps[0].Summary)
        self.assertEqual(maps[0].PointCount, stitched.PointCount)
        self.assertLess(maps[0].MeanAbsDeviation.Value, 0.05)
        made.ViewObject.Visibility = False
        self.bring_tab_to_front(self.doc.Label)  # the report's histogram opened in its own tab
        self.walkthrough_screenshot("multi-9-deviation-map", [maps[0]])
        step("deviation map")
        self.assertEqual(self.messages, [])
