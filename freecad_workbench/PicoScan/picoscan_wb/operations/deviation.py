"""Deviation of a scan from a model: the scan's points and the reference's triangles go to the
core's measure_deviation (AABB tree, signed by pseudo-normals); this module only gathers them."""
import os
import shutil
import tempfile

import numpy
import Part

import picoscan
from picoscan_wb.objects import cloud_of, is_scan_view, is_stitch
from picoscan_wb.operations import tessellate_shape
from picoscan_wb.operations.placement import placed_points
from picoscan_wb.progress import run_freecad_process


def reference_reader(obj, deflection_mm=0.01):
    """reader(progress) -> picoscan.Mesh of the reference, in document coordinates: a mesh object's
    triangles, or any Part shape tessellated so that no triangle is farther than deflection_mm from
    the true surface. Call this on the GUI thread (it reads the object and checks it), the reader on
    a worker (run_in_background): a shape with curved faces is tessellated in another process
    (tessellate_shape.py; Part.Shape.tessellate holds the GIL throughout, so it would stop the GUI
    from any thread) which Cancel ends at once, a shape of planes only here; a mesh goes to the
    core through a file."""
    label = getattr(obj, "Label", str(obj))
    if obj is None:
        raise picoscan.Error("Reference: no reference model chosen")
    if hasattr(obj, "Mesh") and obj.Mesh.CountFacets > 0:
        from picoscan_wb.objects.scan_mesh import core_mesh

        mesh = obj.Mesh.copy()  # with the object's placement, which core_mesh applies
        return lambda progress: core_mesh(mesh, progress)
    if not (hasattr(obj, "Shape") and not obj.Shape.isNull() and obj.Shape.Faces):
        raise picoscan.Error("%s: the reference has no faces or triangles to measure against" % label)
    if deflection_mm <= 0:
        # The map's own property (how closely the model is tessellated), not one of the model's.
        raise picoscan.Error("Deflection: must be positive, is %g mm (how far the tessellated %s may lie from "
                             "its true surface)" % (deflection_mm, label))
    shape = obj.Shape  # carries the placement
    if all(isinstance(face.Surface, Part.Plane) for face in shape.Faces):
        # Planes only: a few triangles whatever the deflection (a box: 12, in 0.03 s at load 10),
        # against 2 to 3 s at load 10 for a FreeCAD process (benchmarks/freecad_process_startup.py).
        vertices, facets = shape.copy().tessellate(deflection_mm)
        mesh = _core_mesh([tuple(v) for v in vertices], facets, label)
        return lambda progress: mesh
    folder = tempfile.mkdtemp(prefix="picoscan_reference_")
    brep = os.path.join(folder, "reference.brep")
    shape.exportBrep(brep)  # 10 ms for a Part primitive

    def read(progress):
        try:
            triangles = os.path.join(folder, "triangles.bin")
            run_freecad_process(tessellate_shape.__file__, [brep, repr(float(deflection_mm)), triangles], progress,
                                "tessellating the reference: {}", "%s: tessellating" % label)
            vertices, facets = tessellate_shape.read_triangles(triangles)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        return _core_mesh(vertices, facets, label)
    return read


def _core_mesh(vertices, facets, label):
    if not len(facets):
        raise picoscan.Error("%s: tessellating the reference gave no triangles" % label)
    mesh = picoscan.Mesh()
    mesh.vertices = numpy.array(vertices, dtype=numpy.float32).reshape(-1, 3)
    mesh.faces = numpy.array(facets, dtype=numpy.int32).reshape(-1, 3)
    return mesh


def scan_points(obj):
    """N x 3 float32 array of the scan's points in document coordinates: a ScanView's or Stitch's
    cloud, any Points object, or a mesh's vertices."""
    label = getattr(obj, "Label", str(obj))
    if obj is None:
        raise picoscan.Error("Scan: no scan chosen")
    if is_scan_view(obj) or is_stitch(obj):
        # The core's cloud is in the scan's own frame: the object's placement moves it.
        points = numpy.asarray(cloud_of(obj).points, dtype=numpy.float32)
        return placed_points(points, obj.Placement).astype(numpy.float32, copy=False)
    # FreeCAD's Points and Mesh data come with the object's placement applied.
    if hasattr(obj, "Points") and obj.Points.CountPoints > 0:
        from picoscan_wb.property_content import points_from_content

        # FreeCAD's own bytes of the points (0.1 s for 1 M), not a Python object per point (seconds).
        return points_from_content(obj.dumpPropertyContent("Points", Compression=0))
    if hasattr(obj, "Mesh") and obj.Mesh.CountPoints > 0:
        from picoscan_wb.objects.scan_mesh import core_mesh

        # Through a file: mesh.Topology builds a Python object per point, holding the GIL (2.6 s for a
        # 460 k-facet mesh on a loaded machine against 0.14 s, benchmarks/freecad_mesh_handover.py).
        return numpy.array(core_mesh(obj.Mesh).vertices, dtype=numpy.float32)
    raise picoscan.Error("%s: the scan has no points" % label)


def options(tolerance_mm=0.05, max_distance_mm=0.0):
    if tolerance_mm <= 0:
        raise picoscan.Error("Tolerance: must be positive, is %g mm" % tolerance_mm)
    result = picoscan.DeviationOptions()
    result.tolerance_mm = tolerance_mm
    result.max_distance_mm = max_distance_mm
    return result


def summary(statistics, tolerance_mm):
    return ("mean %+.4f mm, mean |d| %.4f mm, sigma %.4f mm, p95 |d| %.4f mm, max |d| %.4f mm, %.1f %% within "
            "+-%.3f mm (%d points, %d ignored)" % (
                statistics.mean_mm, statistics.mean_abs_mm, statistics.sigma_mm, statistics.p95_abs_mm,
                statistics.max_abs_mm, 100 * statistics.within_tolerance, tolerance_mm, statistics.count,
                statistics.ignored))
