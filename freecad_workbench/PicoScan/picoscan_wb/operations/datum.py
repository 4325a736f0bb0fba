"""Datum alignment (3-2-1): the part's own coordinate system from three planar features, by the
core's datum_frame. The primary plane gives Z, the line where the secondary plane meets it gives X,
and a third plane (or a point) gives the origin along that line. Axes point into the material:
Z from the primary face into the part, so a part's bottom face as primary puts Z up.

A feature is (object, sub-element name or ""): a fitted plane (Fit primitives), any planar face of
a Part shape ("Face3"), or, for the origin, a vertex or any object whose Placement marks a point."""
import numpy
import FreeCAD

import picoscan
from picoscan_wb.operations import primitives


def _label(feature):
    obj, sub = feature
    return "%s%s" % (getattr(obj, "Label", obj), "." + sub if sub else "")


def _face(feature):
    obj, sub = feature
    shape = getattr(obj, "Shape", None)
    if shape is None or shape.isNull():
        raise picoscan.Error("%s: has no shape; pick a fitted plane or a planar face" % _label(feature))
    if sub:
        element = shape.getElement(sub)
        if element.ShapeType != "Face":
            raise picoscan.Error("%s: is a %s, not a face" % (_label(feature), element.ShapeType.lower()))
        return element
    if len(shape.Faces) != 1:
        raise picoscan.Error("%s: has %d faces; pick one face of it" % (_label(feature), len(shape.Faces)))
    return shape.Faces[0]


def plane_of(feature):
    """picoscan.PlaneFit of a planar feature in document coordinates, its normal pointing into the
    material (the face's outward normal reversed); the fit's RMS when the feature was fitted."""
    face = _face(feature)
    if "Plane" not in type(face.Surface).__name__:
        raise picoscan.Error("%s: is not planar (a %s); pick a plane" % (_label(feature), type(face.Surface).__name__))
    u0, u1, v0, v1 = face.ParameterRange
    outward = face.normalAt(0.5 * (u0 + u1), 0.5 * (v0 + v1))  # follows the face's orientation
    point = face.CenterOfMass
    inward = -outward
    obj = feature[0]
    return picoscan.PlaneFit(numpy.array([inward.x, inward.y, inward.z]), float(inward.dot(point)),
                             primitives.fit_rms_mm(obj), int(getattr(obj, "InlierCount", 0)))


def point_of(feature):
    """An origin point: a vertex, or an object's Placement.Base (a datum point, a fitted sphere's centre)."""
    obj, sub = feature
    if sub:
        element = obj.Shape.getElement(sub)
        if element.ShapeType != "Vertex":
            raise picoscan.Error("%s: is a %s, not a plane or a point" % (_label(feature), element.ShapeType.lower()))
        return element.Point
    return obj.Placement.Base


def _is_point(feature):
    obj, sub = feature
    if sub:
        return sub.startswith("Vertex")
    return getattr(obj, "TypeId", "") in ("Part::Sphere", "PartDesign::Point", "Part::Vertex") or \
        getattr(obj, "FitKind", "") == "Sphere"


def datum_frame(features, min_angle_deg=10.0, flip=(False, False, False)):
    """picoscan.DatumFrame (in document coordinates) of [primary, secondary, origin] features.
    `flip` reverses a plane's normal (an axis pointing out of the material instead)."""
    if len(features) != 3:
        raise picoscan.Error("Datum alignment: needs 3 features (primary plane, secondary plane, origin plane or "
                             "point), %d given" % len(features))
    planes = [plane_of(f) for f in features[:2]]
    options = picoscan.DatumOptions()
    options.min_angle_deg = min_angle_deg
    if flip[0] or flip[1]:
        planes = [_flipped(p) if f else p for p, f in zip(planes, flip)]
    try:
        if _is_point(features[2]):
            point = point_of(features[2])
            return picoscan.datum_frame(planes[0], planes[1], numpy.array([point.x, point.y, point.z]), options)
        third = plane_of(features[2])
        return picoscan.datum_frame(planes[0], planes[1], _flipped(third) if flip[2] else third, options)
    except picoscan.Error as error:
        raise picoscan.Error("Datum alignment (%s): %s" % (", ".join(_label(f) for f in features), error)) from None


def _flipped(plane):
    return picoscan.PlaneFit(-numpy.asarray(plane.normal), -plane.offset_mm, plane.rms_mm, plane.point_count)


def placement(matrix):
    """FreeCAD.Placement of a 4 x 4 rigid transform."""
    return FreeCAD.Placement(FreeCAD.Matrix(*[float(v) for v in numpy.asarray(matrix).reshape(-1)]))


def _move(objects, move):
    for obj in objects:
        obj.Placement = move.multiply(obj.Placement)


def align(moving, moving_features, fixed_features=None, carried=(), min_angle_deg=10.0):
    """Moves `moving` (and `carried`, e.g. the primitives fitted on it) so that the datum frame of
    `moving_features` lands on that of `fixed_features`, or on the document's own axes when
    fixed_features is None (a scan put into its part's coordinate system). Both frames are checked
    before anything moves. Returns (moved frame, fixed frame or None, the move as a Placement)."""
    frame = datum_frame(moving_features, min_angle_deg)
    fixed = datum_frame(fixed_features, min_angle_deg) if fixed_features is not None else None
    move = placement(frame.part_from_scan)
    if fixed is not None:
        move = placement(fixed.part_from_scan).inverse().multiply(move)
    objects = {obj.Name: obj for obj in [moving] + list(carried)}  # each moves once
    _move(objects.values(), move)
    return frame, fixed, move


def frame_report(frame):
    report = "origin (%.3f, %.3f, %.3f) mm; angles between datums %.3f" % (
        frame.origin[0], frame.origin[1], frame.origin[2], frame.primary_secondary_deg)
    if frame.primary_tertiary_deg:
        report += ", %.3f, %.3f" % (frame.primary_tertiary_deg, frame.secondary_tertiary_deg)
    return report + " deg"


def place_in_part_frame(obj, options=None):
    """Puts a ScanView or Stitch into its part frame (the core's part_frame: Z up on the turntable's
    axis, else on its base plane), replacing its Placement. Returns the picoscan.PartFrame; its
    basis is kept in the object's PartFrame property. Raises picoscan.Error, leaving it in place."""
    from picoscan_wb.objects import cloud_of
    from picoscan_wb.progress import run_in_background

    cloud = cloud_of(obj)  # in the object's own frame (a camera's)
    turntable = getattr(obj.Proxy, "turntable", None)
    result = run_in_background("Finding the part frame of " + obj.Label, lambda progress: picoscan.part_frame(
        cloud, turntable, options or picoscan.PartFrameOptions(), progress))
    if not hasattr(obj, "PartFrame"):
        obj.addProperty("App::PropertyString", "PartFrame", "Placement", "What placed the scan in its part frame", 1)
    obj.Placement = placement(result.frame.part_from_scan)
    obj.PartFrame = result.basis
    return result
