"""The triangles of a Part shape for the core (Deviation map, Best fit), made in a separate process:
`python3 -S tessellate_shape.py FREECAD_LIB BREP DEFLECTION_MM OUT_FILE`.
Part.Shape.tessellate holds Python's GIL for as long as OpenCASCADE meshes (43 s for a sphere, a
cylinder and a torus at 0.01 mm, load 13), so in FreeCAD's own process it stops the GUI from any
thread, even on a copy of the shape; a process of its own leaves the GUI answering and is stopped
at once by Cancel. Writes OUT_FILE (read_triangles reads it): the vertex and facet counts (two
little-endian uint32), the vertices (N x 3 float64), the facets (M x 3 int32); with the standard
library's array, not NumPy, whose import was 0.6 to 1.1 s of the process's 2.5 to 3.7 s at load 10
(benchmarks/freecad_process_startup.py). Prints one JSON line per stage ({"stage": ...})."""
import array
import importlib
import json
import sys


def say(**fields):
    print(json.dumps(fields), flush=True)


def read_triangles(path):
    """(vertices N x 3 float64, facets M x 3 int32) of a file main wrote."""
    import numpy

    with open(path, "rb") as stream:
        vertex_count, facet_count = numpy.fromfile(stream, dtype="<u4", count=2)
        vertices = numpy.fromfile(stream, dtype="<f8", count=3 * int(vertex_count)).reshape(-1, 3)
        facets = numpy.fromfile(stream, dtype="<i4", count=3 * int(facet_count)).reshape(-1, 3)
    return vertices, facets


def main(freecad_lib, path, deflection_mm, out_path):
    sys.path.append(freecad_lib)
    importlib.import_module("FreeCAD")  # FreeCAD's application first: Part alone exits silently
    import Part

    say(stage="reading the shape")
    shape = Part.Shape()
    shape.read(path)
    say(stage="meshing %d faces" % len(shape.Faces))
    vertices, facets = shape.tessellate(deflection_mm)
    counts = array.array("I", [len(vertices), len(facets)])
    coordinates = array.array("d", [c for v in vertices for c in (v.x, v.y, v.z)])
    corners = array.array("i", [i for facet in facets for i in facet])
    if sys.byteorder != "little":
        for values in (counts, coordinates, corners):
            values.byteswap()
    with open(out_path, "wb") as stream:
        for values in (counts, coordinates, corners):
            values.tofile(stream)
    say(done=True, facets=len(facets))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4])
