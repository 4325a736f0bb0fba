# How long handing a FreeCAD mesh to the core takes (scan_mesh.core_mesh: Cross-section, Make solid
# and Deviation map start with it), and how long Cancel can go unheard in it. Three ways, on UV
# spheres (Mesh.createSphere):
#   STL file:  FreeCAD writes a binary STL, picoscan.read_mesh reads it and merges the corners
#              of the triangles back into shared vertices;
#   PLY file:  FreeCAD writes a binary PLY (shared vertices and index triangles), read_mesh reads it;
#   Topology:  mesh.Topology (Python lists of points and index triangles) into NumPy arrays, into
#              picoscan.Mesh; no file, but all of it in Python with the GIL held: nothing else in
#              FreeCAD's Python runs meanwhile (in the GUI: the GUI thread), and nothing can cancel it.
# "unheard" is the longest stretch without a progress report (the only moments Cancel is heard):
# FreeCAD's write for the files (it cannot be stopped), between two reports of the reader, or the
# whole hand-over for Topology.
# The other way (scan_mesh.freecad_mesh: the core writes a file, Mesh.Mesh reads it, holding the
# GIL throughout): a binary STL against a binary PLY. Headless:
#   PICOSCAN_WORKBENCH=build/freecad_workbench/PicoScan freecadcmd benchmarks/freecad_mesh_handover.py
# PICOSCAN_SUBDIVISIONS=480 (the default: 459 840 facets, GUI test k4's sphere), PICOSCAN_REPEATS=5.
import os
import statistics
import sys
import tempfile
import time
import traceback

sys.path.insert(0, os.environ.get("PICOSCAN_WORKBENCH", os.path.join(os.getcwd(), "build/freecad_workbench/PicoScan")))


def main():
    import Mesh
    import numpy

    import picoscan

    class Reports:
        """A progress callback that keeps the longest time between two calls (or the start and a call)."""

        def __init__(self):
            self.last = time.perf_counter()
            self.longest = 0.0

        def __call__(self, fraction=None, stage=None):
            now = time.perf_counter()
            self.longest = max(self.longest, now - self.last)
            self.last = now
            return True

    def through_file(mesh, folder, suffix):
        reports = Reports()
        path = os.path.join(folder, "mesh" + suffix)
        mesh.write(path)
        core = picoscan.read_mesh(path, reports)
        reports()
        return core, reports.longest

    def through_topology(mesh, folder):
        started = time.perf_counter()
        points, facets = mesh.Topology
        core = picoscan.Mesh()
        core.vertices = numpy.array([(p.x, p.y, p.z) for p in points], dtype=numpy.float32)
        core.faces = numpy.array(facets, dtype=numpy.int32)
        return core, time.perf_counter() - started

    ways = {"STL file": lambda mesh, folder: through_file(mesh, folder, ".stl"),
            "PLY file": lambda mesh, folder: through_file(mesh, folder, ".ply"),
            "Topology": through_topology}
    def back_to_freecad(core, folder, suffix):
        path = os.path.join(folder, "mesh" + suffix)
        (picoscan.write_stl if suffix == ".stl" else picoscan.write_ply)(core, path)
        started = time.perf_counter()
        mesh = Mesh.Mesh(path)
        return mesh, time.perf_counter() - started

    repeats = int(os.environ.get("PICOSCAN_REPEATS", "5"))
    for subdivisions in [int(s) for s in os.environ.get("PICOSCAN_SUBDIVISIONS", "480").split(",")]:
        mesh = Mesh.createSphere(10.0, subdivisions)
        figures = {name: ([], []) for name in ways}
        shapes = set()
        for _ in range(repeats):
            for name, way in ways.items():
                with tempfile.TemporaryDirectory() as folder:
                    started = time.perf_counter()
                    core, unheard = way(mesh, folder)
                    figures[name][0].append(time.perf_counter() - started)
                    figures[name][1].append(unheard)
                shapes.add((name, len(core.vertices), len(core.faces)))
        print("%d facets, %d points (the core's meshes: %s): %s; load average %.1f" % (
            mesh.CountFacets, mesh.CountPoints, ", ".join("%s %d vertices %d faces" % s for s in sorted(shapes)),
            "; ".join("%s %.3f s (unheard up to %.3f s)" % (name, statistics.median(times), max(unheard))
                      for name, (times, unheard) in figures.items()), os.getloadavg()[0]),
            file=sys.__stdout__, flush=True)
        back = {".stl": ([], []), ".ply": ([], [])}
        for _ in range(repeats):
            for suffix, (times, reads) in back.items():
                with tempfile.TemporaryDirectory() as folder:
                    started = time.perf_counter()
                    freecad, read = back_to_freecad(core, folder, suffix)
                    times.append(time.perf_counter() - started)
                    reads.append(read)
                if (freecad.CountPoints, freecad.CountFacets) != (mesh.CountPoints, mesh.CountFacets):
                    raise RuntimeError("%s: FreeCAD read %d points and %d facets" % (
                        suffix, freecad.CountPoints, freecad.CountFacets))
        print("back to FreeCAD: %s; load average %.1f" % ("; ".join(
            "%s %.3f s (FreeCAD's read, holding the GIL, %.3f s)" % (suffix, statistics.median(times), statistics.median(reads))
            for suffix, (times, reads) in back.items()), os.getloadavg()[0]), file=sys.__stdout__, flush=True)


try:
    main()
    code = 0
except Exception:
    traceback.print_exc(file=sys.__stderr__)
    code = 1
sys.__stderr__.flush()
os._exit(code)
