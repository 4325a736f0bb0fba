"""DeviationMap: a scan measured against a model (any Part shape, tessellated, or a mesh). The
points are coloured by their signed distance (green within the tolerance, yellow to red outside
the model, cyan to blue inside) and the figures are properties. Parametric: change the model or
the scan, recompute, and the map follows."""
import os

import FreeCAD

import picoscan
from picoscan_wb import property_content
from picoscan_wb.objects import DocumentObjectProxy, add_or_remove, brief_input_errors
from picoscan_wb.operations import deviation
from picoscan_wb.progress import cancel_point, run_in_background

TYPE = "PicoScan::DeviationMap"


def _add_colour_range(obj):
    """The colour scale's half width (also added to maps of documents saved before it existed; their
    legend shows from their next recompute)."""
    if not hasattr(obj, "ColourRange"):
        obj.addProperty("App::PropertyDistance", "ColourRange", "Result",
                        "The colours span -this (blue) to +this (red); farther points take the end colours", 1)


class DeviationMap(DocumentObjectProxy):
    TYPE = TYPE

    def __init__(self, obj):
        super().__init__(obj)
        group = "Deviation"
        obj.addProperty("App::PropertyLink", "Scan", group, "The scan: a ScanView, a Stitch, Points or a mesh")
        obj.addProperty("App::PropertyLink", "Reference", group, "The model: any Part shape or a mesh")
        obj.addProperty("App::PropertyLength", "Tolerance", group, "Points nearer than this are within tolerance (green)")
        obj.addProperty("App::PropertyLength", "MaxDistance", group, "Points farther than this are not measured (0: all)")
        obj.addProperty("App::PropertyLength", "Deflection", group, "Largest gap between the tessellated model and its true surface")
        obj.addProperty("App::PropertyFile", "ReportFile", group, "HTML report written on every recompute (empty: none)")
        group = "Result"
        obj.addProperty("App::PropertyColorList", "Color", group, "Colour of each point on the deviation scale", 1)
        obj.addProperty("App::PropertyFloatList", "Distances", group, "Signed distance of each point (mm)", 1)
        for name, tip in (("MeanDeviation", "Signed mean distance"), ("MeanAbsDeviation", "Mean |distance|"),
                          ("Sigma", "Standard deviation of the signed distances"),
                          ("P95Deviation", "95 % of the points are nearer than this"), ("MaxDeviation", "Largest |distance|")):
            obj.addProperty("App::PropertyDistance", name, group, tip, 1)
        obj.addProperty("App::PropertyPercent", "WithinTolerance", group, "Share of the points within tolerance", 1)
        _add_colour_range(obj)
        obj.addProperty("App::PropertyInteger", "PointCount", group, "Points measured", 1)
        obj.addProperty("App::PropertyString", "Summary", group, "The figures in one line", 1)
        obj.Tolerance = 0.05
        obj.Deflection = 0.005

    def onDocumentRestored(self, obj):
        super().onDocumentRestored(obj)
        _add_colour_range(obj)

    @brief_input_errors
    def execute(self, obj):
        # Read on the GUI thread; everything heavy (tessellating, measuring, colouring, the bytes of
        # the result's properties, the report) on a worker; back here only FreeCAD reading those
        # bytes (its own C++) and its view provider drawing them.
        options = deviation.options(obj.Tolerance.Value, obj.MaxDistance.Value)
        points = deviation.scan_points(obj.Scan)
        reference = deviation.reference_reader(obj.Reference, obj.Deflection.Value)  # last: it may leave a file to read
        report_file, title = obj.ReportFile, "%s against %s" % (obj.Scan.Label, obj.Reference.Label)

        def work(progress):
            result = picoscan.measure_deviation(points, reference(progress), options, progress)
            cancel_point(progress, 1.0, "colouring the points")
            contents = {"Points": property_content.points_content(points),
                        "Color": property_content.colour_list_content(result.colours()),
                        "Distances": property_content.float_list_content(result.distances_mm)}
            if report_file:
                cancel_point(progress, 1.0, "writing the report")
                picoscan.write_deviation_report(result, title, report_file)
                picoscan.write_deviation_ply(points, result, os.path.splitext(report_file)[0] + ".ply")
            return result, contents
        result, contents = run_in_background("Deviation of " + obj.Label, work)
        for name, content in contents.items():
            obj.restorePropertyContent(name, content)
        statistics = result.statistics
        obj.MeanDeviation = statistics.mean_mm
        obj.MeanAbsDeviation = statistics.mean_abs_mm
        obj.Sigma = statistics.sigma_mm
        obj.P95Deviation = statistics.p95_abs_mm
        obj.MaxDeviation = statistics.max_abs_mm
        obj.WithinTolerance = int(round(100 * statistics.within_tolerance))
        obj.PointCount = statistics.count
        obj.ColourRange = result.range_mm
        obj.Summary = deviation.summary(statistics, obj.Tolerance.Value)
        self.last_map = result  # for the GUI's histogram; goes with the object


def create(doc, scan, reference, tolerance_mm=0.05, max_distance_mm=0.0, report_file="", name="DeviationMap"):
    """Measures and adds the object; on bad input nothing is added (picoscan.Error says why)."""
    if scan is None or reference is None:
        raise picoscan.Error("Deviation map: select the scan and the reference model")

    def setup(obj):
        DeviationMap(obj)
        obj.Scan = scan
        obj.Reference = reference
        obj.Tolerance = tolerance_mm
        obj.MaxDistance = max_distance_mm
        obj.ReportFile = report_file
        if FreeCAD.GuiUp:
            from picoscan_wb.viewproviders.view_provider import DeviationViewProvider
            DeviationViewProvider(obj.ViewObject)
            obj.ViewObject.PointSize = 3

    obj = add_or_remove(doc, "Points::FeaturePython", name, setup)
    if FreeCAD.GuiUp:
        obj.ViewObject.DisplayMode = "Color"
        scan.ViewObject.Visibility = False
    return obj
