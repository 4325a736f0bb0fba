"""Cross-section: a plane cut of a mesh -> a Sketch of the profile (editable in Sketcher/PartDesign),
and a profile plot comparing the hybrid (Gray + phase) scan with the binary (Gray only) one."""
import os

import numpy
import FreeCAD
import Part
from FreeCAD import Placement, Rotation, Vector

import picoscan
from picoscan_wb.operations.placement import placed_points
from picoscan_wb.progress import cancel_point, run_in_background

AXES = {"X": Vector(1, 0, 0), "Y": Vector(0, 1, 0), "Z": Vector(0, 0, 1)}


def section_plane(mesh, axis, offset_mm=None):
    """(base, normal) of a plane across `axis` at offset_mm (by default through the mesh's
    bounding-box centre). The base is the document's origin moved onto the plane, so that the
    sketch's own origin and axes are the document's (the part frame's): its coordinates are the
    part's, as in a sketch on FreeCAD's XY plane with an offset."""
    if axis not in AXES:
        raise picoscan.Error("%s: section axis must be one of X, Y, Z" % axis)
    normal = AXES[axis]
    position = getattr(mesh.BoundBox.Center, axis.lower()) if offset_mm is None else float(offset_mm)
    base = Vector(0, 0, 0)
    setattr(base, axis.lower(), position)
    return base, normal


def _plane_axes(base, axis):
    """(placement of the cutting plane, its u axis, its v axis)."""
    placement = Placement(base, Rotation(Vector(0, 0, 1), AXES[axis]))
    return placement, placement.Rotation.multVec(Vector(1, 0, 0)), placement.Rotation.multVec(Vector(0, 1, 0))


def scan_behind(mesh_object):
    """(the scan's picoscan.PointCloud, its label) a mesh was made from (a ScanMesh's Source: a
    ScanView or a Stitch), or (None, why none) for any other mesh. Read on the GUI thread."""
    from picoscan_wb.objects import cloud_of, is_scan_mesh, is_scan_view, is_stitch

    source = getattr(mesh_object, "Source", None) if is_scan_mesh(mesh_object) else None
    if source is None or not (is_scan_view(source) or is_stitch(source)):
        return None, "%s was not meshed from a scan in this document" % mesh_object.Label
    return placed_cloud(cloud_of(source), source.Placement), source.Label


def placed_cloud(cloud, placement):
    """The cloud moved by `placement`, into the frame of the mesh made from it (a ScanMesh takes its
    Source's Placement): the core checks that the scan lies on the mesh before its noise sets the
    tolerance (check_scan_of_mesh)."""
    if placement.isIdentity():
        return cloud
    moved = picoscan.PointCloud()
    moved.points = placed_points(numpy.asarray(cloud.points, dtype=float), placement).astype(numpy.float32)
    if len(cloud.normals):
        turn = Placement(Vector(), placement.Rotation)
        moved.normals = placed_points(numpy.asarray(cloud.normals, dtype=float), turn).astype(numpy.float32)
    return moved


def fitted_section(mesh, label, axis, offset_mm=None, tolerance_mm=0.0, band_mm=picoscan.DEFAULT_SECTION_BAND_MM, progress=None,
                   scan=None):
    """(placement of the cutting plane, picoscan.MeshSectionFit) of a FreeCAD mesh (not a document
    object: this runs on the worker thread). The core's one call for the whole section
    (picoscan.section_mesh): the default tolerance (5 x the noise of `scan`, the picoscan.PointCloud
    the mesh was made from, when given: a mesher that flattens the faces leaves their cut nanometres
    of noise; else from the cut), the cut and its Band (band_mm = 0: the one cut), the polylines judged
    together (one noise and tolerance for all; crumbs too small or too noisy to be a feature of the
    part in `fits.left_out`, with the reason) and the report, with the line saying where the
    tolerance came from (tolerance_from)."""
    from picoscan_wb.objects.scan_mesh import core_mesh

    options = fit_options(tolerance_mm)
    cancel_point(progress, 0.0, "cutting the mesh")
    core = core_mesh(mesh, progress)
    base, _ = section_plane(mesh, axis, offset_mm)
    placement, u_axis, v_axis = _plane_axes(base, axis)
    try:
        section = picoscan.section_mesh(core, tuple(base), tuple(u_axis), tuple(v_axis), band_mm, options, progress, scan)
    except picoscan.Error as error:
        if str(error).startswith("cancelled"):
            raise
        raise picoscan.Error("%s, %s plane at %.2f mm: %s" % (label, axis, getattr(base, axis.lower()), error))
    return placement, section


def tolerance_origin(section, scan_label):
    """Where the sketch's tolerance came from, in one line (its FitToleranceFrom): the core's line, with the
    scan named, or why there was none."""
    if section.tolerance_source == picoscan.SectionToleranceSource.ScanNoise:
        return "the scan %s: %s" % (scan_label, section.tolerance_from)
    if section.tolerance_source == picoscan.SectionToleranceSource.CutNoise:
        return "no scan noise known (%s): %s" % (scan_label, section.tolerance_from)
    return section.tolerance_from


def left_out_report(fits):
    """One line per polyline of the section left out of the sketch: which, how many points, where, why."""
    return ["Left out: " + picoscan.left_out_text(left) for left in fits.left_out]


def fit_options(tolerance_mm=0.0):
    options = picoscan.SectionFitOptions()
    if tolerance_mm < 0:
        raise picoscan.Error("Tolerance: must be 0 (from the scan's noise) or positive, is %g mm" % tolerance_mm)
    options.tolerance_mm = tolerance_mm
    return options


def _vector(point):
    return Vector(float(point[0]), float(point[1]), 0)


def _geometry(element):
    """(Part geometry, sketch point id where the element starts, where it ends) in the polyline's order."""
    import math

    kind = element.kind
    if kind == picoscan.SectionElementKind.Line:
        return Part.LineSegment(_vector(element.start), _vector(element.end)), 1, 2
    circle = Part.Circle(_vector(element.centre), Vector(0, 0, 1), float(element.radius_mm))
    if kind == picoscan.SectionElementKind.Circle:
        return circle, None, None
    angle = lambda p: math.atan2(p[1] - element.centre[1], p[0] - element.centre[0])  # noqa: E731
    start, end = angle(element.start), angle(element.end)
    # Sketcher arcs run counter-clockwise from their start point (1) to their end point (2).
    low, high, ids = (start, end, (1, 2)) if element.counter_clockwise else (end, start, (2, 1))
    if high <= low:
        high += 2 * math.pi
    return Part.ArcOfCircle(circle, low, high), ids[0], ids[1]


class _Groups:
    """Union-find of directions (lines) or radii (arcs): constraints that would only repeat what the
    others already imply are not added (the Sketcher calls them redundant)."""

    def __init__(self):
        self.parent = {}

    def find(self, item):
        self.parent.setdefault(item, item)
        while self.parent[item] != item:
            item = self.parent[item]
        return item

    def join(self, a, b):
        root_a, root_b = self.find(a), self.find(b)
        if root_a == root_b:
            return False
        self.parent[root_b] = root_a
        return True


def _key_points(geometry):
    if hasattr(geometry, "StartPoint"):
        return [geometry.StartPoint, geometry.EndPoint]
    return [geometry.Center, geometry.Center + Vector(geometry.Radius, 0, 0)]


def _try_constraint(sketch, constraint, max_move_mm):
    """Adds the constraint and keeps it only when the sketch still solves, without redundancy, and no
    point moves by more than max_move_mm (the solver can satisfy a contradiction by collapsing an
    element); otherwise the constraint is removed and the geometry put back."""
    saved = sketch.Geometry
    sketch.addConstraint(constraint)
    moved = 0.0
    answer = sketch.solve()
    if answer == 0:
        for before, after in zip(saved, sketch.Geometry):
            for p, q in zip(_key_points(before), _key_points(after)):
                moved = max(moved, (p - q).Length)
    if answer != 0 or moved > max_move_mm:
        sketch.delConstraint(sketch.ConstraintCount - 1)
        sketch.Geometry = saved
        return False
    return True


def add_fitted_geometry(sketch, fit):
    """Adds the fitted lines, arcs and circles of one polyline to the sketch, joined by coincident or
    tangent constraints, with the horizontal, vertical, parallel, perpendicular and equal-radius
    constraints the core found to keep every point within the tolerance. Returns the report lines."""
    import Sketcher

    Snap = picoscan.SectionConstraintKind
    placed = []
    report = []
    for element in fit.elements:
        geometry, start_id, end_id = _geometry(element)
        index = sketch.addGeometry(geometry, False)
        placed.append((index, start_id, end_id))
        # The core's line: size with its standard error, residuals, tangency, the Band's part (or why none).
        report.append("Edge%d: %s" % (index + 1, picoscan.section_element_text(element)))
    # The constraints may move the fitted geometry by about the tolerance; much more means they fight.
    max_move = 10 * fit.tolerance_mm + 0.01

    def constrain(*arguments):
        return _try_constraint(sketch, Sketcher.Constraint(*arguments), max_move)

    count = len(fit.elements)
    joints = count if fit.closed else count - 1
    for j in range(joints if count > 1 else 0):
        k = (j + 1) % count
        (a, _, a_end), (b, b_start, _) = placed[j], placed[k]
        if fit.elements[j].tangent_to_next and constrain("Tangent", a, a_end, b, b_start):
            continue
        constrain("Coincident", a, a_end, b, b_start)
    directions, radii = _Groups(), _Groups()
    perpendicular = set()
    axis_kinds = {Snap.Horizontal: "Horizontal", Snap.Vertical: "Vertical"}
    for snap in sorted(fit.constraints, key=lambda c: int(c.kind)):
        first = placed[snap.first][0]
        if snap.kind in axis_kinds:
            if directions.find(axis_kinds[snap.kind]) != directions.find(first) and \
                    constrain(axis_kinds[snap.kind], first):
                directions.join(axis_kinds[snap.kind], first)
            continue
        second = placed[snap.second][0]
        if snap.kind == Snap.Parallel:
            if directions.find(first) != directions.find(second) and \
                    constrain("Parallel", first, second):
                directions.join(first, second)
        elif snap.kind == Snap.Perpendicular:
            pair = frozenset((directions.find(first), directions.find(second)))
            implied = pair == frozenset((directions.find("Horizontal"), directions.find("Vertical")))
            if len(pair) == 2 and pair not in perpendicular and not implied and \
                    constrain("Perpendicular", first, second):
                perpendicular.add(pair)
        elif snap.kind == Snap.EqualRadius:
            if radii.find(first) != radii.find(second) and constrain("Equal", first, second):
                radii.join(first, second)
    return report


def cross_section(doc, mesh_object, axis="Y", offset_mm=None, name="Section", tolerance_mm=0.0,
                  band_mm=picoscan.DEFAULT_SECTION_BAND_MM):
    """Adds a Sketch of the section, placed in the cutting plane: lines, arcs and circles fitted to
    the cut within tolerance_mm (0: from the scan's noise), joined and constrained, ready to edit in
    Sketcher and to pad. All polylines of the cut share one noise and tolerance; those too small or
    too noisy to be a feature of the part are left out of the sketch and listed, with the reason, in
    its LeftOut property (and the Report view). With band_mm > 0 (by default 3 mm) each element is
    refitted with the points of 16 parallel cuts within +- band_mm of the plane wherever they follow
    it (a pad's sides): one cut of a scan mesh gives a short line's direction to about 0.1 degrees,
    the band to 0.04; band_mm = 0 fits the one cut. An element whose cuts lie off it by amounts that
    trend with their height (a drafted wall, a cone, a sphere) keeps to its own cut, and its FitReport
    line says why. Each element's report gives its standard error. Raises picoscan.Error (document unchanged) when the plane misses the mesh. The cut and the fit run off the GUI thread with the progress dialog (Cancel:
    picoscan.Error "cancelled", document unchanged)."""
    mesh, label = mesh_object.Mesh.copy(), mesh_object.Label  # the worker reads no document object
    scan, scan_label = scan_behind(mesh_object) if tolerance_mm == 0 else (None, "")
    placement, section = run_in_background("Cross-section of " + label, lambda progress: fitted_section(
        mesh, label, axis, offset_mm, tolerance_mm, band_mm, progress, scan))
    fits = section.fits
    sketch = doc.addObject("Sketcher::SketchObject", name)
    try:
        sketch.Placement = placement
        report = []
        for fit in fits.fits:
            lines = add_fitted_geometry(sketch, fit)
            if fit.tolerance_mm > fits.tolerance_mm:  # a measured hole in a mesh whose sides were flattened
                lines = ["%s; its loop's noise %.4f mm is above the section's tolerance: fitted within its own %.4f mm" % (
                    line, fit.noise_mm, fit.tolerance_mm) for line in lines]
            report += lines
        sketch.addProperty("App::PropertyLink", "SourceMesh", "Section", "The mesh that was cut")
        # Set after the sketch is made, it changes no geometry: an output (8: Prop_Output), which does not
        # mark the sketch as needing a recompute.
        sketch.addProperty("App::PropertyFile", "ProfilePlot", "Section", "Plot of the profile (hybrid vs binary)", 8)
        sketch.addProperty("App::PropertyLength", "FitTolerance", "Section", "Largest distance of a section point to its element")
        sketch.addProperty("App::PropertyLength", "FitNoise", "Section",
                           "Noise (sigma) of the scan the mesh was made from, measured on its points; 0: none known")
        sketch.addProperty("App::PropertyString", "FitToleranceFrom", "Section", "Where FitTolerance came from")
        sketch.addProperty("App::PropertyStringList", "FitReport", "Section", "Per element: kind, size, points, residuals")
        sketch.addProperty("App::PropertyLength", "FitBand", "Section", "Elements refitted with parallel cuts within +- this (0: one cut)")
        sketch.addProperty("App::PropertyStringList", "LeftOut", "Section",
                           "Polylines of the cut left out of the sketch (too small or too noisy to be a feature), and why")
        sketch.SourceMesh = mesh_object
        sketch.FitTolerance = fits.tolerance_mm
        sketch.FitNoise = section.scan_noise_mm  # never the cut's: a flattened mesh's is nanometres, no measure of the scan
        sketch.FitToleranceFrom = tolerance_origin(section, scan_label)
        sketch.FitReport = report
        sketch.FitBand = band_mm
        sketch.LeftOut = left_out_report(fits)
        for name in ("FitTolerance", "FitNoise", "FitToleranceFrom", "FitReport", "FitBand", "LeftOut"):
            sketch.setEditorMode(name, 1)  # shown, not edited: they describe the fit
        doc.recompute()
        if not sketch.isValid():
            raise picoscan.Error("%s: the fitted sketch does not solve: %s" % (mesh_object.Label, sketch.getStatusString()))
    except Exception:
        doc.removeObject(sketch.Name)
        raise
    FreeCAD.Console.PrintLog("%s: the core's report of the section:\n    %s\n" % (sketch.Label, "\n    ".join(section.report)))
    if section.tolerance_source == picoscan.SectionToleranceSource.CutNoise:
        FreeCAD.Console.PrintWarning("%s: %s\n" % (sketch.Label, sketch.FitToleranceFrom))
    for line in list(sketch.LeftOut) + [line for line in sketch.FitReport if "not prismatic" in line]:
        FreeCAD.Console.PrintWarning("%s: %s\n" % (sketch.Label, line))
    return sketch


def profile_points(view, axis, position_mm, half_width_mm, placement=None):
    """Points of an organised view within half_width_mm of the plane `axis` = position_mm, in the
    document's coordinates when the scan's `placement` is given."""
    index = "XYZ".index(axis)
    points = view.points.reshape(-1, 3)
    points = placed_points(points, placement)
    near = numpy.abs(points[:, index] - position_mm) < half_width_mm
    return points[near & numpy.isfinite(points).all(axis=1)]


def plot_profiles(profiles, axis, position_mm, path, camera_frame=True):
    """Saves a plot of depth (z) along the section for each (label, points) in `profiles` as PNG."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib import pyplot

    along = 0 if axis != "X" else 1
    figure, plot = pyplot.subplots(figsize=(8, 4.5), dpi=100)
    for label, points in profiles:
        order = numpy.argsort(points[:, along])
        plot.plot(points[order, along], points[order, 2], ".", markersize=1.5, label="%s (%d points)" % (label, len(points)))
    plot.set_xlabel("%s (mm)" % "XYZ"[along])
    plot.set_ylabel("depth z (mm)" if camera_frame else "z (mm)")
    if camera_frame:  # depth grows away from the camera: the nearest surface on top
        plot.invert_yaxis()
    plot.set_title("Profile at %s = %.2f mm" % (axis, position_mm))
    plot.legend(markerscale=6)
    plot.grid(True, alpha=0.3)
    figure.tight_layout()
    temporary = path + ".tmp.png"
    figure.savefig(temporary)
    pyplot.close(figure)
    os.replace(temporary, path)
    return path


def hybrid_vs_binary_plot(scan_view_object, axis, position_mm, path):
    """The seed's comparison: the same capture set decoded with Gray code + phase (hybrid) and with
    Gray code only (binary), both profiles across the plane in one plot. Returns the PNG path."""
    from picoscan_wb.operations.reconstruct import reconstruct

    hybrid, calibration = scan_view_object.Proxy.scan_view(scan_view_object)
    folders = (scan_view_object.CaptureFolder, scan_view_object.CalibrationFile, scan_view_object.ManifestFile,
               getattr(scan_view_object, "SecondCaptureFolder", ""))
    placement = scan_view_object.Placement

    def work(progress):  # off the GUI thread: decoding the captures again takes seconds
        binary = reconstruct(*folders[:3], binary_only=True, second_capture_folder=folders[3], progress=progress)[0]
        depths = hybrid.points[..., 2]
        # Half a pixel footprint at the typical depth: one row (or column) of pixels per profile.
        half_width = 0.5 * float(numpy.nanmedian(depths)) / hybrid.focal_px()
        profiles = [("hybrid (Gray + phase)", profile_points(hybrid, axis, position_mm, half_width, placement)),
                    ("binary (Gray only)", profile_points(binary, axis, position_mm, half_width, placement))]
        cancel_point(progress, 1.0, "plotting the profiles")
        return plot_profiles(profiles, axis, position_mm, path, camera_frame=placement.isIdentity())
    return run_in_background("Profile plot", work)
