"""Deviation of a scan from a model: the scan's points and the reference's triangles go to the
core's measure_deviation (AABB tree, signed by pseudo-normals); this module only gathers them."""
import numpy

import picoscan
from picoscan_wb.objects import cloud_of, is_scan_view, is_stitch


def reference_mesh(obj, deflection_mm=0.01):
    """picoscan.Mesh of the reference: a mesh object's triangles, or any Part shape tessellated so
    that no triangle is farther than deflection_mm from the true surface. In document coordinates."""
    label = getattr(obj, "Label", str(obj))
    if obj is None:
        raise picoscan.Error("Reference: no reference model chosen")
    if hasattr(obj, "Mesh") and obj.Mesh.CountFacets > 0:
        from picoscan_wb.objects.scan_mesh import core_mesh

        return core_mesh(obj.Mesh)  # written with the object's placement applied
    if hasattr(obj, "Shape") and not obj.Shape.isNull() and obj.Shape.Faces:
        if deflection_mm <= 0:
            raise picoscan.Error("%s: Deflection must be positive" % label)
        vertices, facets = obj.Shape.tessellate(deflection_mm)  # Shape carries the placement
    else:
        raise picoscan.Error("%s: the reference has no faces or triangles to measure against" % label)
    if not facets:
        raise picoscan.Error("%s: tessellating the reference gave no triangles" % label)
    reference = picoscan.Mesh()
    reference.vertices = numpy.array([(v.x, v.y, v.z) for v in vertices], dtype=numpy.float32)
    reference.faces = numpy.array(facets, dtype=numpy.int32)
    return reference


def scan_points(obj):
    """N x 3 float32 array of the scan's points in document coordinates: a ScanView's or Stitch's
    cloud, any Points object, or a mesh's vertices."""
    label = getattr(obj, "Label", str(obj))
    if obj is None:
        raise picoscan.Error("Scan: no scan chosen")
    if is_scan_view(obj) or is_stitch(obj):
        # The core's cloud is in the scan's own frame: the object's placement moves it.
        points = numpy.asarray(cloud_of(obj).points, dtype=numpy.float32)
        if not obj.Placement.isIdentity():
            matrix = numpy.array(obj.Placement.toMatrix().A).reshape(4, 4)
            points = (points @ matrix[:3, :3].T + matrix[:3, 3]).astype(numpy.float32)
        return points
    # FreeCAD's Points and Mesh data come with the object's placement applied.
    if hasattr(obj, "Points") and obj.Points.CountPoints > 0:
        return numpy.array([(p.x, p.y, p.z) for p in obj.Points.Points], dtype=numpy.float32)
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
