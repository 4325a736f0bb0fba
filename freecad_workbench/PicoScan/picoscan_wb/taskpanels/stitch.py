"""Stitch views task panel: the views and placements found in the selection, the alignment mode and,
for a known turntable axis, its point and direction (with units) are set before computing; the
stitch then runs off the GUI thread with a progress dialog and Cancel."""
import FreeCADGui
from PySide import QtCore, QtGui

from picoscan_wb.commands.base import run_guarded
from picoscan_wb.objects import stitch


class StitchTaskPanel:
    """The command that opens this panel keeps it as its `panel` (for tests and macros).
    placement_of_view: each view's placement from 1 (groups selected), or empty for one placement."""

    def __init__(self, views, placement_of_view=()):
        self.views = list(views)
        self.placement_of_view = list(placement_of_view)
        self.created = None
        self.form = QtGui.QWidget()
        self.form.setWindowTitle("PicoScan stitch views")
        layout = QtGui.QFormLayout(self.form)
        self.found = QtGui.QLabel(self.selection_text())
        self.found.setWordWrap(True)
        layout.addRow("Views", self.found)
        self.mode = QtGui.QComboBox()
        for index, mode in enumerate(stitch.MODES):
            self.mode.addItem(mode)
            self.mode.setItemData(index, stitch.MODE_TIPS[mode], QtCore.Qt.ToolTipRole)
        self.mode.setToolTip("; ".join("%s: %s" % item for item in stitch.MODE_TIPS.items()))
        layout.addRow("Mode", self.mode)
        self.point = [self.number(" mm", -1e5, 1e5, 4) for _ in range(3)]
        self.direction = [self.number("", -1, 1, 6) for _ in range(3)]
        self.step = self.number(" °", 0, 359.999, 3)
        self.step.setSpecialValueText("one full round")
        self.step.setToolTip("The turn between views; 0: one full round (360 degrees / the views of a placement)")
        layout.addRow("Axis point", self.row(self.point, "A point on the turntable's axis, in the first view's camera "
                                                         "frame (as a Stitch's AlignmentReport or 'picoscan stitch' "
                                                         "gives it)"))
        layout.addRow("Axis direction", self.row(self.direction, "The axis direction (any length); the part turns "
                                                                 "right-handed about it from one view to the next"))
        layout.addRow("Step", self.step)
        self.mode.currentTextChanged.connect(self.show_axis)
        self.show_axis()

    def selection_text(self):
        numbers = self.placement_of_view or [1] * len(self.views)
        lines = []
        for number in sorted(set(numbers)):
            labels = [view.Label for view, n in zip(self.views, numbers) if n == number]
            lines.append("Placement %d (%d views): %s" % (number, len(labels), ", ".join(labels)))
        return "\n".join(lines)

    @staticmethod
    def number(suffix, low, high, decimals):
        box = QtGui.QDoubleSpinBox()
        box.setRange(low, high)
        box.setDecimals(decimals)
        box.setSuffix(suffix)
        return box

    @staticmethod
    def row(boxes, tip):
        widget = QtGui.QWidget()
        line = QtGui.QHBoxLayout(widget)
        line.setContentsMargins(0, 0, 0, 0)
        for box in boxes:
            box.setToolTip(tip)
            line.addWidget(box)
        return widget

    def show_axis(self, *_):
        known = self.mode.currentText() == "Turntable axis"
        for box in self.point + self.direction + [self.step]:
            box.setEnabled(known)

    def set_axis(self, point_mm, direction, step_deg=0.0):
        """Fills the known-axis fields (tests and macros)."""
        for box, value in zip(self.point, point_mm):
            box.setValue(value)
        for box, value in zip(self.direction, direction):
            box.setValue(value)
        self.step.setValue(step_deg)

    def stitch(self):
        known = self.mode.currentText() == "Turntable axis"
        return stitch.create(self.views[0].Document, self.views, placement_of_view=self.placement_of_view,
                             mode=self.mode.currentText(),
                             axis_point=[box.value() for box in self.point] if known else None,
                             axis_direction=[box.value() for box in self.direction] if known else None,
                             step_deg=self.step.value() if known else 0.0)

    def accept(self):
        self.created = run_guarded("Stitch views", self.stitch)
        if self.created is None:
            return False  # the message is shown; the panel stays open for another mode or axis
        FreeCADGui.Control.closeDialog()
        return True

    def reject(self):
        FreeCADGui.Control.closeDialog()
        return True
