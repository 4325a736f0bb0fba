"""Capture set + calibration -> organised ScanView, through the core's reconstruct recipe."""
import os

import picoscan


def reconstruct(capture_folder, calibration_file, manifest_file="", min_contrast=15.0, min_modulation=4.0,
                binary_only=False, clean=False, max_grazing_deg=80.0, progress=None):
    """Returns (view, calibration, clean_report or None). Raises picoscan.Error naming the bad input."""
    if not capture_folder or not os.path.isdir(capture_folder):
        raise picoscan.Error("%s: capture folder does not exist" % (capture_folder or "(no capture folder)"))
    if not calibration_file or not os.path.isfile(calibration_file):
        raise picoscan.Error("%s: calibration file does not exist" % (calibration_file or "(no calibration file)"))
    calibration = picoscan.read_calibration(calibration_file)
    options = picoscan.ReconstructOptions()
    options.manifest_path = manifest_file or ""
    options.decode.min_contrast = min_contrast
    options.decode.min_modulation = min_modulation
    options.decode.binary_only = binary_only
    options.clean = clean
    options.cleaning.max_grazing_deg = max_grazing_deg
    result = picoscan.reconstruct_view(capture_folder, calibration, calibration_file, options, progress)
    return result.view, calibration, result.cleaning
