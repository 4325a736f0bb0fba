"""Cloud of a scan -> real Part primitives (Plane, Cylinder, Sphere, Cone) placed where they were
measured, found by the core's CGAL Efficient RANSAC detection and refined by least squares."""
import math

import numpy
import FreeCAD
from FreeCAD import Placement, Rotation, Vector

import picoscan
from picoscan_wb.progress import run_in_background


def _vector(values):
    return Vector(float(values[0]), float(values[1]), float(values[2]))


def _rotation_to(direction, x_direction=None):
    """Rotation taking +z to `direction` (and +x to `x_direction` when given)."""
    z = _vector(direction).normalize()
    if x_direction is None:
        return Rotation(Vector(0, 0, 1), z)
    x = _vector(x_direction).normalize()
    return Rotation(x, z.cross(x), z, "ZXY")


def _add_fit_properties(obj, shape):
    obj.addProperty("App::PropertyString", "FitKind", "Fit", "Shape kind detected", 1)
    obj.addProperty("App::PropertyLength", "FitRms", "Fit", "RMS distance of the inliers to the shape", 1)
    obj.addProperty("App::PropertyInteger", "InlierCount", "Fit", "Points of the scan on this shape", 1)
    obj.FitKind = str(shape.kind).split(".")[-1]
    obj.FitRms = float(shape.rms_mm)
    obj.InlierCount = int(shape.inlier_count)


def fit_rms_mm(obj):
    """A fitted primitive's RMS in mm: FitRms, or FitRmsMm (a plain number) in documents saved before
    it had a unit; 0 for a face that was not fitted."""
    if hasattr(obj, "FitRms"):
        return float(obj.FitRms.Value)
    return float(getattr(obj, "FitRmsMm", 0.0))


def _add_plane(doc, shape, points):
    normal = numpy.asarray(shape.direction)
    inliers = points[shape.inliers].astype(numpy.float64)
    # Rectangle around the inliers in the plane, along their principal directions.
    centred = inliers - shape.point
    centred -= numpy.outer(centred @ normal, normal)
    _, _, axes = numpy.linalg.svd(centred[:: max(1, len(centred) // 20000)], full_matrices=False)
    x_axis = axes[0] - (axes[0] @ normal) * normal
    x_axis /= numpy.linalg.norm(x_axis)
    y_axis = numpy.cross(normal, x_axis)
    u, v = centred @ x_axis, centred @ y_axis
    corner = numpy.asarray(shape.point) + u.min() * x_axis + v.min() * y_axis
    obj = doc.addObject("Part::Plane", "FittedPlane")
    obj.Length = float(u.max() - u.min())
    obj.Width = float(v.max() - v.min())
    obj.Placement = Placement(_vector(corner), _rotation_to(normal, x_axis))
    return obj


def _add_cylinder(doc, shape):
    obj = doc.addObject("Part::Cylinder", "FittedCylinder")
    obj.Radius = float(shape.radius_mm)
    obj.Height = float(shape.length_mm)
    obj.Placement = Placement(_vector(shape.point), _rotation_to(shape.direction))
    return obj


def _add_sphere(doc, shape):
    obj = doc.addObject("Part::Sphere", "FittedSphere")
    obj.Radius = float(shape.radius_mm)
    obj.Placement = Placement(_vector(shape.point), Rotation())
    return obj


def _add_cone(doc, shape, points):
    axis = numpy.asarray(shape.direction)
    along = (points[shape.inliers] - shape.point) @ axis
    near, far = max(float(along.min()), 0.0), float(along.max())
    slope = math.tan(math.radians(shape.half_angle_deg))
    obj = doc.addObject("Part::Cone", "FittedCone")
    obj.Radius1 = near * slope
    obj.Radius2 = far * slope
    obj.Height = far - near
    obj.Placement = Placement(_vector(numpy.asarray(shape.point) + near * axis), _rotation_to(axis))
    return obj


def detection_options(planes=True, cylinders=True, spheres=True, cones=True, epsilon_mm=0.25, min_points=500):
    options = picoscan.ShapeDetectionOptions()
    options.planes, options.cylinders, options.spheres, options.cones = planes, cylinders, spheres, cones
    options.epsilon_mm = epsilon_mm
    options.min_points = min_points
    return options


def fit_primitives(doc, cloud, options=None, label="Fitted primitives", placement=None):
    """Detects shapes in `cloud` (picoscan.PointCloud with normals) off the GUI thread with the
    progress dialog (Cancel: picoscan.Error "cancelled", document unchanged), then adds one Part
    primitive per shape, in a group; `placement` (the scan object's) moves them from the cloud's
    frame into the document's. Returns (group, [(part object, picoscan.DetectedShape)])."""
    options = options or detection_options()
    shapes = run_in_background("Fitting primitives", lambda progress: picoscan.detect_shapes(cloud, options, progress))
    if not shapes:
        raise picoscan.Error("%s: no plane, cylinder, sphere or cone with enough points was found" % label)
    points = cloud.points
    group = doc.addObject("App::DocumentObjectGroup", "FittedPrimitives")
    group.Label = label
    created = []
    for shape in shapes:
        if shape.kind == picoscan.ShapeKind.Plane:
            obj = _add_plane(doc, shape, points)
        elif shape.kind == picoscan.ShapeKind.Cylinder:
            obj = _add_cylinder(doc, shape)
        elif shape.kind == picoscan.ShapeKind.Sphere:
            obj = _add_sphere(doc, shape)
        else:
            obj = _add_cone(doc, shape, points)
        if placement is not None:
            obj.Placement = placement.multiply(obj.Placement)
        _add_fit_properties(obj, shape)
        group.addObject(obj)
        created.append((obj, shape))
    doc.recompute()
    return group, created
