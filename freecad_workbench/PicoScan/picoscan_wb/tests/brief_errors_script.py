# Run by test_app's PicoScanBriefErrorsTest in a separate freecadcmd, whose console output it reads:
#   PICOSCAN_WORKBENCH=<folder> PICOSCAN_CAPTURES=<folder> PICOSCAN_CALIBRATION=<file> freecadcmd brief_errors_script.py
# or, for a stereo ScanView (test_app's PicoScanStereoTest), PICOSCAN_STEREO_CAPTURES, PICOSCAN_STEREO_SECOND and
# PICOSCAN_STEREO_CALIBRATION instead of the last two.
# Bad input met during recomputes must print one line, never a Python traceback.
import os
import sys

sys.path.insert(0, os.environ["PICOSCAN_WORKBENCH"])
import FreeCAD  # noqa: E402

import picoscan  # noqa: E402
from picoscan_wb.objects import scan_mesh, scan_view  # noqa: E402


def stereo_cleared():
    """A stereo ScanView whose SecondCaptureFolder is cleared, fresh and after save and reopen."""
    import tempfile

    doc = FreeCAD.newDocument("BriefStereo")
    view = scan_view.create(doc, os.environ["PICOSCAN_STEREO_CAPTURES"], os.environ["PICOSCAN_STEREO_CALIBRATION"],
                            second_capture_folder=os.environ["PICOSCAN_STEREO_SECOND"])
    view.SecondCaptureFolder = ""
    doc.recompute()
    print("STEREO CLEARED VALID %s: %s" % (view.isValid(), view.getStatusString()))
    view.SecondCaptureFolder = os.environ["PICOSCAN_STEREO_SECOND"]
    doc.recompute()
    name, path = view.Name, os.path.join(tempfile.mkdtemp(prefix="picoscan_brief_"), "stereo.FCStd")
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    doc = FreeCAD.openDocument(path)
    view = doc.getObject(name)
    view.SecondCaptureFolder = ""
    doc.recompute()
    print("STEREO REOPENED CLEARED VALID %s: %s" % (view.isValid(), view.getStatusString()))
    FreeCAD.closeDocument(doc.Name)
    print("DONE")
    sys.stdout.flush()
    os._exit(0)


if os.environ.get("PICOSCAN_STEREO_CALIBRATION"):
    stereo_cleared()
doc = FreeCAD.newDocument("BriefErrors")
view = scan_view.create(doc, os.environ["PICOSCAN_CAPTURES"], os.environ["PICOSCAN_CALIBRATION"])
mesh = scan_mesh.create(doc, view, pixel_step=8)
mesh.PixelStep = 0  # bad parameter met by a document recompute
doc.recompute()
print("MESH VALID %s: %s" % (mesh.isValid(), mesh.getStatusString()))
try:
    scan_mesh.create(doc, view, pixel_step=-1)  # bad parameter met by a create
except picoscan.Error as error:
    print("CREATE REFUSED: %s" % error)
view.CaptureFolder = os.path.join(os.environ["PICOSCAN_CAPTURES"], "no_such_folder")  # the stored view is used: no error at all
view.MinContrast = 99  # ... unless other decoding parameters need the captures
doc.recompute()
print("VIEW VALID %s: %s" % (view.isValid(), view.getStatusString()))
try:
    raise RuntimeError("a real bug keeps its traceback")
except RuntimeError:
    import traceback

    print("BUG TRACEBACK LINES %d" % len(traceback.format_exc().splitlines()))
print("DONE")
sys.stdout.flush()
os._exit(0)
