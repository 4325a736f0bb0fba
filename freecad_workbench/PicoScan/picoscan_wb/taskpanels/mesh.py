"""Mesh task panel: the method and its parameters (with units) are chosen before computing; the
long surface methods then run off the GUI thread with a progress dialog and Cancel."""
import FreeCADGui
from PySide import QtGui

import picoscan
from picoscan_wb.commands.base import run_guarded
from picoscan_wb.objects import is_scan_view, scan_mesh


class MeshTaskPanel:
    """The command that opens this panel keeps it as its `panel` (for tests and macros)."""

    def __init__(self, source):
        self.source = source
        self.created = None
        defaults = picoscan.MeshOptions()
        self.form = QtGui.QWidget()
        self.form.setWindowTitle("PicoScan mesh")
        layout = QtGui.QFormLayout(self.form)
        self.method = QtGui.QComboBox()
        self.method.addItems([m for m in scan_mesh.METHODS if m != "Grid" or is_scan_view(source)])
        self.method.setToolTip("Grid: joins neighbouring pixels of one view (fast, open). Poisson: watertight. "
                               "AdvancingFront: open surfaces.")
        layout.addRow("Method", self.method)
        self.pixel_step = QtGui.QSpinBox()
        self.pixel_step.setRange(1, 64)
        self.pixel_step.setValue(2)
        self.pixel_step.setToolTip("Grid: join every n-th pixel (n x n fewer triangles)")
        layout.addRow("Pixel step", self.pixel_step)
        self.sample_spacing = self.length(defaults.sample_spacing_mm, "Thin the cloud to about this spacing first; 0 keeps all")
        layout.addRow("Sample spacing", self.sample_spacing)
        self.max_hole = self.length(defaults.max_hole_diameter_mm, "Holes up to this size are filled")
        layout.addRow("Largest hole filled", self.max_hole)
        self.target_faces = QtGui.QSpinBox()
        self.target_faces.setRange(0, 100000000)
        self.target_faces.setValue(defaults.target_faces)
        self.target_faces.setSpecialValueText("all")
        self.target_faces.setToolTip("Simplify to about this many faces; 0 keeps all")
        layout.addRow("Target faces", self.target_faces)
        self.fill = QtGui.QComboBox()
        self.fill.addItems(scan_mesh.FILLS)
        self.fill.setToolTip("The side the scan never saw: Poisson closes it with a smooth guess (right for a "
                             "part scanned in two placements), Table with a flat cap at the table's plane (a part "
                             "standing on the turntable, one placement), Open leaves it open (nothing invented)")
        layout.addRow("Unseen side", self.fill)
        self.method.currentTextChanged.connect(self.show_parameters)
        self.show_parameters()

    @staticmethod
    def length(value, tip):
        box = QtGui.QDoubleSpinBox()
        box.setRange(0, 1000)
        box.setDecimals(3)
        box.setSuffix(" mm")
        box.setValue(value)
        box.setToolTip(tip)
        return box

    def show_parameters(self, *_):
        grid = self.method.currentText() == "Grid"
        self.pixel_step.setEnabled(grid)
        for box in (self.sample_spacing, self.max_hole, self.target_faces, self.fill):
            box.setEnabled(not grid)

    def mesh(self):
        return scan_mesh.create(self.source.Document, self.source, method=self.method.currentText(),
                                pixel_step=self.pixel_step.value(), sample_spacing_mm=self.sample_spacing.value(),
                                target_faces=self.target_faces.value(), max_hole_diameter_mm=self.max_hole.value(),
                                fill=self.fill.currentText())

    def accept(self):
        self.created = run_guarded("Mesh", self.mesh)
        if self.created is None:
            return False  # the message is shown; the panel stays open for corrections
        FreeCADGui.Control.closeDialog()
        return True

    def reject(self):
        FreeCADGui.Control.closeDialog()
        return True
