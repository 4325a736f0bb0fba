"""The workbench's commands, registered with FreeCAD's GUI."""
import FreeCADGui

from picoscan_wb.commands import analysis, scanning

COMMANDS = {
    "PicoScan_Calibrate": scanning.CalibrateCommand(),
    "PicoScan_Scan": scanning.ScanCommand(),
    "PicoScan_ImportCaptures": scanning.ImportCapturesCommand(),
    "PicoScan_Clean": scanning.CleanCommand(),
    "PicoScan_Stitch": analysis.StitchCommand(),
    "PicoScan_Mesh": analysis.MeshCommand(),
    "PicoScan_MakeSolid": analysis.MakeSolidCommand(),
    "PicoScan_FitPrimitives": analysis.FitPrimitivesCommand(),
    "PicoScan_FitRegion": analysis.FitRegionCommand(),
    "PicoScan_CrossSection": analysis.CrossSectionCommand(),
    "PicoScan_DeviationMap": analysis.DeviationMapCommand(),
    "PicoScan_BestFit": analysis.BestFitCommand(),
    "PicoScan_DatumAlign": analysis.DatumAlignCommand(),
    "PicoScan_PartFrame": analysis.PartFrameCommand(),
    "PicoScan_Measurements": analysis.MeasurementsCommand(),
    "PicoScan_ShowRig": analysis.ShowRigCommand(),
    "PicoScan_EncodingView": analysis.EncodingViewCommand(),
}
TOOLBAR = list(COMMANDS)
MENU = list(COMMANDS)


def register_all():
    for name, command in COMMANDS.items():
        FreeCADGui.addCommand(name, command)
