"""Measurements: a table of distances and angles between fitted features with their uncertainty
(operations/measure.py), parametric (it follows the features) and written as CSV when asked."""
import FreeCAD

from picoscan_wb.objects import DocumentObjectProxy, add_or_remove, brief_input_errors
from picoscan_wb.operations import measure

TYPE = "PicoScan::Measurements"


class Measurements(DocumentObjectProxy):
    TYPE = TYPE

    def __init__(self, obj):
        super().__init__(obj)
        obj.addProperty("App::PropertyLinkList", "Features", "Measurements", "Fitted planes, cylinders and spheres")
        obj.addProperty("App::PropertyFile", "CsvFile", "Measurements", "The table is written here on every recompute (empty: not written)")
        obj.addProperty("App::PropertyStringList", "Table", "Result", "Feature A - feature B: measure value +- uncertainty", 1)

    @brief_input_errors
    def execute(self, obj):
        rows = measure.measure(obj.Features)
        obj.Table = [measure.format_row(row) for row in rows]
        if obj.CsvFile:
            measure.write_csv(rows, obj.CsvFile)


def create(doc, features, csv_file="", name="Measurements"):
    def setup(obj):
        Measurements(obj)
        obj.Features = list(features)
        obj.CsvFile = csv_file

    obj = add_or_remove(doc, "App::FeaturePython", name, setup)
    for row in obj.Table:
        FreeCAD.Console.PrintLog(row + "\n")
    return obj
