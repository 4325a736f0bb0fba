"""Big list properties (a million points, their colours and distances) handed to and from FreeCAD in
its own storage format, through DocumentObject.restorePropertyContent and dumpPropertyContent: a
zip holding Persistence.xml and the property's binary file, as in a saved .FCStd. Setting such a
property from Python lists builds one Python object per item on the GUI thread, holding the GIL
(1 M points: about 10 s for the points and 11 s for the colours at load 7); these bytes are made
with NumPy on any thread, and FreeCAD reads them in one C++ pass (0.3 s and 0.9 s at load 7).
The layouts are those FreeCAD 0.20 writes: a little-endian uint32 count, then the items."""
import io
import re
import zipfile

import numpy


def _content(tag, payload, attributes=""):
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_STORED) as archive:
        archive.writestr("Persistence.xml", '<Content>\n<%s file="Data"%s/>\n</Content>' % (tag, attributes))
        archive.writestr("Data", payload)
    return buffer.getvalue()


def _count(items):
    return numpy.array([len(items)], dtype="<u4").tobytes()


def points_content(points):
    """A Points kernel (PropertyPointKernel) of N x 3 points, float32 x, y, z each, not moved."""
    points = numpy.ascontiguousarray(points, dtype="<f4").reshape(-1, 3)
    return _content("Points", _count(points) + points.tobytes(), ' mtrx="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"')


def colour_list_content(rgb):
    """A PropertyColorList of N x 3 uint8 RGB colours, opaque: each packed as r << 24 | g << 16 | b << 8."""
    rgb = numpy.asarray(rgb, dtype=numpy.uint8).reshape(-1, 3).astype("<u4")
    packed = (rgb[:, 0] << 24) | (rgb[:, 1] << 16) | (rgb[:, 2] << 8)
    return _content("ColorList", _count(packed) + packed.tobytes())


def float_list_content(values):
    """A PropertyFloatList, as doubles."""
    values = numpy.ascontiguousarray(values, dtype="<f8").ravel()
    return _content("FloatList", _count(values) + values.tobytes())


def points_from_content(content):
    """N x 3 float32 points in document coordinates of dumpPropertyContent("Points") (a Points
    object's kernel: its points and the placement they are moved by)."""
    with zipfile.ZipFile(io.BytesIO(bytes(content))) as archive:
        xml = archive.read("Persistence.xml").decode()
        data = [archive.read(name) for name in archive.namelist() if name != "Persistence.xml"]
    matrix = re.search(r'mtrx="([^"]*)"', xml)
    count = int(numpy.frombuffer(data[0][:4], dtype="<u4")[0]) if data else 0
    points = numpy.frombuffer(data[0][4:4 + 12 * count], dtype="<f4").reshape(-1, 3) if count else numpy.zeros((0, 3), "<f4")
    if matrix is not None:
        transform = numpy.array([float(v) for v in matrix.group(1).split()]).reshape(4, 4)
        if not numpy.allclose(transform, numpy.eye(4)):
            return (points @ transform[:3, :3].T + transform[:3, 3]).astype(numpy.float32)
    return points.astype(numpy.float32)
