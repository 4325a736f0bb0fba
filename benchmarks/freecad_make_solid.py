# Make solid from closed meshes of growing size, timed (FreeCAD's own mesh -> solid path beside it
# for the small sizes), to show how the time grows. Run with FreeCAD's Python:
#   freecadcmd benchmarks/freecad_make_solid.py   (PICOSCAN_WORKBENCH=build/freecad_workbench/PicoScan,
#   PICOSCAN_CHECK_VALID=1 to time OpenCASCADE's isValid() of the largest solid as well)
import os
import sys
import time

sys.path.insert(0, os.environ.get("PICOSCAN_WORKBENCH", os.path.join(os.getcwd(), "build/freecad_workbench/PicoScan")))
import Mesh  # noqa: E402
import Part  # noqa: E402

from picoscan_wb.operations import solid  # noqa: E402

print("facets | PicoScan make solid | per 1000 facets | volume vs mesh | FreeCAD makeShapeFromMesh + makeSolid")
for sampling in (60, 120, 180, 250, 320):
    mesh = Mesh.createSphere(10.0, sampling)
    start = time.perf_counter()
    shape = solid.solid_of_mesh(mesh, "sphere")
    elapsed = time.perf_counter() - start
    peer = "-"
    if mesh.CountFacets <= 10000:
        start = time.perf_counter()
        faces = Part.Shape()
        faces.makeShapeFromMesh(mesh.Topology, 0.01)
        Part.makeSolid(Part.makeShell(faces.Faces))
        peer = "%.1f s" % (time.perf_counter() - start)
    print("%d | %.1f s | %.3f s | %+.4f %% | %s" % (mesh.CountFacets, elapsed, 1000 * elapsed / mesh.CountFacets,
                                                   100 * (shape.Volume - mesh.Volume) / mesh.Volume, peer), flush=True)
if os.environ.get("PICOSCAN_CHECK_VALID"):  # OpenCASCADE's BRepCheck of the largest solid: minutes
    start = time.perf_counter()
    valid = shape.isValid()
    print("isValid() of the %d-face solid: %s in %.1f s" % (len(shape.Faces), valid, time.perf_counter() - start), flush=True)
sys.stdout.flush()
os._exit(0)
