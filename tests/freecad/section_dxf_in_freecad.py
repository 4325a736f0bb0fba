"""`picoscan section`'s DXF opened by FreeCAD's own DXF importer (importDXF), as a CAD user would:
the demo part's outline at z = 12 mm must come in as the 5 lines and the hole's circle the CLI
wrote, at the same coordinates. Run by CTest: freecadcmd -c "exec(open(THIS).read())", with
PICOSCAN_CLI, PYTHONPATH (the picoscan module) and PICOSCAN_OUTPUT_DIR set; exits 1 on failure."""
import os
import subprocess
import sys
import traceback


def check():
    import FreeCAD
    import importDXF
    import picoscan

    folder = os.environ["PICOSCAN_OUTPUT_DIR"]
    os.makedirs(folder, exist_ok=True)
    part, drawing = os.path.join(folder, "part.3mf"), os.path.join(folder, "outline.dxf")
    picoscan.write_3mf(picoscan.mechanical_part(), part)
    result = subprocess.run([os.environ["PICOSCAN_CLI"], "section", part, "--axis", "z", "--at", "12", "--dxf", drawing],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    doc = FreeCAD.newDocument("SectionDxf")
    importDXF.insert(drawing, doc.Name)
    doc.recompute()
    edges = [edge for obj in doc.Objects if hasattr(obj, "Shape") for edge in obj.Shape.Edges]
    lines = [e for e in edges if type(e.Curve).__name__ == "Line"]
    circles = [e for e in edges if type(e.Curve).__name__ == "Circle"]
    print("FreeCAD read %d lines and %d circles from %s" % (len(lines), len(circles), drawing))
    assert (len(lines), len(circles), len(edges)) == (5, 1, 6), [type(e.Curve).__name__ for e in edges]
    hole = circles[0].Curve
    print("hole: radius %.4f mm at (%.4f, %.4f)" % (hole.Radius, hole.Center.x, hole.Center.y))
    assert abs(hole.Radius - 5) < 0.02 and abs(hole.Center.x + 11) < 0.02 and abs(hole.Center.y) < 0.02
    # The lines' ends as the CLI wrote them: FreeCAD moved none by more than 1 nm.
    written = []
    with open(drawing) as text:
        values = text.read().split("\n")
    for k in range(0, len(values) - 1, 2):
        if values[k] == "0" and values[k + 1] == "LINE":
            group = dict(zip(values[k + 2:k + 14:2], values[k + 3:k + 15:2]))
            written.append(((float(group["10"]), float(group["20"])), (float(group["11"]), float(group["21"]))))
    read = [((e.Vertexes[0].X, e.Vertexes[0].Y), (e.Vertexes[1].X, e.Vertexes[1].Y)) for e in lines]
    for a, b in written:
        assert any(max(abs(p[0] - q[0]) + abs(p[1] - q[1]) for p, q in zip(sorted((a, b)), sorted(ends))) < 1e-6
                   for ends in read), (a, b, read)
    corners = sorted(tuple(round(c, 2) for c in p) for a, b in written for p in (a, b))
    print("corners:", sorted(set(corners)))
    assert sorted(set(corners)) == sorted({(-25.0, -18.0), (25.0, -18.0), (25.0, 10.0), (17.0, 18.0), (-25.0, 18.0)})


try:
    check()
    code = 0
except Exception:
    traceback.print_exc()
    code = 1
sys.stdout.flush()
os._exit(code)
