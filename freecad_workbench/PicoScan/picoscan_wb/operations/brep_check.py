"""What Make solid asks OpenCASCADE about the B-rep it wrote (its shape type, volume and, when
asked, validity), run as a separate process:
`python3 -S brep_check.py FREECAD_LIB BREP CHECK_VALID`.
FreeCAD's Part calls hold Python's GIL while they run (seconds each for tens of thousands of
faces), so in the GUI's own process they would stop the GUI from answering, whichever thread runs
them; a process of its own leaves the GUI answering and is stopped at once by Cancel.
Prints one JSON line per stage ({"stage": ...}) and the answer last
({"type": ..., "volume": ..., "valid": ...})."""
import importlib
import json
import sys


def say(**fields):
    print(json.dumps(fields), flush=True)


def main(freecad_lib, path, check_valid):
    sys.path.append(freecad_lib)
    importlib.import_module("FreeCAD")  # FreeCAD's application first: Part alone exits silently
    import Part

    say(stage="parsing the B-rep")
    shape = Part.Shape()
    shape.read(path)
    say(stage="volume")
    answer = {"type": shape.ShapeType, "volume": shape.Volume if shape.ShapeType == "Solid" else 0.0}
    if check_valid:
        say(stage="OpenCASCADE's check")
        answer["valid"] = shape.isValid()
    say(**answer)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3] == "1")
