# Headless tests of the PicoScan workbench: freecadcmd -t TestPicoScanApp -M <workbench folder>
from picoscan_wb.tests.test_app import *  # noqa: F401,F403
