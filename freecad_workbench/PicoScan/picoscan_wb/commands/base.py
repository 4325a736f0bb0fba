"""What every PicoScan command shares: resources with an icon, selection helpers, and running an
action so that bad input shows a message box and leaves the document as it was."""
import os

import FreeCAD
import FreeCADGui

import picoscan
from picoscan_wb import icon_path
from picoscan_wb.objects import has_mesh, input_errors, is_scan_view, restore_tracebacks

# Errors that come from the user's input or files; anything else is a bug and propagates.
INPUT_ERRORS = input_errors()


def show_message(title, text, warning=False):
    from PySide import QtGui

    box = QtGui.QMessageBox.warning if warning else QtGui.QMessageBox.critical
    box(FreeCADGui.getMainWindow(), title, text)


def run_guarded(title, action):
    """Runs action() in one undo transaction. On bad input: a message box, the objects the action
    added are removed, the transaction is aborted, and None is returned."""
    doc = FreeCAD.ActiveDocument
    before = set(o.Name for o in doc.Objects) if doc else set()
    if doc:
        doc.openTransaction(title)
    try:
        result = action()
    except INPUT_ERRORS as error:
        restore_tracebacks()
        if doc:
            doc.abortTransaction()
            for name in [o.Name for o in doc.Objects if o.Name not in before]:
                doc.removeObject(name)
        FreeCAD.Console.PrintError("PicoScan %s: %s\n" % (title, error))
        show_message("PicoScan: " + title, str(error))
        return None
    if doc:
        doc.commitTransaction()
    return result


def active_document():
    return FreeCAD.ActiveDocument or FreeCAD.newDocument("Scan")


def selected(predicate):
    return [obj for obj in FreeCADGui.Selection.getSelection() if predicate(obj)]


def selected_scan_views():
    return selected(is_scan_view)


def captures_on_disk(view):
    """Whether a ScanView's capture folders are still there (a reopened document's may be gone: it then
    recomputes from the view kept in it, but cannot decode again or show the captures)."""
    folders = [view.CaptureFolder] + ([view.SecondCaptureFolder] if view.SecondCaptureFolder else [])
    return all(os.path.isdir(folder or "") for folder in folders)


def selected_meshes():
    return selected(has_mesh)


class Command:
    """Subclasses set icon, menu, tooltip and implement run(); IsActive defaults to always."""

    icon = ""
    menu = ""
    tooltip = ""

    def GetResources(self):
        return {"Pixmap": icon_path(self.icon), "MenuText": self.menu, "ToolTip": self.tooltip}

    def IsActive(self):
        return True

    def Activated(self):
        run_guarded(self.menu, self.run)

    def run(self):
        raise NotImplementedError
