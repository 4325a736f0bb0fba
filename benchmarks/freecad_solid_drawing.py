# How long FreeCAD's GUI is held by Make solid's last two steps, reading the B-rep back (FreeCAD's
# Part read holds Python's GIL) and drawing it (the view provider runs OpenCASCADE's mesher on the
# GUI thread): the B-rep as write_brep writes it (each face with its facets as its triangulation,
# read as text) against the same solid without triangulations (read from FreeCAD's binary format,
# as Make solid did before, then meshed by the view provider). UV spheres, where every facet is a
# face. Run inside FreeCAD's GUI (it exits by itself):
#   PICOSCAN_WORKBENCH=build/freecad_workbench/PicoScan QTWEBENGINE_DISABLE_SANDBOX=1 \
#     xvfb-run -a -s "-screen 0 1600x1000x24" freecad benchmarks/freecad_solid_drawing.py
# PICOSCAN_SUBDIVISIONS=60,112 (the default: 7 080 and 24 864 facets), PICOSCAN_REPEATS=3.
import os
import statistics
import sys
import tempfile
import time
import traceback

sys.path.insert(0, os.environ.get("PICOSCAN_WORKBENCH", os.path.join(os.getcwd(), "build/freecad_workbench/PicoScan")))


def main():
    import FreeCAD
    import FreeCADGui
    import Mesh
    import Part
    from PySide2 import QtWidgets

    import picoscan
    from picoscan_wb.objects.scan_mesh import core_mesh

    def settle():
        FreeCADGui.updateGui()
        QtWidgets.QApplication.processEvents()

    doc = FreeCAD.newDocument("SolidDrawing")
    folder = tempfile.mkdtemp(prefix="picoscan-drawing-")
    repeats = int(os.environ.get("PICOSCAN_REPEATS", "3"))
    for subdivisions in [int(s) for s in os.environ.get("PICOSCAN_SUBDIVISIONS", "60,112").split(",")]:
        mesh = Mesh.createSphere(10.0, subdivisions)
        text = os.path.join(folder, "solid.brep")
        binary = os.path.join(folder, "solid.bin")
        picoscan.write_brep(picoscan.planar_face_model(core_mesh(mesh)), text)
        shape = Part.Shape()
        shape.read(text)
        shape.exportBinary(binary)  # FreeCAD's binary format keeps no triangulations
        figures = {"with triangulations (text)": ([], []), "without (binary)": ([], [])}
        for _ in range(repeats):
            for name, (reads, draws) in figures.items():
                shape = Part.Shape()
                started = time.perf_counter()
                shape.read(text) if "text" in name else shape.importBinary(binary)
                reads.append(time.perf_counter() - started)
                feature = doc.addObject("Part::Feature", "Solid")
                settle()
                started = time.perf_counter()
                feature.Shape = shape
                settle()
                draws.append(time.perf_counter() - started)
                doc.removeObject(feature.Name)
                settle()
        print("%d facets, %d faces: %s; load average %.1f" % (
            mesh.CountFacets, len(shape.Faces), "; ".join(
                "%s: read %.3f s, drawing %.3f s" % (name, statistics.median(reads), statistics.median(draws))
                for name, (reads, draws) in figures.items()), os.getloadavg()[0]), file=sys.__stdout__, flush=True)


try:
    main()
    code = 0
except Exception:
    traceback.print_exc(file=sys.__stderr__)
    code = 1
sys.__stderr__.flush()
os._exit(code)
