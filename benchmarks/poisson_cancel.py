# The GUI test's long Poisson (the shaft's ScanView from the half-resolution seed rig, 462 613 points,
# sample spacing SPACING mm), outside FreeCAD: each stage's start time, and, with CANCEL_AT, the delay
# from the first progress report after CANCEL_AT seconds that answers False (Cancel) to the call's return.
#   PYTHONPATH=build/freecad_workbench/PicoScan /usr/bin/python3 benchmarks/poisson_cancel.py SPACING [CANCEL_AT]
import os
import sys
import tempfile
import time

import picoscan
from picoscan_wb.operations import reconstruct, simulate

spacing = float(sys.argv[1])
cancel_at = float(sys.argv[2]) if len(sys.argv) > 2 else None
folder = os.path.join(tempfile.gettempdir(), "picoscan_poisson_cancel_shaft")
if not os.path.isdir(folder):
    simulate.simulate_scan(folder, simulate.shaft_scene(), camera_scale=0.5)
view = reconstruct.reconstruct(folder, os.path.join(folder, "calibration.yml"))[0]
cloud = picoscan.to_point_cloud(view)
options = picoscan.MeshOptions()
options.method = picoscan.MeshMethod.Poisson
options.sample_spacing_mm = spacing
options.target_faces = 0
print("%d points, sample spacing %.2f mm" % (len(cloud.points), spacing), flush=True)
stages, asked = [], {}
start = time.monotonic()


def progress(fraction, stage):
    now = time.monotonic()
    if not stages or stages[-1] != stage:
        stages.append(stage)
        print("  %7.1f s  %s" % (now - start, stage), flush=True)
    if cancel_at is not None and now - start > cancel_at:
        asked.setdefault("at", now)
        return False
    return True


try:
    mesh = picoscan.mesh_points(cloud, options, progress)
    print("%d faces in %.1f s" % (len(mesh.faces), time.monotonic() - start))
except picoscan.Error as error:
    if "at" not in asked:
        raise
    print("Cancel answered at %.1f s (in '%s'); the call returned %.3f s later: %s" % (
        asked["at"] - start, stages[-1], time.monotonic() - asked["at"], error))
