# GUI tests of the PicoScan workbench (run inside the FreeCAD GUI, e.g. under xvfb-run).
from picoscan_wb.tests.test_gui import *  # noqa: F401,F403
