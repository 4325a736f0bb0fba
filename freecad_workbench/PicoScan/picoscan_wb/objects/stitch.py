"""Stitch: ScanViews -> one merged cloud (Points) in the first view's frame. The core's recipe
stitch_views registers the views (features on the white frames, RANSAC, trimmed point-to-plane
ICP, then all views refined together) and merges them; views it cannot register are reported,
not forced in. Views from several placements of the part (standing, then set down on its side)
are aligned placement by placement, then the placements to each other by shape (the core's
align_placements); a placement that does not join is named with the reason."""
import numpy
import FreeCAD

import picoscan
from picoscan_wb.objects import DocumentObjectProxy, add_or_remove, brief_input_errors, is_scan_view, millimetres
from picoscan_wb.objects.scan_view import _parameters as scan_view_parameters, points_of
from picoscan_wb.progress import run_in_background

TYPE = "PicoScan::Stitch"

def _parameters(obj):
    # A view's own parameters count too: a changed view makes the merged cloud stale.
    return (obj.IcpMaxDistance, obj.MinOverlap, tuple(obj.PlacementOfView), obj.TurntableRound) + tuple(
        (v.Name,) + scan_view_parameters(v) for v in obj.Views)


def _add_placement_properties(obj):
    """The several-placements properties (also added to Stitches of documents saved before they existed)."""
    if not hasattr(obj, "PlacementOfView"):
        obj.addProperty("App::PropertyIntegerList", "PlacementOfView", "Stitch",
                        "How the part lay for each view in Views (the scan's placements, not FreeCAD's Placement): "
                        "1 for the views of the first placement (e.g. standing), 2 for those taken after the part was "
                        "set down again (e.g. on its side), ... Empty: all views are one placement")
    if not hasattr(obj, "TurntableRound"):
        obj.addProperty("App::PropertyBool", "TurntableRound", "Registration",
                        "The views of each placement are one full turntable round, in order, in equal steps; the axis "
                        "is found from the views themselves (plain, unpainted parts need this)")
    if not hasattr(obj, "PlacementReport"):
        obj.addProperty("App::PropertyStringList", "PlacementReport", "Result",
                        "Per placement: how it joined the model, or why it was left out", 1)


def _placement_of_view(obj, sources):
    """PlacementOfView (numbered from 1, as the report names them) as the core's placement_of_view
    (from 0); empty for one placement."""
    numbers = list(obj.PlacementOfView)
    if not numbers:
        return []
    if len(numbers) != len(sources):
        raise picoscan.Error("%s: PlacementOfView has %d entries for %d views; give one placement number per view" % (
            obj.Label, len(numbers), len(sources)))
    highest = 0
    for source, number in zip(sources, numbers):
        if number < 1 or number > highest + 1:
            raise picoscan.Error("%s: PlacementOfView: %s has placement %d; number the placements 1, 2, ... in the "
                                 "order of the views" % (obj.Label, source.Label, number))
        highest = max(highest, number)
    return [number - 1 for number in numbers] if highest > 1 else []


def _placement_lines(placements):
    """One line per placement, as picoscan stitch prints them."""
    lines = []
    for index, placement in enumerate(placements):
        if not placement.aligned:
            lines.append("%s: NOT aligned: %s" % (placement.name, placement.problem or "no view of it aligned"))
        elif index == 0:
            lines.append("%s: the model frame, %d views" % (placement.name, placement.aligned_views))
        else:
            lines.append("%s: aligned to the others, %d views: residual %.4f mm (its views' own %.4f mm), overlap %.0f %%" % (
                placement.name, placement.aligned_views, placement.rms_mm, placement.noise_mm,
                100 * min(1.0, placement.overlap)))
    return lines


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
        _add_placement_properties(obj)
        options = picoscan.RegistrationOptions()
        obj.IcpMaxDistance = options.icp_max_distance_mm
        obj.MinOverlap = options.min_overlap

    def onDocumentRestored(self, obj):
        super().onDocumentRestored(obj)
        _add_placement_properties(obj)

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
        registration.turntable_round = obj.TurntableRound
        options.registration = registration
        options.placement_of_view = _placement_of_view(obj, sources)
        names = [v.Label for v in sources]
        stitched = run_in_background("Stitching " + obj.Label,
                                     lambda progress: picoscan.stitch_views(views, names, options, progress))
        alignment = stitched.alignment
        several = bool(options.placement_of_view)
        report = []
        for source, result in zip(sources, alignment.views):
            where = "placement %d, " % (result.placement + 1) if several else ""
            report.append("%s: %soverlap %.2f, rms %.3f mm" % (source.Label, where, result.overlap, result.rms_mm)
                          if result.aligned else "%s: %sleft out: %s" % (source.Label, where, result.problem))
        placement_report = _placement_lines(alignment.placements)
        if alignment.aligned_count() < 2:
            raise picoscan.Error("%s: fewer than two views could be registered (%s)" % (obj.Label, "; ".join(
                placement_report + report)))
        for placement in alignment.placements:  # a placement left out leaves the model incomplete: say so
            if not placement.aligned:
                FreeCAD.Console.PrintWarning("%s: %s NOT aligned, its views are left out: %s\n" % (
                    obj.Label, placement.name, placement.problem))
        cloud = stitched.merged
        self.turntable = stitched.axis  # the axis the views turned about, if they did: the part frame's Z
        self.cached = (_parameters(obj), cloud)  # on the proxy: goes with the object; not saved (see scan_view)
        obj.ViewPoses = [_placement(result.pose) for result in alignment.views]
        obj.Report = report
        obj.PlacementReport = placement_report
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


def create(doc, views, name="Stitch", part_frame=True, placement_of_view=(), turntable_round=False):
    """Stitches the views; the result lands in its part frame (Z up on the turntable's axis or
    its base plane) unless part_frame is False or none is found (then view 0's camera frame).
    placement_of_view: for views from several placements of the part, each view's placement
    (1, 2, ...); turntable_round: each placement's views are one turntable round."""
    if len(views) < 2 or not all(is_scan_view(v) for v in views):
        raise picoscan.Error("Stitch views: select two or more ScanViews")

    def setup(obj):
        Stitch(obj)
        obj.Views = list(views)
        obj.PlacementOfView = list(placement_of_view)
        obj.TurntableRound = turntable_round
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
