"""Capture set + calibration -> organised ScanView: the core's decode, triangulate and clean."""
import os

import picoscan


def camera_focal_px(calibration):
    return float(calibration.camera_matrix[0, 0])


def reconstruct(capture_folder, calibration_file, manifest_file="", min_contrast=15.0, min_modulation=4.0,
                binary_only=False, clean=False, max_grazing_deg=80.0, progress=None):
    """Returns (view, calibration, clean_report or None). Raises picoscan.Error naming the bad input."""
    if not capture_folder or not os.path.isdir(capture_folder):
        raise picoscan.Error("%s: capture folder does not exist" % (capture_folder or "(no capture folder)"))
    if not calibration_file or not os.path.isfile(calibration_file):
        raise picoscan.Error("%s: calibration file does not exist" % (calibration_file or "(no calibration file)"))
    calibration = picoscan.read_calibration(calibration_file)
    captures = picoscan.load_capture_set(capture_folder, manifest_file or "", progress)
    picoscan.check_camera_size(calibration, captures, calibration_file)
    options = picoscan.DecodeOptions()
    options.min_contrast = min_contrast
    options.min_modulation = min_modulation
    options.binary_only = binary_only
    correspondences = picoscan.decode(captures, options, progress)
    view = picoscan.triangulate(correspondences, calibration, captures.white_colour, progress=progress)
    report = None
    if clean:
        clean_options = picoscan.CleanOptions()
        clean_options.max_grazing_deg = max_grazing_deg
        report = picoscan.clean_view(view, camera_focal_px(calibration), clean_options)
    if view.valid_count() == 0:
        raise picoscan.Error("%s: no pixel could be decoded and triangulated" % capture_folder)
    return view, calibration, report
