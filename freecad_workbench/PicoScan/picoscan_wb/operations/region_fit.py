"""Fitting where the user points: a plane, cylinder, sphere or cone fitted to the region of a scan
around a picked point (or to given point indices), by the core's `grow_face` (the face at the point,
grown as the kind that fits it), `select_region` and `fit_region`.
The core chooses the kind from the residuals against the scan's noise (a flat chamfer is a plane),
holds constraints to another fitted feature (parallel, perpendicular, coaxial) and snaps diameters
to nominal sizes on request. The result is an ordinary Part primitive, like Fit primitives'."""
import FreeCAD

import picoscan

from picoscan_wb.operations import primitives

KINDS = {"plane": picoscan.ShapeKind.Plane, "cylinder": picoscan.ShapeKind.Cylinder,
         "sphere": picoscan.ShapeKind.Sphere, "cone": picoscan.ShapeKind.Cone}
CONSTRAINTS = {"parallel": picoscan.FitConstraint.Parallel, "perpendicular": picoscan.FitConstraint.Perpendicular,
               "coaxial": picoscan.FitConstraint.Coaxial}


def reference_axis(feature):
    """(point, direction) of a fitted feature (or any Part::Plane/Cylinder/Cone/Sphere) in document
    coordinates: a plane's normal, a cylinder's or cone's axis, a sphere's centre."""
    if feature.TypeId not in ("Part::Plane", "Part::Cylinder", "Part::Cone", "Part::Sphere"):
        raise picoscan.Error("%s: a reference must be a fitted plane, cylinder, cone or sphere" % feature.Label)
    placement = feature.Placement
    return placement.Base, placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))


def region_options(kind=None, noise_mm=0.0, constraint=None, reference=None, placement=None,
                   snap_step_mm=0.0, snap_tolerance_mm=0.05):
    options = picoscan.RegionFitOptions()
    if kind:
        if kind not in KINDS:
            raise picoscan.Error("kind: %r is not one of %s" % (kind, ", ".join(KINDS)))
        options.automatic = False
        options.kind = KINDS[kind]
    if noise_mm < 0:
        raise picoscan.Error("noise_mm: must not be negative")
    options.noise_mm = noise_mm
    if constraint:
        if constraint not in CONSTRAINTS:
            raise picoscan.Error("constraint: %r is not one of %s" % (constraint, ", ".join(CONSTRAINTS)))
        if reference is None:
            raise picoscan.Error("constraint: %s needs a reference feature" % constraint)
        point, direction = reference_axis(reference)
        # Into the scan's own frame, where the cloud's points are.
        inverse = (placement or FreeCAD.Placement()).inverse()
        point, direction = inverse.multVec(point), inverse.Rotation.multVec(direction)
        options.constraint = CONSTRAINTS[constraint]
        options.reference_point = tuple(point)
        options.reference_direction = tuple(direction)
    options.snap_step_mm = snap_step_mm
    options.snap_tolerance_mm = snap_tolerance_mm
    return options


def pick_region(cloud, seed, radius_mm=30.0, grow=True, placement=None, max_gap_mm=1.0):
    """Indices of the cloud's points around `seed` (document coordinates; `placement` is the scan
    object's): within radius_mm of it and, with grow, the face the point is on up to its edges, grown
    as the plane, sphere, cylinder or cone that fits it best (the core's grow_face: neighbours within
    max_gap_mm that lie on the fitted shape within 3 x the scan's noise)."""
    selection = picoscan.RegionSelection()
    selection.radius_mm = radius_mm
    selection.grow = grow
    selection.max_gap_mm = max_gap_mm
    local = (placement or FreeCAD.Placement()).inverse().multVec(FreeCAD.Vector(*seed))
    return picoscan.select_region(cloud, tuple(local), selection)


def picked_options(region="grown", radius_mm=30.0, box_half_size_mm=(5.0, 5.0, 5.0), placement=None, **fit_options):
    """picoscan.PickedFitOptions for the core's fit_at_point: region "grown" (the face under the point,
    within radius_mm, grown as the kind that fits it; a point on an edge or a face too small to tell
    its kind is refused with the reason), "ball" (every point within radius_mm) or "box" (box_half_size_mm along the
    document's axes, around the point); fit_options as for region_options."""
    options = picoscan.PickedFitOptions()
    selection = picoscan.grown_face_selection()
    if region not in REGIONS:
        raise picoscan.Error("region: %r is not one of %s" % (region, ", ".join(REGIONS)))
    selection.radius_mm = radius_mm
    selection.grow = region == "grown"
    if region == "box":
        selection.box_half_size_mm = tuple(box_half_size_mm)
        # The box's axes are the document's, seen from the scan's own frame: the rows of its rotation.
        matrix = (placement or FreeCAD.Placement()).Rotation.toMatrix()
        selection.box_axes = ((matrix.A11, matrix.A12, matrix.A13), (matrix.A21, matrix.A22, matrix.A23),
                              (matrix.A31, matrix.A32, matrix.A33))
    options.selection = selection
    options.fit = region_options(placement=placement, **fit_options)
    picoscan.validate(options)
    return options


REGIONS = ("grown", "ball", "box")


def grown_face(cloud, seed, options, placement=None, progress=None):
    """The face the grown region of `options` (picked_options) takes at `seed` (document coordinates):
    picoscan.GrownFace, the points fit_at_point fits (for the panel's preview)."""
    local = (placement or FreeCAD.Placement()).inverse().multVec(FreeCAD.Vector(*seed))
    return picoscan.grow_face(cloud, tuple(local), options.selection, options.fit, progress)


def fit_at_point(cloud, seed, options, placement=None, progress=None):
    """The core's recipe on `seed` given in document coordinates (`placement` is the scan object's):
    returns picoscan.PickedFit. Raises picoscan.Error for bad options or a region no kind fits."""
    local = (placement or FreeCAD.Placement()).inverse().multVec(FreeCAD.Vector(*seed))
    return picoscan.fit_at_point(cloud, tuple(local), options, progress=progress)


def fit_in_lasso(cloud, document_to_screen, polygon, options, placement=None, progress=None):
    """The core's recipe on the points under `polygon` (screen pixels) for the 4 x 4 map
    `document_to_screen` (rows; numpy array); `placement` is the scan object's."""
    import numpy

    matrix = (placement or FreeCAD.Placement()).toMatrix()
    document_from_cloud = numpy.array(matrix.A).reshape(4, 4)
    cloud_to_screen = numpy.asarray(document_to_screen, dtype=float) @ document_from_cloud
    return picoscan.fit_in_lasso(cloud, [tuple(map(float, row)) for row in cloud_to_screen],
                                 [tuple(map(float, p)) for p in polygon], options, progress=progress)


def add_fitted(doc, cloud, fit, placement=None, label=None):
    """Adds the Part primitive of a picoscan.RegionFit (in the scan's frame, moved by `placement`),
    with FitKind, FitRms, InlierCount and FitReport. Returns the object."""
    shape = fit.shape
    points = cloud.points
    if shape.kind == picoscan.ShapeKind.Plane:
        obj = primitives._add_plane(doc, shape, points)
    elif shape.kind == picoscan.ShapeKind.Cylinder:
        obj = primitives._add_cylinder(doc, shape)
    elif shape.kind == picoscan.ShapeKind.Sphere:
        obj = primitives._add_sphere(doc, shape)
    else:
        obj = primitives._add_cone(doc, shape, points)
    if label:
        obj.Label = label
    if placement is not None:
        obj.Placement = placement.multiply(obj.Placement)
    primitives._add_fit_properties(obj, shape)
    obj.addProperty("App::PropertyString", "FitReport", "Fit", "The kinds' RMS and why this one was chosen", 1)
    obj.FitReport = fit.report
    doc.recompute()
    return obj


def fit_region(doc, cloud, region, options=None, placement=None, label=None):
    """Adds the Part primitive fitted to cloud's points `region`; returns (object, picoscan.RegionFit).
    Raises picoscan.Error (document unchanged) when no kind fits or a constraint cannot hold."""
    fit = picoscan.fit_region(cloud, list(region), options or picoscan.RegionFitOptions())
    return add_fitted(doc, cloud, fit, placement, label), fit
