"""Where the seconds of a FreeCAD helper process go (Deviation map's tessellate_shape.py, Make
solid's brep_check.py: run_freecad_process in progress.py). Run with FreeCAD's Python:
`freecadcmd benchmarks/freecad_process_startup.py` (PICOSCAN_WORKBENCH: the staged workbench
folder, default build/freecad_workbench/PicoScan). Prints, for ROUNDS runs each: the child's own
phases (interpreter up, import FreeCAD, import numpy, import Part, reading and tessellating a
Part cylinder at 0.01 mm) in a bare child, then run_freecad_process of tessellate_shape.py end to
end on the same cylinder, as the Deviation map runs it."""
import os
import statistics
import subprocess
import sys
import tempfile
import time

import FreeCAD
import Part

ROUNDS = 5
workbench = os.environ.get("PICOSCAN_WORKBENCH", os.path.join(os.getcwd(), "build", "freecad_workbench", "PicoScan"))
sys.path.insert(0, workbench)
from picoscan_wb.operations import tessellate_shape  # noqa: E402
from picoscan_wb.progress import run_freecad_process  # noqa: E402

python = os.path.join(sys.base_prefix, "bin", "python%d.%d" % sys.version_info[:2])
library = os.path.dirname(Part.__file__)
PHASES = r'''
import time, sys, importlib
t = [time.time()]
sys.path.append(sys.argv[1])
importlib.import_module("FreeCAD"); t.append(time.time())
import numpy; t.append(time.time())
import Part; t.append(time.time())
shape = Part.Shape(); shape.read(sys.argv[2]); shape.tessellate(0.01); t.append(time.time())
print(" ".join("%.3f" % v for v in t))
'''
with tempfile.TemporaryDirectory() as folder:
    brep = os.path.join(folder, "cylinder.brep")
    Part.makeCylinder(12.5, 40).exportBrep(brep)
    phases = {name: [] for name in ("interpreter", "import FreeCAD", "import numpy", "import Part", "read + tessellate", "child total")}
    for _ in range(ROUNDS):
        started = time.time()
        out = subprocess.run([python, "-c", PHASES, library, brep], capture_output=True, text=True, check=True).stdout
        t = [float(v) for v in out.split()]
        for name, value in zip(phases, [t[0] - started] + [b - a for a, b in zip(t, t[1:])] + [t[-1] - started]):
            phases[name].append(value)
    for name, values in phases.items():
        print("bare child, %-18s median %.3f s  (%s)" % (name, statistics.median(values), " ".join("%.3f" % v for v in values)))
    runs = []
    for _ in range(ROUNDS):
        started = time.time()
        run_freecad_process(tessellate_shape.__file__, [brep, "0.01", os.path.join(folder, "triangles.bin")], None, "{}", "tessellating")
        runs.append(time.time() - started)
    print("run_freecad_process(tessellate_shape.py), cylinder at 0.01 mm: median %.3f s  (%s)" % (
        statistics.median(runs), " ".join("%.3f" % v for v in runs)))
print("load: %s" % open("/proc/loadavg").read().strip())
