"""Stitch: ScanViews -> one merged cloud (Points) in the first view's frame. The core's recipe
stitch_views registers the views (features on the white frames, RANSAC, trimmed point-to-plane
ICP, then all views refined together) and merges them; views it cannot register are reported,
not forced in."""
import numpy
import FreeCAD

import picoscan
from picoscan_wb.objects import DocumentObjectProxy, add_or_remove, brief_input_errors, is_scan_view, millimetres
from picoscan_wb.objects.scan_view import _parameters as scan_view_parameters, points_of
from picoscan_wb.progress import run_in_background

TYPE = "PicoScan::Stitch"

def _parameters(obj):
    # A view's own parameters count too: a changed view makes the merged cloud stale.
    return (obj.IcpMaxDistance, obj.MinOverlap) + tuple((v.Name,) + scan_view_parameters(v) for v in obj.Views)


def _placement(pose):
    matrix = FreeCAD.Matrix(*[float(value) for value in numpy.asarray(pose).reshape(-1)])
    return FreeCAD.Placement(matrix)


class Stitch(DocumentObjectProxy):
    TYPE = TYPE

    def __init__(self, obj):
        super().__init__(obj)
        obj.addProperty("App::PropertyLinkList", "Views", "Stitch", "ScanViews to register; the first defines the model frame")
        obj.addProperty("App::PropertyLength", "IcpMaxDistance", "Registration", "Point pairs farther apart than this are never used")
        obj.addProperty("App::PropertyFloat", "MinOverlap", "Registration", "Share of a view's points that must have a partner")
        obj.addProperty("App::PropertyInteger", "AlignedCount", "Result", "Views registered and merged", 1)
        obj.addProperty("App::PropertyPlacementList", "ViewPoses", "Result", "View -> model pose of each view", 1)
        obj.addProperty("App::PropertyStringList", "Report", "Result", "Per view: overlap and residual, or why it was left out", 1)
        obj.addProperty("App::PropertyInteger", "PointCount", "Result", "Points in the merged cloud", 1)
        options = picoscan.RegistrationOptions()
        obj.IcpMaxDistance = options.icp_max_distance_mm
        obj.MinOverlap = options.min_overlap

    @brief_input_errors
    def execute(self, obj):
        cached = getattr(self, "cached", None)
        if cached is not None and cached[0] == _parameters(obj):
            # Only the Placement changed (a datum alignment): the registration stands.
            obj.Points = points_of(cached[1], obj.Placement)
            return
        sources = list(obj.Views)
        if len(sources) < 2 or not all(is_scan_view(v) for v in sources):
            raise picoscan.Error("%s: Views must hold two or more ScanViews" % obj.Label)
        views = [source.Proxy.scan_view(source)[0] for source in sources]
        options = picoscan.StitchOptions()
        registration = options.registration
        registration.icp_max_distance_mm = millimetres(obj.IcpMaxDistance)
        registration.min_overlap = obj.MinOverlap
        options.registration = registration
        names = [v.Label for v in sources]
        stitched = run_in_background("Stitching " + obj.Label,
                                     lambda progress: picoscan.stitch_views(views, names, options, progress))
        alignment = stitched.alignment
        report = []
        for source, result in zip(sources, alignment.views):
            report.append("%s: overlap %.2f, rms %.3f mm" % (source.Label, result.overlap, result.rms_mm) if result.aligned
                          else "%s: left out: %s" % (source.Label, result.problem))
        if alignment.aligned_count() < 2:
            raise picoscan.Error("%s: fewer than two views could be registered (%s)" % (obj.Label, "; ".join(report)))
        cloud = stitched.merged
        self.turntable = stitched.axis  # the axis the views turned about, if they did: the part frame's Z
        self.cached = (_parameters(obj), cloud)  # on the proxy: goes with the object; not saved (see scan_view)
        obj.ViewPoses = [_placement(result.pose) for result in alignment.views]
        obj.Report = report
        obj.AlignedCount = alignment.aligned_count()
        obj.Points = points_of(cloud, obj.Placement)
        obj.PointCount = len(cloud)

    def merged_cloud(self, obj):
        """The merged picoscan.PointCloud (with normals), recomputed if not in memory or stale."""
        cached = getattr(self, "cached", None)
        if cached is None or cached[0] != _parameters(obj):
            self.execute(obj)
            cached = self.cached
        return cached[1]


def create(doc, views, name="Stitch", part_frame=True):
    """Stitches the views; the result lands in its part frame (Z up on the turntable's axis or
    its base plane) unless part_frame is False or none is found (then view 0's camera frame)."""
    if len(views) < 2 or not all(is_scan_view(v) for v in views):
        raise picoscan.Error("Stitch views: select two or more ScanViews")

    def setup(obj):
        Stitch(obj)
        obj.Views = list(views)
        if FreeCAD.GuiUp:
            from picoscan_wb.viewproviders.view_provider import ViewProvider
            ViewProvider(obj.ViewObject, "picoscan_stitch")

    obj = add_or_remove(doc, "Points::FeaturePython", name, setup)
    if part_frame:
        from picoscan_wb.operations import datum

        try:
            datum.place_in_part_frame(obj)
        except picoscan.Error as error:  # the camera frame of the first view stays; say why
            FreeCAD.Console.PrintWarning("%s: left in the first camera's frame: %s\n" % (obj.Label, error))
    if FreeCAD.GuiUp:
        for view in views:
            view.ViewObject.Visibility = False
    return obj
