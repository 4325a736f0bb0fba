# How long FreeCAD's GUI is held reading and drawing the B-rep that Make solid writes, for two
# builds of the core (e.g. main's and a branch's write_brep), in one FreeCAD process with the two
# alternated, so that both see the same machine load. UV spheres (every facet a face, unless the
# build simplifies curved regions).
# Run inside FreeCAD's GUI (it exits by itself):
#   PICOSCAN_BUILDS=/path/to/old/build/freecad_workbench/PicoScan:build/freecad_workbench/PicoScan \
#     QTWEBENGINE_DISABLE_SANDBOX=1 xvfb-run -a -s "-screen 0 1600x1000x24" freecad benchmarks/freecad_brep_drawing_ab.py
# PICOSCAN_SUBDIVISIONS=60,112 (the default: 7 080 and 24 864 facets), PICOSCAN_REPEATS=6.
import os
import statistics
import subprocess
import sys
import tempfile
import time
import traceback

# Each build's picoscan module writes its B-rep in a Python of its own (one process holds one
# module of that name); FreeCAD's Python, which the module is built for.
WRITE = "import sys; sys.path.insert(0, sys.argv[1]); import picoscan; " \
        "picoscan.write_brep(picoscan.planar_face_model(picoscan.read_mesh(sys.argv[2])), sys.argv[3])"


def main():
    import FreeCAD
    import FreeCADGui
    import Mesh
    import Part
    from PySide2 import QtWidgets

    def settle():
        FreeCADGui.updateGui()
        QtWidgets.QApplication.processEvents()

    builds = [os.path.abspath(b) for b in os.environ.get("PICOSCAN_BUILDS", "").split(":") if b]
    if len(builds) != 2:
        raise SystemExit("PICOSCAN_BUILDS: two workbench folders separated by ':', got %r" % builds)
    python = os.path.join(sys.base_prefix, "bin", "python%d.%d" % sys.version_info[:2])
    repeats = int(os.environ.get("PICOSCAN_REPEATS", "6"))
    doc = FreeCAD.newDocument("BrepDrawingAB")
    folder = tempfile.mkdtemp(prefix="picoscan-drawing-ab-")
    for subdivisions in [int(s) for s in os.environ.get("PICOSCAN_SUBDIVISIONS", "60,112").split(",")]:
        mesh = Mesh.createSphere(10.0, subdivisions)
        stl = os.path.join(folder, "sphere.stl")
        mesh.write(stl)
        paths = []
        for number, build in enumerate(builds):
            paths.append(os.path.join(folder, "solid%d.brep" % number))
            subprocess.run([python, "-c", WRITE, build, stl, paths[-1]], check=True)
        figures = {path: ([], []) for path in paths}
        faces = {}
        for repeat in range(repeats):
            for path in paths if repeat % 2 == 0 else reversed(paths):
                shape = Part.Shape()
                started = time.perf_counter()
                shape.read(path)
                figures[path][0].append(time.perf_counter() - started)
                faces[path] = len(shape.Faces)
                feature = doc.addObject("Part::Feature", "Solid")
                settle()
                started = time.perf_counter()
                feature.Shape = shape
                settle()
                figures[path][1].append(time.perf_counter() - started)
                doc.removeObject(feature.Name)
                settle()
        for build, path in zip(builds, paths):
            reads, draws = figures[path]
            print("%d facets, %d faces, %s (%.1f MB): read %.3f s, drawing %.3f s (medians of %d; drawing %s); "
                  "load average %.1f" % (mesh.CountFacets, faces[path], build, os.path.getsize(path) / 1e6,
                                         statistics.median(reads), statistics.median(draws), repeats,
                                         " ".join("%.2f" % d for d in draws), os.getloadavg()[0]),
                  file=sys.__stdout__, flush=True)


try:
    main()
    code = 0
except SystemExit as refusal:  # bad input: one line
    print(refusal, file=sys.__stderr__)
    code = 2
except BaseException:
    traceback.print_exc(file=sys.__stderr__)
    code = 1
sys.__stderr__.flush()
os._exit(code)
