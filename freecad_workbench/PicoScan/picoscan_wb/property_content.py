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


def normal_list_content(normals):
    """A Points::PropertyNormalList of N x 3 normals, float32 x, y, z each."""
    normals = numpy.ascontiguousarray(normals, dtype="<f4").reshape(-1, 3)
    return _content("VectorList", _count(normals) + normals.tobytes())


def _payload(content):
    """(Persistence.xml text, the first data file's bytes or b"") of a property's content."""
    with zipfile.ZipFile(io.BytesIO(bytes(content))) as archive:
        xml = archive.read("Persistence.xml").decode()
        data = [archive.read(name) for name in archive.namelist() if name != "Persistence.xml"]
    return xml, data[0] if data else b""


def _vectors(data):
    count = int(numpy.frombuffer(data[:4], dtype="<u4")[0]) if data else 0
    return numpy.frombuffer(data[4:4 + 12 * count], dtype="<f4").reshape(-1, 3) if count else numpy.zeros((0, 3), "<f4")


def normals_from_content(content):
    """N x 3 float32 normals of dumpPropertyContent of a Points::PropertyNormalList."""
    return _vectors(_payload(content)[1]).astype(numpy.float32)


def colour_list_content(rgb):
    """A PropertyColorList of N x 3 uint8 RGB colours, opaque: each packed as r << 24 | g << 16 | b << 8."""
    rgb = numpy.asarray(rgb, dtype=numpy.uint8).reshape(-1, 3).astype("<u4")
    packed = (rgb[:, 0] << 24) | (rgb[:, 1] << 16) | (rgb[:, 2] << 8)
    return _content("ColorList", _count(packed) + packed.tobytes())


def float_list_content(values):
    """A PropertyFloatList, as doubles."""
    values = numpy.ascontiguousarray(values, dtype="<f8").ravel()
    return _content("FloatList", _count(values) + values.tobytes())


def points_from_content(content, moved=True):
    """N x 3 float32 points of dumpPropertyContent("Points") (a Points object's kernel: its points
    and the placement they are moved by): in document coordinates, or as stored (moved=False: the
    frame a view provider draws them in, under the object's placement)."""
    xml, data = _payload(content)
    matrix = re.search(r'mtrx="([^"]*)"', xml) if moved else None
    points = _vectors(data)
    if matrix is not None:
        transform = numpy.array([float(v) for v in matrix.group(1).split()]).reshape(4, 4)
        if not numpy.allclose(transform, numpy.eye(4)):
            return (points @ transform[:3, :3].T + transform[:3, 3]).astype(numpy.float32)
    return points.astype(numpy.float32)
