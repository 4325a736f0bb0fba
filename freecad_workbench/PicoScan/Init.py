# PicoScan workbench, application part (run by FreeCAD with exec at start-up, also headless).
import FreeCAD

FreeCAD.__unit_test__ += ["TestPicoScanApp"]
