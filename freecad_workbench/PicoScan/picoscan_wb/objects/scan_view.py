"""ScanView: capture set + calibration + parameters -> Points (an organised scan of one camera view)."""
import FreeCAD
import Points

import picoscan
from picoscan_wb.objects import DocumentObjectProxy
from picoscan_wb.operations.reconstruct import reconstruct, stereo_summary
from picoscan_wb.progress import run_in_background

TYPE = "PicoScan::ScanView"



def _parameters(obj):
    """What the reconstruction depends on, in the order of reconstruct()'s arguments."""
    return (obj.CaptureFolder, obj.CalibrationFile, obj.ManifestFile, obj.MinContrast, obj.MinModulation,
            obj.BinaryOnly, obj.Clean, float(obj.MaxGrazingAngle), obj.SecondCaptureFolder)


def _add_stereo_properties(obj):
    """The two-camera properties (also added to ScanViews of documents saved before they existed)."""
    if not hasattr(obj, "SecondCaptureFolder"):
        obj.addProperty("App::PropertyPath", "SecondCaptureFolder", "Scan",
                        "The second camera's capture folder, needed when CalibrationFile is a stereo calibration "
                        "(two cameras; the projector only labels pixels)")
    if not hasattr(obj, "StereoReport"):
        obj.addProperty("App::PropertyString", "StereoReport", "Result",
                        "What the two cameras matched (stereo calibrations only)", 1)


def points_of(cloud):
    """FreeCAD Points from a picoscan.PointCloud (or an N x 3 array)."""
    coordinates = cloud.points if hasattr(cloud, "points") else cloud
    result = Points.Points()
    result.addPoints([tuple(point) for point in coordinates.tolist()])
    return result


class ScanView(DocumentObjectProxy):
    TYPE = TYPE

    def __init__(self, obj):
        super().__init__(obj)
        group = "Scan"
        obj.addProperty("App::PropertyPath", "CaptureFolder", group, "Folder of the capture set (images + sequence.json)")
        obj.addProperty("App::PropertyFile", "CalibrationFile", group, "Calibration (.yml): camera-projector, or stereo (two cameras, with SecondCaptureFolder)")
        obj.addProperty("App::PropertyFile", "ManifestFile", group, "sequence.json to use instead of the folder's own (foreign capture sets)")
        group = "Decoding"
        obj.addProperty("App::PropertyFloat", "MinContrast", group, "White-black contrast below this is shadow (grey levels)")
        obj.addProperty("App::PropertyFloat", "MinModulation", group, "Fringe amplitude below this is rejected (grey levels)")
        obj.addProperty("App::PropertyBool", "BinaryOnly", group, "Gray code only, ignoring the phase frames (for comparison)")
        group = "Cleaning"
        obj.addProperty("App::PropertyBool", "Clean", group, "Remove stray-light outliers, grazing points and small clusters")
        obj.addProperty("App::PropertyAngle", "MaxGrazingAngle", group, "Points seen more obliquely than this are removed when cleaning")
        group = "Result"
        obj.addProperty("App::PropertyInteger", "PointCount", group, "Points measured", 1)
        obj.addProperty("App::PropertyString", "CleanReport", group, "What cleaning removed", 1)
        _add_stereo_properties(obj)
        obj.MinContrast = 15.0
        obj.MinModulation = 4.0
        obj.MaxGrazingAngle = 80.0

    def execute(self, obj):
        # The organised view lives on the proxy, so it goes when the object goes. Not saved: the
        # document stores the Points; the view is recomputed when first needed after reopening.
        fresh, self.fresh = getattr(self, "fresh", None), None
        if fresh is not None and fresh[0] == _parameters(obj):
            view, calibration, report, statistics = fresh[1:]
        else:
            parameters = _parameters(obj)
            view, calibration, report, statistics = run_in_background(
                "Reconstructing " + obj.Label, lambda progress: reconstruct(*parameters, progress=progress))
        self.cached = (_parameters(obj), view, calibration)
        cloud = picoscan.to_point_cloud(view)
        obj.Points = points_of(cloud)
        obj.PointCount = len(cloud)
        obj.StereoReport = stereo_summary(statistics)
        obj.CleanReport = "" if report is None else (
            "removed %d: %d grazing, %d outliers, %d with few neighbours, %d in small clusters" % (
                report.removed(), report.by_grazing, report.by_statistics, report.by_radius, report.by_cluster))

    def onDocumentRestored(self, obj):
        super().onDocumentRestored(obj)
        _add_stereo_properties(obj)

    def scan_view(self, obj):
        """(organised picoscan.ScanView, picoscan.Calibration or StereoCalibration), recomputed if not in
        memory or stale."""
        cached = getattr(self, "cached", None)
        if cached is None or cached[0] != _parameters(obj):
            self.execute(obj)
            cached = self.cached
        return cached[1], cached[2]


def create(doc, capture_folder, calibration_file, name="ScanView", clean=False, binary_only=False, manifest_file="",
           second_capture_folder=""):
    """Reconstructs first and adds the object only when that worked, so bad input leaves `doc` unchanged.
    With a stereo calibration, second_capture_folder is the second camera's capture set."""
    result = run_in_background("Reconstructing", lambda progress: reconstruct(
        capture_folder, calibration_file, manifest_file, binary_only=binary_only, clean=clean,
        second_capture_folder=second_capture_folder, progress=progress))
    obj = doc.addObject("Points::FeaturePython", name)
    ScanView(obj)
    obj.CaptureFolder = capture_folder
    obj.SecondCaptureFolder = second_capture_folder
    obj.CalibrationFile = calibration_file
    obj.ManifestFile = manifest_file
    obj.Clean = clean
    obj.BinaryOnly = binary_only
    obj.Proxy.fresh = (_parameters(obj),) + result  # a reconstruction made before the object existed
    if FreeCAD.GuiUp:
        from picoscan_wb.viewproviders.view_provider import ViewProvider
        ViewProvider(obj.ViewObject, "picoscan_scan")
    obj.recompute()
    return obj
