"""ScanView: capture set + calibration + parameters -> Points (an organised scan of one camera view)."""
import os
import tempfile

import FreeCAD
import numpy
import Points

import picoscan
from picoscan_wb import property_content
from picoscan_wb.objects import DocumentObjectProxy, brief_input_errors, input_errors, recompute_now, restore_tracebacks
from picoscan_wb.operations.reconstruct import check_second_folder, read_any_calibration, reconstruct, stereo_summary
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


def _decoding(obj):
    """The parameters a stored view was decoded with (the paths may change: a moved folder)."""
    return repr((obj.MinContrast, obj.MinModulation, obj.BinaryOnly, obj.Clean, float(obj.MaxGrazingAngle)))


def _add_storage(obj):
    # The decoded view (pixel grid, camera, points, normals) goes into the .FCStd, so the scan still
    # meshes, fits and stitches when the capture folder is gone (docs/formats.md, view PLY).
    obj.addProperty("App::PropertyFileIncluded", "StoredView", "Result",
                    "The decoded view kept in the document (a view PLY): used when the capture folder is gone", 1)
    obj.addProperty("App::PropertyString", "StoredDecoding", "Result", "Decoding parameters of the stored view", 1)


def _store(obj, view):
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, obj.Name + "_view.ply")
        picoscan.write_view_ply(view, path)
        obj.StoredView = path  # FreeCAD copies the file into the document
    obj.StoredDecoding = _decoding(obj)


def _stored_view(obj):
    """(view, calibration or None, None, None) from the document when the capture folders or the
    calibration are gone; None when they are there (reconstruct from them) or nothing usable is stored."""
    folders = [obj.CaptureFolder] + ([obj.SecondCaptureFolder] if obj.SecondCaptureFolder else [])
    if all(os.path.isdir(folder or "") for folder in folders) and os.path.isfile(obj.CalibrationFile or ""):
        return None
    stored = getattr(obj, "StoredView", "")
    if not stored or not os.path.isfile(stored):
        return None
    if obj.StoredDecoding != _decoding(obj):
        raise picoscan.Error("%s: capture folder %s is gone, and the view kept in the document was decoded with other "
                             "parameters; restore them or the captures" % (obj.Label, obj.CaptureFolder))
    FreeCAD.Console.PrintLog("%s: capture folder %s is gone; using the view kept in the document\n" % (
        obj.Label, obj.CaptureFolder))
    calibration = None
    if os.path.isfile(obj.CalibrationFile or ""):
        # The stored view was decoded with the calibration's kind: a stereo view needs its second folder named.
        check_second_folder(obj.CalibrationFile, obj.SecondCaptureFolder, folder_must_exist=False)
        calibration = read_any_calibration(obj.CalibrationFile)
    return picoscan.read_view_ply(stored), calibration, None, None


def points_of(cloud, placement=None):
    """FreeCAD Points from a picoscan.PointCloud (or an N x 3 array), moved by `placement`: the
    object's own, since assigning Points resets an object's Placement to the points'."""
    coordinates = cloud.points if hasattr(cloud, "points") else cloud
    result = Points.Points()
    result.addPoints([tuple(point) for point in coordinates.tolist()])
    if placement is not None:
        result.Placement = placement
    return result


def add_normal_property(obj, what):
    """The Normal property (a Points::PropertyNormalList) that FreeCAD's Shaded mode of Points lights
    the points by; `what`: whose normals they are."""
    if not hasattr(obj, "Normal"):
        obj.addProperty("Points::PropertyNormalList", "Normal", "Result",
                        "%s (the core's, one per point): the 3D view shades the points by them" % what, 1)


def show_cloud(obj, cloud):
    """A Points object's Points (moved by its Placement), Normal and PointCount from a picoscan.PointCloud
    with a normal per point. The normals go in as FreeCAD's own bytes: a Python object per normal
    would hold the GIL for seconds."""
    if len(cloud.normals) != len(cloud):
        raise picoscan.Error("%s: %d normals for %d points" % (obj.Label, len(cloud.normals), len(cloud)))
    obj.Points = points_of(cloud, obj.Placement)
    obj.restorePropertyContent("Normal", property_content.normal_list_content(cloud.normals))
    obj.PointCount = len(cloud)


def _cloud_with_normals(view):
    """The view's points with their normals: the view's own, or the core's from its pixel grid when it
    has none (a view PLY written without them). A point with no measured neighbour has no normal
    from the grid (NaN): it is drawn as if facing its camera (lit fully), not left unlit."""
    if view.normals is None or view.normals.size == 0:
        picoscan.estimate_normals(view)
    cloud = picoscan.to_point_cloud(view)
    normals = numpy.array(cloud.normals)
    missing = ~numpy.isfinite(normals).all(axis=1)
    if missing.any():
        towards_camera = numpy.asarray(view.pose)[:3, 3] - cloud.points[missing]
        normals[missing] = towards_camera / numpy.linalg.norm(towards_camera, axis=1, keepdims=True)
        cloud.normals = normals
    return cloud


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
        _add_storage(obj)
        add_normal_property(obj, "The view's normals, from its pixel grid")
        obj.MinContrast = 15.0
        obj.MinModulation = 4.0
        obj.MaxGrazingAngle = 80.0

    def onDocumentRestored(self, obj):
        super().onDocumentRestored(obj)
        _add_stereo_properties(obj)
        if not hasattr(obj, "StoredView"):  # a document saved before views were kept in it
            _add_storage(obj)
        if not hasattr(obj, "Normal"):  # a document saved before views were drawn lit by their normals
            add_normal_property(obj, "The view's normals, from its pixel grid")
            self._light_restored_view(obj)

    def _light_restored_view(self, obj):
        """Computes the normals of a view saved without them (from its stored view or captures) and draws
        it lit, as a new one. The document is not marked modified by this: FreeCAD clears that mark once
        the whole document is restored. Without its captures or stored view it stays flat, with the reason."""
        touched = "Touched" in obj.State
        try:
            self.scan_view(obj)  # recomputes the view: show_cloud sets Normal one per point
        except input_errors() as error:  # captures and stored view gone: opening goes on
            restore_tracebacks()
            FreeCAD.Console.PrintWarning("%s: saved without normals and not recomputed, so drawn unlit: %s\n" % (
                obj.Label, error))
            return
        if not touched:
            obj.purgeTouched()
        if FreeCAD.GuiUp:
            obj.ViewObject.DisplayMode = "Shaded"

    @brief_input_errors
    def execute(self, obj):
        # The organised view lives on the proxy, so it goes when the object goes. After reopening
        # it is recomputed when first needed: from the captures, or from StoredView when they are gone.
        fresh, self.fresh = getattr(self, "fresh", None), None
        cached = getattr(self, "cached", None)
        stored = None
        if fresh is not None and fresh[0] == _parameters(obj):
            view, calibration, report, statistics = fresh[1:]
        elif cached is not None and cached[0] == _parameters(obj):
            # Only the Placement changed (a best fit, a datum alignment): the points stay as decoded.
            obj.Points = points_of(picoscan.to_point_cloud(cached[1]), obj.Placement)
            return
        else:
            stored = _stored_view(obj) if hasattr(obj, "StoredView") else None
            if stored is not None:
                view, calibration, report, statistics = stored
            else:
                parameters = _parameters(obj)
                view, calibration, report, statistics = run_in_background(
                    "Reconstructing " + obj.Label, lambda progress: reconstruct(*parameters, progress=progress))
        self.cached = (_parameters(obj), view, calibration)
        if stored is None and hasattr(obj, "StoredView"):
            _store(obj, view)
        show_cloud(obj, _cloud_with_normals(view))
        if stored is not None:
            return  # the clean and stereo reports of the stored view are in the document already
        obj.StereoReport = stereo_summary(statistics)
        obj.CleanReport = "" if report is None else (
            "removed %d: %d grazing, %d outliers, %d with few neighbours, %d in small clusters" % (
                report.removed(), report.by_grazing, report.by_statistics, report.by_radius, report.by_cluster))

    def scan_view(self, obj):
        """(organised picoscan.ScanView, picoscan.Calibration), recomputed if not in memory or stale."""
        cached = getattr(self, "cached", None)
        if cached is None or cached[0] != _parameters(obj):
            self.execute(obj)
            cached = self.cached
        return cached[1], cached[2]


def create(doc, capture_folder, calibration_file, name="ScanView", clean=False, binary_only=False, manifest_file="",
           second_capture_folder="", part_frame=False):
    """Reconstructs first and adds the object only when that worked, so bad input leaves `doc` unchanged.
    With a stereo calibration, second_capture_folder is the second camera's capture set.
    With part_frame, the scan is placed Z up on its base plane (the commands do this; it stays in the
    camera's frame, with a warning, when it has no plane to stand on)."""
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
        from picoscan_wb.viewproviders.view_provider import ShadedPointsViewProvider
        ShadedPointsViewProvider(obj.ViewObject, "picoscan_scan")
    recompute_now(obj)
    if part_frame:
        from picoscan_wb.operations import datum

        try:
            datum.place_in_part_frame(obj)
            obj.purgeTouched()  # the new Placement moves its points at once: nothing left to recompute
        except picoscan.Error as error:
            FreeCAD.Console.PrintWarning("%s: left in the camera's frame: %s\n" % (obj.Label, error))
    if FreeCAD.GuiUp:
        obj.ViewObject.DisplayMode = "Shaded"
    return obj
