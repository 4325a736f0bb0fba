"""Distances and angles between fitted features (planes, cylinders, spheres from Fit primitives),
each with its uncertainty from the fits, as rows of a table that can be written as CSV.

The uncertainties are first-order estimates from each fit's RMS residual (sigma), inlier count
(n) and extent (L): a plane's offset is known to sigma / sqrt(n) and its normal to
sigma / (L sqrt(n / 12)) radians (a line of n points over L); a cylinder's axis position to
sigma sqrt(2 / n) and its direction to sigma sqrt(2) / (L sqrt(n / 12)). Two features' are
combined in quadrature. They describe the noise of the fit, not a systematic error (a scan's
calibration)."""
import csv
import math
import os

import FreeCAD

import picoscan
from picoscan_wb.operations import primitives

KINDS = ("Plane", "Cylinder", "Sphere")
PARALLEL_DEG = 2.0  # features nearer to parallel than this also get a distance
HEADER = ("Feature A", "Feature B", "Measure", "Value", "Unit", "Uncertainty")


class Feature:
    """A fitted feature in document coordinates, with what its uncertainty needs."""

    def __init__(self, obj):
        kind = getattr(obj, "FitKind", "")
        if kind not in KINDS:
            raise picoscan.Error("%s: not a fitted plane, cylinder or sphere (Fit primitives makes them)" % obj.Label)
        self.label = obj.Label
        self.kind = kind
        placement = obj.Placement
        self.direction = placement.Rotation.multVec(FreeCAD.Vector(0, 0, 1))
        sigma, count = primitives.fit_rms_mm(obj), max(int(obj.InlierCount), 3)
        if kind == "Plane":
            self.point = obj.Shape.Faces[0].CenterOfMass
            extent = math.hypot(obj.Length.Value, obj.Width.Value) / math.sqrt(2)
            self.position_sigma = sigma / math.sqrt(count)
        elif kind == "Cylinder":
            self.point = placement.Base + self.direction * (0.5 * obj.Height.Value)  # the middle of the axis
            extent = max(obj.Height.Value, 2 * obj.Radius.Value)
            self.radius = obj.Radius.Value
            self.position_sigma = sigma * math.sqrt(2.0 / count)
        else:
            self.point = placement.Base
            extent = 2 * obj.Radius.Value
            self.radius = obj.Radius.Value
            self.position_sigma = sigma * math.sqrt(3.0 / count)
        self.direction_sigma = sigma * (1 if kind == "Plane" else math.sqrt(2)) / (max(extent, 1e-9) * math.sqrt(count / 12.0))
        self.radius_sigma = sigma / math.sqrt(count)


def _angle_deg(a, b):
    return math.degrees(a.getAngle(b))


def _line_angle_deg(a, b):
    """0..90: the angle between two directions taken as lines."""
    angle = _angle_deg(a, b)
    return min(angle, 180.0 - angle)


def _quadrature(*values):
    return math.sqrt(sum(v * v for v in values))


def _axis_distance(point_a, direction_a, point_b):
    offset = point_b - point_a
    return (offset - direction_a * offset.dot(direction_a)).Length


def measure_pair(a, b):
    """[(measure, value, unit, uncertainty)] between two features."""
    rows = []
    direction_sigma_deg = math.degrees(_quadrature(a.direction_sigma, b.direction_sigma))
    if a.kind == "Sphere" or b.kind == "Sphere":
        if a.kind == b.kind:
            rows.append(("centre distance", (b.point - a.point).Length, "mm", _quadrature(a.position_sigma, b.position_sigma)))
        return rows
    if a.kind == "Plane" and b.kind == "Plane":
        angle = _line_angle_deg(a.direction, b.direction)
        rows.append(("angle", angle, "deg", direction_sigma_deg))
        if angle < PARALLEL_DEG:  # both ways, averaged: the planes' middles differ
            distance = 0.5 * (abs((b.point - a.point).dot(a.direction)) + abs((a.point - b.point).dot(b.direction)))
            rows.append(("distance", distance, "mm", _quadrature(a.position_sigma, b.position_sigma)))
        return rows
    if a.kind == "Cylinder" and b.kind == "Cylinder":
        angle = _line_angle_deg(a.direction, b.direction)
        rows.append(("axis angle", angle, "deg", direction_sigma_deg))
        if angle < PARALLEL_DEG:
            distance = 0.5 * (_axis_distance(a.point, a.direction, b.point) + _axis_distance(b.point, b.direction, a.point))
            rows.append(("axis distance", distance, "mm", _quadrature(a.position_sigma, b.position_sigma)))
        return rows
    plane, cylinder = (a, b) if a.kind == "Plane" else (b, a)
    # 90: the axis is square to the plane (a hole in a face); 0: the axis lies along it.
    angle = 90.0 - _line_angle_deg(cylinder.direction, plane.direction)
    rows.append(("axis to plane angle", angle, "deg", direction_sigma_deg))
    if angle < PARALLEL_DEG:
        rows.append(("axis to plane distance", abs((cylinder.point - plane.point).dot(plane.direction)), "mm",
                     _quadrature(a.position_sigma, b.position_sigma)))
    return rows


def measure(objects):
    """The table: one row per feature size (diameters) and per measure between two features."""
    features = [Feature(obj) for obj in objects]
    if len(features) < 2:
        raise picoscan.Error("Measurements: needs two or more fitted features, %d given" % len(features))
    rows = []
    for feature in features:
        if feature.kind in ("Cylinder", "Sphere"):
            rows.append((feature.label, "", "diameter", 2 * feature.radius, "mm", 2 * feature.radius_sigma))
    for i, a in enumerate(features):
        for b in features[i + 1:]:
            rows += [(a.label, b.label) + row for row in measure_pair(a, b)]
    return rows


def format_row(row):
    a, b, what, value, unit, sigma = row
    return "%s%s: %s %.4f %s +- %.4f" % (a, " - " + b if b else "", what, value, unit, sigma)


def write_csv(rows, path):
    """Writes the table (HEADER first) to a temporary file, then renames it onto `path`."""
    temporary = path + ".tmp"
    with open(temporary, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(HEADER)
        for a, b, what, value, unit, sigma in rows:
            writer.writerow((a, b, what, "%.6f" % value, unit, "%.6f" % sigma))
    os.replace(temporary, path)
    return path
