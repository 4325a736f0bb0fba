# Make solid from closed meshes of growing size, timed, to show how the time grows. Run with
# FreeCAD's Python:
#   freecadcmd benchmarks/freecad_make_solid.py   (PICOSCAN_WORKBENCH=build/freecad_workbench/PicoScan;
#   PICOSCAN_CHECK_VALID=1 times OpenCASCADE's isValid() of the solids as well)
# Two series: the demo part's block (outline with the chamfer and a rounded edge, tests/test_app.py's
# outline_block_mesh) meshed at about 50 k, 100 k and 200 k facets with 20 um of vertex noise, a
# stand-in for a closed scan mesh (coplanar facets merge into planar faces); and FreeCAD's UV
# spheres, where almost nothing is flat (the curved facets are simplified within 4 x the noise
# estimated from the mesh).
import os
import sys
import time

sys.path.insert(0, os.environ.get("PICOSCAN_WORKBENCH", os.path.join(os.getcwd(), "build/freecad_workbench/PicoScan")))
import Mesh  # noqa: E402

from picoscan_wb.objects import scan_mesh  # noqa: E402
from picoscan_wb.operations import solid  # noqa: E402
from picoscan_wb.tests.test_app import outline_block_mesh  # noqa: E402

check = bool(os.environ.get("PICOSCAN_CHECK_VALID"))


def run(name, mesh, check=False):
    start = time.perf_counter()
    shape, model, _ = solid.solid_with_model(mesh, name, check_valid=False)
    elapsed = time.perf_counter() - start
    valid = ""
    if check:
        start = time.perf_counter()
        valid = " | isValid() %s in %.1f s" % (shape.isValid(), time.perf_counter() - start)
    print("%s | %d facets | %.1f s | %.3f s per 1000 facets | %d faces (%d planar regions holding %d facets) | "
          "volume %+.4f %%%s" % (name, mesh.CountFacets, elapsed, 1000 * elapsed / mesh.CountFacets, len(shape.Faces),
                                  model.merged_faces, model.merged_facets, 100 * (shape.Volume - mesh.Volume) / mesh.Volume,
                                  valid), flush=True)


for spacing in (0.54, 0.38, 0.27):
    run("block, %.2f mm facets, 20 um noise" % spacing, scan_mesh.freecad_mesh(outline_block_mesh(0.02, spacing)), check)
for sampling in (180, 250, 320):
    run("UV sphere", Mesh.createSphere(10.0, sampling), check)
sys.stdout.flush()
os._exit(0)
