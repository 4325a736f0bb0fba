"""Points kept in a scan's own frame, moved by its FreeCAD Placement into the document's frame."""
import numpy


def placed_points(points, placement):
    """`points` (N x 3) moved by `placement`; the same array when there is none or it is the identity."""
    if placement is None or placement.isIdentity():
        return points
    matrix = numpy.array(placement.toMatrix().A, dtype=float).reshape(4, 4)
    return points @ matrix[:3, :3].T + matrix[:3, 3]
