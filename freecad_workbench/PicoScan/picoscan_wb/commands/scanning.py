"""Commands that produce scans: Calibrate, Scan (simulated; hardware capture is `picoscan capture`),
Import capture set, Clean."""
import os

import FreeCAD
import FreeCADGui

import picoscan
from picoscan_wb.commands.base import Command, active_document, captures_on_disk, selected_scan_views
from picoscan_wb.objects import recompute_now, scan_view


class CalibrateCommand(Command):
    icon = "picoscan_calibrate"
    menu = "Calibrate rig"
    tooltip = "Calibrate camera and projector from captures of a board in several poses"

    def Activated(self):
        from picoscan_wb.taskpanels.calibrate import CalibrateTaskPanel

        self.panel = CalibrateTaskPanel()  # the open panel, for tests and scripts
        FreeCADGui.Control.showDialog(self.panel)


class ScanCommand(Command):
    icon = "picoscan_scan"
    menu = "Scan"
    tooltip = "Scan a part: simulated with the virtual rig here; hardware capture comes from 'picoscan capture'"

    def Activated(self):
        from picoscan_wb.taskpanels.scan import ScanTaskPanel

        self.panel = ScanTaskPanel()  # the open panel, for tests and scripts
        FreeCADGui.Control.showDialog(self.panel)


def _ask_capture_set():
    """(capture folder, calibration file, second capture folder or "") from file dialogs; None when the
    user cancels. A stereo calibration (two cameras) asks for the second camera's folder too."""
    from PySide import QtGui

    from picoscan_wb.operations.reconstruct import is_stereo_calibration

    window = FreeCADGui.getMainWindow()
    folder = QtGui.QFileDialog.getExistingDirectory(window, "Capture set folder (images + sequence.json)")
    if not folder:
        return None
    if not os.path.isdir(folder):
        raise picoscan.Error("%s: capture folder does not exist" % folder)
    found = [os.path.join(folder, name) for name in ("calibration.yml", "stereo.yml")
             if os.path.isfile(os.path.join(folder, name))]
    if len(found) == 1:
        calibration = found[0]
    else:
        calibration, _ = QtGui.QFileDialog.getOpenFileName(
            window, "Calibration of the rig (camera-projector, or stereo for two cameras)", folder,
            "Calibration (*.yml *.yaml *.xml *.json)")
        if not calibration:
            return None
    second_folder = ""
    if is_stereo_calibration(calibration):
        second_folder = QtGui.QFileDialog.getExistingDirectory(
            window, "Second camera's capture folder (%s is a stereo calibration)" % os.path.basename(calibration),
            os.path.dirname(folder))
        if not second_folder:
            return None
    return folder, calibration, second_folder


class ImportCapturesCommand(Command):
    icon = "picoscan_import"
    menu = "Import capture set"
    tooltip = "Reconstruct a capture set (from 'picoscan capture', the simulator or another system) into a ScanView"

    def run(self):
        answer = _ask_capture_set()
        if answer is None:
            return None
        active_document()
        view = scan_view.create(FreeCAD.ActiveDocument, answer[0], answer[1], second_capture_folder=answer[2],
                                part_frame=True)
        FreeCADGui.SendMsgToActiveView("ViewFit")
        return view


def _cleanable(views):
    return [view for view in views if not view.Clean and captures_on_disk(view)]


class CleanCommand(Command):
    icon = "picoscan_clean"
    menu = "Clean scan"
    tooltip = ("Remove stray-light outliers, grazing points and small clusters from the selected ScanViews not "
               "cleaned yet (decoded again: their capture folders must be on disk)")

    def IsActive(self):
        return bool(_cleanable(selected_scan_views()))

    def run(self):
        for view in _cleanable(selected_scan_views()):
            view.Clean = True
            if not recompute_now(view):
                raise picoscan.Error("%s: cleaning failed: %s" % (view.Label, view.getStatusString()))
            FreeCAD.Console.PrintMessage("%s: %s\n" % (view.Label, view.CleanReport))
