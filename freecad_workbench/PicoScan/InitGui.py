# PicoScan workbench, GUI part (run by FreeCAD with exec: no __file__ here, the package finds its folder).
import FreeCAD
import FreeCADGui


class PicoScanWorkbench(FreeCADGui.Workbench):
    MenuText = "PicoScan"
    ToolTip = "Structured-light 3D scanning: calibrate, scan, reconstruct, mesh and turn scans into CAD"

    def __init__(self):
        import picoscan_wb

        self.__class__.Icon = picoscan_wb.icon_path("picoscan_workbench")

    def Initialize(self):
        from picoscan_wb import commands

        commands.register_all()
        self.appendToolbar("PicoScan", commands.TOOLBAR)
        self.appendMenu("PicoScan", commands.MENU)

    def GetClassName(self):
        return "Gui::PythonWorkbench"


FreeCADGui.addWorkbench(PicoScanWorkbench())
FreeCAD.__unit_test__ += ["TestPicoScanGui"]
