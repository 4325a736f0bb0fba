"""Cross-section: a plane cut of a mesh -> a Sketch of the profile (editable in Sketcher/PartDesign),
and a profile plot comparing the hybrid (Gray + phase) scan with the binary (Gray only) one."""
import os

import numpy
import FreeCAD
import Part
from FreeCAD import Placement, Rotation, Vector

import picoscan

AXES = {"X": Vector(1, 0, 0), "Y": Vector(0, 1, 0), "Z": Vector(0, 0, 1)}
MAX_SEGMENTS = 2000


def section_plane(mesh, axis, offset_mm=None):
    """(base, normal) of a plane across `axis`; through the mesh's bounding-box centre by default."""
    if axis not in AXES:
        raise picoscan.Error("%s: section axis must be one of X, Y, Z" % axis)
    normal = AXES[axis]
    centre = mesh.BoundBox.Center
    base = Vector(centre)
    if offset_mm is not None:
        base = Vector(centre.x, centre.y, centre.z)
        setattr(base, axis.lower(), float(offset_mm))
    return base, normal


def cross_section(doc, mesh_object, axis="Y", offset_mm=None, name="Section"):
    """Adds a Sketch of the section polylines, placed in the cutting plane. Raises picoscan.Error when
    the plane misses the mesh."""
    mesh = mesh_object.Mesh
    base, normal = section_plane(mesh, axis, offset_mm)
    polylines = [line for line in mesh.crossSections([(base, normal)], 1e-6)[0] if len(line) > 1]
    if not polylines:
        raise picoscan.Error("%s: the %s plane at %.2f mm does not cut the mesh" % (
            mesh_object.Label, axis, getattr(base, axis.lower())))
    placement = Placement(base, Rotation(Vector(0, 0, 1), normal))
    to_plane = placement.inverse()
    total = sum(len(line) - 1 for line in polylines)
    stride = max(1, -(-total // MAX_SEGMENTS))  # sketches stay editable: at most ~MAX_SEGMENTS segments
    segments = []
    for line in polylines:
        kept = line[::stride] + ([line[-1]] if (len(line) - 1) % stride else [])
        local = [to_plane.multVec(point) for point in kept]
        for start, end in zip(local, local[1:]):
            if (end - start).Length > 1e-6:
                segments.append(Part.LineSegment(Vector(start.x, start.y, 0), Vector(end.x, end.y, 0)))
    sketch = doc.addObject("Sketcher::SketchObject", name)
    sketch.Placement = placement
    sketch.addGeometry(segments, False)
    sketch.addProperty("App::PropertyLink", "SourceMesh", "Section", "The mesh that was cut")
    sketch.addProperty("App::PropertyFile", "ProfilePlot", "Section", "Plot of the profile (hybrid vs binary)")
    sketch.SourceMesh = mesh_object
    doc.recompute()
    return sketch


def profile_points(view, axis, position_mm, half_width_mm):
    """Points of an organised view within half_width_mm of the plane `axis` = position_mm."""
    index = "XYZ".index(axis)
    points = view.points.reshape(-1, 3)
    near = numpy.abs(points[:, index] - position_mm) < half_width_mm
    return points[near & numpy.isfinite(points).all(axis=1)]


def plot_profiles(profiles, axis, position_mm, path):
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
    plot.set_ylabel("depth z (mm)")
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
    binary, _, _ = reconstruct(scan_view_object.CaptureFolder, scan_view_object.CalibrationFile,
                               scan_view_object.ManifestFile, binary_only=True)
    depths = hybrid.points[..., 2]
    # Half a pixel footprint at the typical depth: one row (or column) of pixels per profile.
    half_width = 0.5 * float(numpy.nanmedian(depths)) / hybrid.focal_px()
    profiles = [("hybrid (Gray + phase)", profile_points(hybrid, axis, position_mm, half_width)),
                ("binary (Gray only)", profile_points(binary, axis, position_mm, half_width))]
    return plot_profiles(profiles, axis, position_mm, path)
