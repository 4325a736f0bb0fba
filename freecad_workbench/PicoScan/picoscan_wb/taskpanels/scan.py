"""Scan task panel. Simulated scans (the core's virtual rig) are made here; scans from the real
projector and camera are captured with `picoscan capture` (capture issue) and brought in with
Import capture set. The capture step is this panel's `capture()` alone, so hardware capture can be
wired in there later."""
import os
import tempfile

import FreeCAD
import FreeCADGui
from PySide import QtGui

import picoscan
from picoscan_wb.commands.base import INPUT_ERRORS, show_message
from picoscan_wb.objects import scan_view
from picoscan_wb.operations import simulate
from picoscan_wb.progress import FreeCADProgress

HARDWARE_NOTE = ("Hardware capture: run 'picoscan capture' with the projector and camera, then use "
                 "Import capture set. This panel simulates a scan with the virtual rig.")


class ScanTaskPanel:
    # The panel on screen, for tests and macros.
    current = None

    def __init__(self):
        ScanTaskPanel.current = self
        self.form = QtGui.QWidget()
        self.form.setWindowTitle("PicoScan scan")
        layout = QtGui.QFormLayout(self.form)
        note = QtGui.QLabel(HARDWARE_NOTE)
        note.setWordWrap(True)
        layout.addRow(note)
        self.scene = QtGui.QComboBox()
        self.scene.addItems(list(simulate.SCENES))
        layout.addRow("Scene", self.scene)
        self.scene_file = QtGui.QLineEdit()
        self.scene_file.setToolTip("Scene description (YAML/JSON) when Scene is 'Scene file'")
        layout.addRow("Scene file", self.scene_file)
        self.folder = QtGui.QLineEdit(tempfile.mkdtemp(prefix="picoscan_scan_"))
        layout.addRow("Capture folder", self.folder)
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

    def capture(self, folder, progress):
        """Writes a capture set and its calibration into `folder`; returns the calibration file."""
        scene = simulate.make_scene(self.scene.currentText(), self.scene_file.text().strip())
        return simulate.simulate_scan(folder, scene, camera_scale=self.camera_scale.value(), progress=progress)

    def scan(self):
        folder = self.folder.text().strip()
        if not folder:
            raise picoscan.Error("Capture folder: choose where the scan is written")
        self.cancel_requested = False
        with FreeCADProgress("Scanning", self.should_cancel) as progress:
            calibration = self.capture(folder, progress)
        doc = FreeCAD.ActiveDocument or FreeCAD.newDocument("Scan")
        self.created = scan_view.create(doc, folder, calibration)
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
