"""Scan task panel: capture a scan with the projector and a camera (through `picoscan capture`,
the capture issue's command) or simulate one with the core's virtual rig (one camera, or two
cameras with a stereo calibration), then reconstruct it into a ScanView. The capture step is
this panel's `capture()` alone."""
import os
import tempfile

import FreeCAD
import FreeCADGui
from PySide import QtGui

import picoscan
from picoscan_wb.commands.base import INPUT_ERRORS, show_message
from picoscan_wb.objects import scan_view
from picoscan_wb.operations import capture as hardware, simulate
from picoscan_wb.progress import FreeCADProgress

SOURCES = ("Simulate", "Camera + projector")
CAMERAS = ("One camera", "Two cameras (stereo)")


class ScanTaskPanel:
    """The command that opens this panel keeps it as its `panel` (for tests and macros)."""

    def __init__(self):
        self.form = QtGui.QWidget()
        self.form.setWindowTitle("PicoScan scan")
        layout = QtGui.QFormLayout(self.form)
        self.source = QtGui.QComboBox()
        self.source.addItems(list(SOURCES))
        self.source.setToolTip("Simulate: the virtual rig renders a scene. Camera + projector: 'picoscan capture' "
                               "shows the patterns on the projector's screen and grabs them with the camera.")
        layout.addRow("Source", self.source)
        self.camera = QtGui.QLineEdit("0")
        self.camera.setToolTip("Webcam index (0), device (/dev/video0), video file, or 'virtual' (the simulated rig)")
        layout.addRow("Camera", self.camera)
        self.projector_screen = QtGui.QSpinBox()
        self.projector_screen.setRange(-1, 16)
        self.projector_screen.setValue(1)
        self.projector_screen.setToolTip("The projector's screen ('picoscan screens'); -1: none (virtual camera only)")
        layout.addRow("Projector screen", self.projector_screen)
        self.calibration = QtGui.QLineEdit()
        self.calibration.setToolTip("The rig's calibration (Calibrate rig), needed for camera + projector")
        layout.addRow("Calibration", self.calibration)
        self.scene = QtGui.QComboBox()
        self.scene.addItems(list(simulate.SCENES))
        self.scene.setToolTip("Simulate: what the virtual rig scans. Demo part: a block with a through hole and a boss, "
                              "and a ball, before a wall. Shaft: a cylinder before a wall. Scene file: your own "
                              "scene (YAML/JSON)")
        layout.addRow("Scene", self.scene)
        self.scene_file = QtGui.QLineEdit()
        self.scene_file.setToolTip("Scene description (YAML/JSON) when Scene is 'Scene file'")
        layout.addRow("Scene file", self.scene_file)
        self.cameras = QtGui.QComboBox()
        self.cameras.addItems(list(CAMERAS))
        self.cameras.setToolTip("Two cameras: the simulated stereo rig (two cameras 200 mm apart, the projector "
                                "between them only labelling pixels), reconstructed with its stereo calibration")
        layout.addRow("Cameras", self.cameras)
        self.folder = QtGui.QLineEdit(tempfile.mkdtemp(prefix="picoscan_scan_"))
        self.folder.setToolTip("Where the capture set (images + sequence.json) is written; the ScanView reads it "
                               "from there (and keeps its decoded view in the document)")
        layout.addRow("Capture folder", self.folder)
        self.second_folder = QtGui.QLineEdit()
        self.second_folder.setToolTip("Two cameras: where the second camera's capture set is written "
                                      "(empty: a new temporary folder)")
        layout.addRow("Second capture folder", self.second_folder)
        self.camera_scale = QtGui.QDoubleSpinBox()
        self.camera_scale.setRange(0.25, 1.0)
        self.camera_scale.setSingleStep(0.25)
        self.camera_scale.setValue(0.5)
        self.camera_scale.setToolTip("Camera resolution relative to the seed rig's 1600 x 1200")
        layout.addRow("Camera scale", self.camera_scale)
        self.stop = QtGui.QPushButton("Stop scan")
        self.stop.clicked.connect(self.request_cancel)
        layout.addRow(self.stop)
        self.cancel_requested = False
        self.created = None

    def request_cancel(self):
        self.cancel_requested = True

    def should_cancel(self):
        QtGui.QApplication.processEvents()
        return self.cancel_requested

    def two_cameras(self):
        return self.cameras.currentText() == CAMERAS[1]

    def capture(self, folder, progress, second_folder=""):
        """Writes a capture set into `folder` (and the second camera's into `second_folder` with two
        cameras); returns the calibration file to reconstruct it with."""
        if self.source.currentText() == "Camera + projector":
            screen = self.projector_screen.value()
            return hardware.capture(folder, self.camera.text().strip(), self.calibration.text().strip(),
                                    None if screen < 0 else screen, self.should_cancel)
        scene = simulate.make_scene(self.scene.currentText(), self.scene_file.text().strip())
        if second_folder:
            return simulate.simulate_stereo_scan(folder, second_folder, scene, camera_scale=self.camera_scale.value(),
                                                 progress=progress)
        return simulate.simulate_scan(folder, scene, camera_scale=self.camera_scale.value(), progress=progress)

    def scan(self):
        folder = self.folder.text().strip()
        if not folder:
            raise picoscan.Error("Capture folder: choose where the scan is written")
        second_folder = ""
        if self.two_cameras():
            if self.source.currentText() == "Camera + projector":
                raise picoscan.Error("Cameras: this panel captures with one camera; reconstruct a two-camera capture "
                                     "with Import capture set and its stereo calibration")
            second_folder = self.second_folder.text().strip() or tempfile.mkdtemp(prefix="picoscan_scan_camera2_")
        self.cancel_requested = False
        with FreeCADProgress("Scanning", self.should_cancel) as progress:
            calibration = self.capture(folder, progress, second_folder)
        doc = FreeCAD.ActiveDocument or FreeCAD.newDocument("Scan")
        doc.openTransaction("Scan")  # one undo step
        try:
            self.created = scan_view.create(doc, folder, calibration, second_capture_folder=second_folder,
                                            part_frame=True)
        except Exception:
            doc.abortTransaction()
            raise
        doc.commitTransaction()
        return self.created

    def accept(self):
        doc = FreeCAD.ActiveDocument
        before = set(o.Name for o in doc.Objects) if doc else set()
        try:
            self.scan()
        except INPUT_ERRORS as error:
            if doc:
                for name in [o.Name for o in doc.Objects if o.Name not in before]:
                    doc.removeObject(name)
            FreeCAD.Console.PrintError("PicoScan scan: %s\n" % error)
            show_message("PicoScan: Scan", str(error))
            return False
        FreeCADGui.Control.closeDialog()
        FreeCADGui.SendMsgToActiveView("ViewFit")
        return True

    def reject(self):
        FreeCADGui.Control.closeDialog()
        return True
