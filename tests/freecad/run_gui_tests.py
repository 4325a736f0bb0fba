# Runs the workbench's GUI tests inside FreeCAD and exits with their result:
#   FREECAD_USER_HOME=<dir with Mod/PicoScan> xvfb-run -a freecad run_gui_tests.py
# PICOSCAN_GUI_TESTS=name,name runs only those tests of test_gui (e.g. scripts/walkthrough-screenshots).
# (FreeCAD's GUI would keep running after a script, so it ends with os._exit.)
import os
import sys
import traceback
import unittest

try:
    from picoscan_wb.tests import test_gui

    names = [n for n in os.environ.get("PICOSCAN_GUI_TESTS", "").split(",") if n]
    suite = (unittest.defaultTestLoader.loadTestsFromNames(names, test_gui) if names
             else unittest.defaultTestLoader.loadTestsFromModule(test_gui))
    result = unittest.TextTestRunner(stream=sys.__stderr__, verbosity=2).run(suite)
    code = 0 if result.wasSuccessful() and result.testsRun > 0 else 1
except Exception:
    traceback.print_exc(file=sys.__stderr__)
    code = 2
sys.__stderr__.flush()
os._exit(code)
