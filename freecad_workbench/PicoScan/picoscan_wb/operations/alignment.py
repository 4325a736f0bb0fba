"""Best fit of a scan onto a model: the core's trimmed point-to-plane ICP against the model's
triangles; the scan object's Placement takes the result, so everything measured on it (a
deviation map) follows."""
import numpy
import FreeCAD

import picoscan
from picoscan_wb.operations import deviation
from picoscan_wb.progress import run_in_background


def best_fit(scan, reference, deflection_mm=0.01, keep_fraction=0.9):
    """Moves `scan` (its Placement) onto `reference` from where it is now. Returns picoscan.BestFit
    (its transform is the move applied). Raises picoscan.Error, leaving the scan where it was, when
    the points cannot fix the six degrees of freedom or lie too far from the model, or when
    cancelled. The objects are read and moved on the calling thread; the model's tessellation and
    the ICP run off it (run_in_background)."""
    options = picoscan.BestFitOptions()
    options.keep_fraction = keep_fraction
    points, model = deviation.scan_points(scan), deviation.reference_reader(reference, deflection_mm)
    result = run_in_background("Best fit of " + scan.Label, lambda progress: picoscan.best_fit_to_reference(
        points, model(progress), options, progress))
    if not result.converged:
        raise picoscan.Error("%s: the best fit did not settle in %d steps (rms %.3f mm); place the scan nearer to "
                             "the model first" % (scan.Label, result.iterations, result.rms_mm))
    move = FreeCAD.Placement(FreeCAD.Matrix(*[float(v) for v in numpy.asarray(result.transform).reshape(-1)]))
    scan.Placement = move.multiply(scan.Placement)
    return result
