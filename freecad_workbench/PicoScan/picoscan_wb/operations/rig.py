"""The rig at its calibrated poses: camera and projector frusta as wires, in the camera frame (mm)."""
import numpy
import Part
from FreeCAD import Vector

import picoscan


def frustum_corners(matrix, size, depth_mm):
    """Camera-frame corners (4 x 3) of the image at depth_mm for a pinhole of `matrix` and `size`."""
    fx, fy, cx, cy = matrix[0, 0], matrix[1, 1], matrix[0, 2], matrix[1, 2]
    width, height = size
    pixels = [(-0.5, -0.5), (width - 0.5, -0.5), (width - 0.5, height - 0.5), (-0.5, height - 0.5)]
    return numpy.array([((u - cx) / fx * depth_mm, (v - cy) / fy * depth_mm, depth_mm) for u, v in pixels])


def frustum_shape(centre, corners):
    centre = Vector(*map(float, centre))
    points = [Vector(*map(float, corner)) for corner in corners]
    edges = [Part.makeLine(centre, point) for point in points]
    edges += [Part.makeLine(points[i], points[(i + 1) % 4]) for i in range(4)]
    return Part.makeCompound(edges)


def projector_in_camera(calibration, points):
    """Projector-frame points -> camera frame (X_projector = R X_camera + T)."""
    rotation, translation = numpy.asarray(calibration.R), numpy.asarray(calibration.T)
    return (numpy.atleast_2d(points) - translation) @ rotation


def show_rig(doc, calibration_file, depth_mm=450.0):
    """Adds a group with the camera and projector frusta (both cameras' for a stereo calibration).
    Returns (group, camera, projector or second camera)."""
    if picoscan.calibration_kind(calibration_file) == picoscan.CalibrationKind.Stereo:
        return show_stereo_rig(doc, picoscan.read_stereo_calibration(calibration_file), depth_mm)
    calibration = picoscan.read_calibration(calibration_file)
    camera = doc.addObject("Part::Feature", "CameraFrustum")
    camera.Shape = frustum_shape((0, 0, 0), frustum_corners(calibration.camera_matrix, calibration.camera_size, depth_mm))
    projector_corners = frustum_corners(calibration.projector_matrix, calibration.projector_size, depth_mm)
    projector = doc.addObject("Part::Feature", "ProjectorFrustum")
    projector.Shape = frustum_shape(projector_in_camera(calibration, numpy.zeros(3))[0],
                                    projector_in_camera(calibration, projector_corners))
    group = doc.addObject("App::DocumentObjectGroup", "Rig")
    group.addObject(camera)
    group.addObject(projector)
    if hasattr(camera, "ViewObject") and camera.ViewObject is not None:
        camera.ViewObject.LineColor = (0.1, 0.4, 0.9)
        projector.ViewObject.LineColor = (0.9, 0.5, 0.1)
    doc.recompute()
    return group, camera, projector


def show_stereo_rig(doc, stereo, depth_mm=450.0):
    """Both cameras of a stereo calibration, in the first camera's frame (X_2 = R X_1 + T)."""
    first = doc.addObject("Part::Feature", "CameraFrustum")
    first.Shape = frustum_shape((0, 0, 0), frustum_corners(stereo.left_matrix, stereo.left_size, depth_mm))
    rotation, translation = numpy.asarray(stereo.R), numpy.asarray(stereo.T)

    def in_first_camera(points):
        return (numpy.atleast_2d(points) - translation) @ rotation

    second = doc.addObject("Part::Feature", "SecondCameraFrustum")
    second.Shape = frustum_shape(in_first_camera(numpy.zeros(3))[0],
                                 in_first_camera(frustum_corners(stereo.right_matrix, stereo.right_size, depth_mm)))
    group = doc.addObject("App::DocumentObjectGroup", "Rig")
    group.addObject(first)
    group.addObject(second)
    if hasattr(first, "ViewObject") and first.ViewObject is not None:
        first.ViewObject.LineColor = (0.1, 0.4, 0.9)
        second.ViewObject.LineColor = (0.1, 0.7, 0.3)
    doc.recompute()
    return group, first, second
