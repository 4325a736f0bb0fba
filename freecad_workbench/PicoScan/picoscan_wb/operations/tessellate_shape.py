"""The triangles of a Part shape for the core (Deviation map, Best fit), made in a separate process:
`python3 tessellate_shape.py FREECAD_LIB BREP DEFLECTION_MM OUT_NPZ`.
Part.Shape.tessellate holds Python's GIL for as long as OpenCASCADE meshes (43 s for a sphere, a
cylinder and a torus at 0.01 mm, load 13), so in FreeCAD's own process it stops the GUI from any
thread, even on a copy of the shape; a process of its own leaves the GUI answering and is stopped
at once by Cancel. Writes `vertices` (N x 3 float64) and `facets` (M x 3 int32) to OUT_NPZ and
prints one JSON line per stage ({"stage": ...})."""
import importlib
import json
import sys


def say(**fields):
    print(json.dumps(fields), flush=True)


def main(freecad_lib, path, deflection_mm, out_path):
    sys.path.append(freecad_lib)
    importlib.import_module("FreeCAD")  # FreeCAD's application first: Part alone exits silently
    import numpy
    import Part

    say(stage="reading the shape")
    shape = Part.Shape()
    shape.read(path)
    say(stage="meshing %d faces" % len(shape.Faces))
    vertices, facets = shape.tessellate(deflection_mm)
    numpy.savez(out_path, vertices=numpy.array([(v.x, v.y, v.z) for v in vertices], dtype=numpy.float64).reshape(-1, 3),
                facets=numpy.array(facets, dtype=numpy.int32).reshape(-1, 3))
    say(done=True, facets=len(facets))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4])
