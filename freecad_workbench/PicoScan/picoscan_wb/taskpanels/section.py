"""Cross-section task panel: the cutting plane (its normal axis and position, with units) and the
fit tolerance are set before anything is computed; a translucent plane shows where the cut will be."""
import FreeCADGui
from PySide import QtGui

import picoscan

from picoscan_wb.commands.base import run_guarded

AXES = ("X", "Y", "Z")


class CrossSectionTaskPanel:
    """The command that opens this panel keeps it as its `panel` (for tests and macros)."""

    def __init__(self, mesh_object, make_section):
        self.mesh_object = mesh_object
        self.make_section = make_section  # (mesh, axis, position_mm, tolerance_mm, band_mm) -> sketch
        self.created = None
        self.form = QtGui.QWidget()
        self.form.setWindowTitle("PicoScan cross-section")
        layout = QtGui.QFormLayout(self.form)
        self.axis = QtGui.QComboBox()
        self.axis.addItems(list(AXES))
        self.axis.setCurrentText("Y")
        self.axis.setToolTip("The cutting plane is perpendicular to this axis")
        layout.addRow("Normal", self.axis)
        self.position = QtGui.QDoubleSpinBox()
        self.position.setRange(-1e6, 1e6)
        self.position.setDecimals(3)
        self.position.setSuffix(" mm")
        self.position.setToolTip("Where the plane crosses the axis (the mesh's centre to begin with)")
        layout.addRow("Position", self.position)
        self.tolerance = QtGui.QDoubleSpinBox()
        self.tolerance.setRange(0, 10)
        self.tolerance.setDecimals(3)
        self.tolerance.setSuffix(" mm")
        self.tolerance.setSpecialValueText("from the scan's noise")
        self.tolerance.setToolTip("Largest distance of a section point to its fitted line or arc, the same for "
                                  "every loop of the cut; 0: five times the noise of the scan the mesh was made "
                                  "from (measured on its points), or, for a mesh with no scan behind it, of the cut "
                                  "itself (a flattened mesh's cut has almost none: set the tolerance yourself; the "
                                  "sketch's FitToleranceFrom says which). "
                                  "Loops too small or too noisy for it are left out (the sketch's LeftOut says why)")
        layout.addRow("Tolerance", self.tolerance)
        self.band = QtGui.QDoubleSpinBox()
        self.band.setRange(0, 1000)
        self.band.setDecimals(3)
        self.band.setSuffix(" mm")
        self.band.setSpecialValueText("one cut")
        self.band.setValue(picoscan.DEFAULT_SECTION_BAND_MM)
        self.band.setToolTip("Refit each line and arc with 16 more cuts within +- this distance of the plane, "
                             "wherever they follow it (a pad's sides): one cut of a scan gives a short line's "
                             "direction to about 0.1 degrees, 17 cuts over +- 3 mm to 0.04; 0: the one cut")
        layout.addRow("Band (+-)", self.band)
        self.preview = None
        self.axis.currentTextChanged.connect(self.centre_position)
        self.position.valueChanged.connect(self.show_plane)
        self.centre_position()

    def centre_position(self, *_):
        centre = self.mesh_object.Mesh.BoundBox.Center
        self.position.setValue(getattr(centre, self.axis.currentText().lower()))
        self.show_plane()

    def show_plane(self, *_):
        """A translucent square over the mesh where the plane cuts it (not part of the document)."""
        try:
            from pivy import coin
        except ImportError:
            return
        box = self.mesh_object.Mesh.BoundBox
        size = 0.6 * max(box.XLength, box.YLength, box.ZLength)
        centre = box.Center
        axis = self.axis.currentText()
        setattr(centre, axis.lower(), self.position.value())
        corners = []
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            offsets = {"X": (0, a, b), "Y": (a, 0, b), "Z": (a, b, 0)}[axis]
            corners.append([centre.x + size * offsets[0], centre.y + size * offsets[1], centre.z + size * offsets[2]])
        if self.preview is None:
            self.preview = coin.SoSeparator()
            material = coin.SoMaterial()
            material.diffuseColor = (1.0, 0.8, 0.2)
            material.transparency = 0.6
            self.coordinates = coin.SoCoordinate3()
            self.preview.addChild(material)
            self.preview.addChild(self.coordinates)
            face = coin.SoFaceSet()
            face.numVertices = 4
            self.preview.addChild(face)
            view = FreeCADGui.ActiveDocument.ActiveView if FreeCADGui.ActiveDocument else None
            if view is None or not hasattr(view, "getSceneGraph"):
                self.preview = None
                return
            self.scene = view.getSceneGraph()
            self.scene.addChild(self.preview)
        self.coordinates.point.setValues(0, 4, corners)

    def remove_preview(self):
        if self.preview is not None:
            self.scene.removeChild(self.preview)
            self.preview = None

    def accept(self):
        arguments = (self.mesh_object, self.axis.currentText(), self.position.value(), self.tolerance.value(),
                     self.band.value())
        self.created = run_guarded("Cross-section", lambda: self.make_section(*arguments))
        if self.created is None:
            return False  # the message is shown; the panel stays open for corrections
        self.remove_preview()
        FreeCADGui.Control.closeDialog()
        return True

    def reject(self):
        self.remove_preview()
        FreeCADGui.Control.closeDialog()
        return True
