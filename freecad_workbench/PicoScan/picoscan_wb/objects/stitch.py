"""Stitch: ScanViews -> one merged cloud (Points) in the first view's frame. The core's recipe
stitch_views aligns the views by the Mode: features on the white frames (RANSAC, trimmed
point-to-plane ICP, then all views refined together), a turntable round with the axis estimated,
a known turntable axis, or automatic (features, then the turntable round where they fall short).
Views it cannot align are reported, not forced in. Views from several placements of the part
(standing, then set down on its side) are aligned placement by placement, then the placements to
each other by shape (the core's align_placements); a placement that does not join is named with
the reason."""
import numpy
import FreeCAD

import picoscan
from picoscan_wb.objects import DocumentObjectProxy, add_or_remove, brief_input_errors, is_scan_view, millimetres
from picoscan_wb.objects.scan_view import _parameters as scan_view_parameters, add_normal_property, points_of, show_cloud
from picoscan_wb.progress import run_in_background

TYPE = "PicoScan::Stitch"

# How the views of each placement are aligned (the Mode property); the core's recipe does each.
MODES = ("Automatic", "Features", "Turntable round", "Turntable axis")
MODE_TIPS = {
    "Automatic": "Features first; a placement they leave incomplete (a plain, unpainted part gives no features) "
                 "is aligned again as one turntable round, and the way that aligns more views is kept",
    "Features": "Features on the white frames (painted or textured parts), RANSAC, ICP",
    "Turntable round": "Each placement's views are one full turntable round, in order, in equal steps; the axis is "
                       "estimated from the views themselves",
    "Turntable axis": "Each placement's views are turntable steps about a known axis (TurntableAxisPoint, "
                      "TurntableAxisDirection, TurntableStep), e.g. the one a previous Stitch found",
}


def _parameters(obj):
    # A view's own parameters count too: a changed view makes the merged cloud stale.
    return (obj.IcpMaxDistance, obj.MinOverlap, tuple(obj.PlacementOfView), obj.Mode, tuple(obj.TurntableAxisPoint),
            tuple(obj.TurntableAxisDirection), float(obj.TurntableStep)) + tuple(
        (v.Name,) + scan_view_parameters(v) for v in obj.Views)


def _add_placement_properties(obj, restored=False):
    """The several-placements and mode properties (also added to Stitches of documents saved before
    they existed; those keep the way they were computed: TurntableRound becomes the Mode)."""
    if not hasattr(obj, "PlacementOfView"):
        obj.addProperty("App::PropertyIntegerList", "PlacementOfView", "Stitch",
                        "How the part lay for each view in Views (the scan's placements, not FreeCAD's Placement): "
                        "1 for the views of the first placement (e.g. standing), 2 for those taken after the part was "
                        "set down again (e.g. on its side), ... Empty: all views are one placement")
    if not hasattr(obj, "Mode"):
        obj.addProperty("App::PropertyEnumeration", "Mode", "Registration",
                        "How each placement's views are aligned: " + "; ".join(
                            "%s: %s" % (mode, tip) for mode, tip in MODE_TIPS.items()))
        obj.Mode = list(MODES)
        obj.Mode = "Features" if restored else "Automatic"
    if hasattr(obj, "TurntableRound"):  # documents saved before Mode existed
        obj.Mode = "Turntable round" if obj.TurntableRound else "Features"
        obj.removeProperty("TurntableRound")
    if not hasattr(obj, "TurntableAxisPoint"):
        obj.addProperty("App::PropertyVectorDistance", "TurntableAxisPoint", "Registration",
                        "Mode 'Turntable axis': a point on the turntable's axis, in the first view's camera frame "
                        "(as a Stitch's AlignmentReport or 'picoscan stitch' gives it)")
        obj.addProperty("App::PropertyVector", "TurntableAxisDirection", "Registration",
                        "Mode 'Turntable axis': the axis direction (any length); the part turns right-handed about it "
                        "from one view to the next")
        obj.addProperty("App::PropertyAngle", "TurntableStep", "Registration",
                        "Mode 'Turntable axis': the turn between views; 0: one full round (360 degrees / the views "
                        "of a placement)")
    if not hasattr(obj, "PlacementReport"):
        obj.addProperty("App::PropertyStringList", "PlacementReport", "Result",
                        "Per placement: how it joined the model, or why it was left out", 1)
    add_normal_property(obj, "The merged cloud's normals")
    if not hasattr(obj, "AlignmentReport"):
        obj.addProperty("App::PropertyStringList", "AlignmentReport", "Result",
                        "Per placement, each way tried (features, turntable round, turntable axis): the views it "
                        "aligned, the first it left out and why, and which was kept; the turntable axis found", 1)


def _turntable_axis(obj, groups):
    """Mode 'Turntable axis': the core's TurntableAxis from the properties, checked."""
    direction = obj.TurntableAxisDirection
    if direction.Length < 1e-9:
        raise picoscan.Error("%s: TurntableAxisDirection must not be zero for Mode 'Turntable axis'" % obj.Label)
    step = float(getattr(obj.TurntableStep, "Value", obj.TurntableStep))
    if step == 0:
        sizes = set(len(group) for group in groups)
        if len(sizes) > 1:
            raise picoscan.Error("%s: TurntableStep: give the step between views: the placements have different "
                                 "numbers of views" % obj.Label)
        step = 360.0 / sizes.pop()
    if not 0 < step < 360:
        raise picoscan.Error("%s: TurntableStep must be above 0 and below 360 degrees (0: one full round)" % obj.Label)
    axis = picoscan.TurntableAxis()
    point = obj.TurntableAxisPoint
    axis.point_mm = (point.x, point.y, point.z)
    unit = FreeCAD.Vector(direction).normalize()
    axis.direction = (unit.x, unit.y, unit.z)
    axis.step_deg = step
    return axis


def _attempt_lines(attempts, several, outcome=True):
    """One line per way tried: what it aligned, the first view it left out and why, and (outcome)
    whether it was kept."""
    lines = []
    for attempt in attempts:
        where = "placement %d: " % (attempt.placement + 1) if several else ""
        line = "%s%s aligned %d of %d views" % (where, attempt.method, attempt.aligned_views, attempt.views)
        if attempt.problem:
            line += " (first left out: %s)" % attempt.problem
        lines.append(line + (("; kept" if attempt.kept else "; not kept") if outcome else ""))
    return lines


def _axis_line(axis):
    return ("turntable axis found: point (%.4f, %.4f, %.4f) mm, direction (%.6f, %.6f, %.6f), step %.3f deg "
            "(Mode 'Turntable axis' with these for the next scan on this rig)" % (
                tuple(axis.point_mm) + tuple(axis.direction) + (axis.step_deg,)))


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
        unlit = not hasattr(obj, "Normal")  # saved before Stitches were drawn lit by their normals
        _add_placement_properties(obj, restored=True)
        if unlit:
            # Its normals need the views stitched again (seconds, and it may not align as saved):
            # left to the user's recompute, which draws it lit. Touched (headless it stays so; the
            # GUI clears it once the document is open, so the warning says how to ask for it).
            obj.touch()
            FreeCAD.Console.PrintWarning("%s: saved without normals, so drawn unlit until recomputed (Mark to recompute, "
                                         "then Recompute)\n" % obj.Label)
            if FreeCAD.GuiUp:
                obj.ViewObject.DisplayMode = "Shaded"  # FreeCAD draws it flat while it has no normals

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
        options = picoscan.StitchOptions()
        registration = options.registration
        registration.icp_max_distance_mm = millimetres(obj.IcpMaxDistance)
        registration.min_overlap = obj.MinOverlap
        registration.turntable_round = obj.Mode == "Turntable round"
        options.registration = registration
        options.placement_of_view = _placement_of_view(obj, sources)
        options.automatic = obj.Mode == "Automatic"
        if obj.Mode == "Turntable axis":
            numbers = list(options.placement_of_view) or [0] * len(sources)
            options.turntable = _turntable_axis(obj, [[n for n in numbers if n == p] for p in sorted(set(numbers))])
        views = [source.Proxy.scan_view(source)[0] for source in sources]
        names = [v.Label for v in sources]
        stitched = run_in_background("Stitching " + obj.Label,
                                     lambda progress: picoscan.stitch_views(views, names, options, progress))
        alignment = stitched.alignment
        several = bool(options.placement_of_view)
        report = []
        for source, result, method in zip(sources, alignment.views, stitched.method_of_view):
            where = "placement %d, " % (result.placement + 1) if several else ""
            report.append("%s: %s%s, overlap %.2f, rms %.3f mm" % (source.Label, where, method, result.overlap, result.rms_mm)
                          if result.aligned else "%s: %sleft out: %s" % (source.Label, where, result.problem))
        placement_report = _placement_lines(alignment.placements)
        if alignment.aligned_count() < 2:
            raise picoscan.Error("%s: fewer than two views could be aligned: %s" % (obj.Label, "; ".join(
                _attempt_lines(stitched.attempts, several, outcome=False) +
                [line for line in placement_report if "NOT aligned" in line])))
        attempts = _attempt_lines(stitched.attempts, several)
        for placement in alignment.placements:  # a placement left out leaves the model incomplete: say so
            if not placement.aligned:
                FreeCAD.Console.PrintWarning("%s: %s NOT aligned, its views are left out: %s\n" % (
                    obj.Label, placement.name, placement.problem))
        cloud = stitched.merged
        # The axis the views turned about (found, or given): the part frame's Z.
        self.turntable = stitched.axis or options.turntable
        self.cached = (_parameters(obj), cloud)  # on the proxy: goes with the object; not saved (see scan_view)
        obj.ViewPoses = [_placement(result.pose) for result in alignment.views]
        obj.Report = report
        obj.PlacementReport = placement_report
        obj.AlignmentReport = attempts + ([_axis_line(stitched.axis)] if stitched.axis else [])
        obj.AlignedCount = alignment.aligned_count()
        show_cloud(obj, cloud)

    def merged_cloud(self, obj):
        """The merged picoscan.PointCloud (with normals), recomputed if not in memory or stale."""
        cached = getattr(self, "cached", None)
        if cached is None or cached[0] != _parameters(obj):
            self.execute(obj)
            cached = self.cached
        return cached[1]


def create(doc, views, name="Stitch", part_frame=True, placement_of_view=(), mode="Automatic", axis_point=None,
           axis_direction=None, step_deg=0.0):
    """Stitches the views (what the Stitch views task panel runs); the result lands in its part frame
    (Z up on the turntable's axis or its base plane) unless part_frame is False or none is found (then
    view 0's camera frame). placement_of_view: for views from several placements of the part, each
    view's placement (1, 2, ...). mode: one of MODES; "Turntable axis" takes axis_point (mm) and
    axis_direction in the first view's camera frame, and step_deg (0: one full round)."""
    if len(views) < 2 or not all(is_scan_view(v) for v in views):
        raise picoscan.Error("Stitch views: select two or more ScanViews")
    if mode not in MODES:
        raise picoscan.Error("Stitch views: mode must be one of %s, not %r" % (", ".join(MODES), mode))

    def setup(obj):
        Stitch(obj)
        obj.Views = list(views)
        obj.PlacementOfView = list(placement_of_view)
        obj.Mode = mode
        if axis_point is not None:
            obj.TurntableAxisPoint = FreeCAD.Vector(*axis_point)
        if axis_direction is not None:
            obj.TurntableAxisDirection = FreeCAD.Vector(*axis_direction)
        obj.TurntableStep = step_deg
        if FreeCAD.GuiUp:
            from picoscan_wb.viewproviders.view_provider import ShadedPointsViewProvider
            ShadedPointsViewProvider(obj.ViewObject, "picoscan_stitch")

    obj = add_or_remove(doc, "Points::FeaturePython", name, setup)
    if part_frame:
        from picoscan_wb.operations import datum

        try:
            datum.place_in_part_frame(obj)
            obj.purgeTouched()  # the new Placement moves its points at once: nothing left to recompute
        except picoscan.Error as error:  # the camera frame of the first view stays; say why
            FreeCAD.Console.PrintWarning("%s: left in the first camera's frame: %s\n" % (obj.Label, error))
    if FreeCAD.GuiUp:
        obj.ViewObject.DisplayMode = "Shaded"
        for view in views:
            view.ViewObject.Visibility = False
    return obj
