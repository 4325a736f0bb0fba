"""Capture set(s) + calibration -> organised ScanView, through the core's reconstruct recipes.
The calibration's kind decides the method: a camera-projector calibration reconstructs one
capture folder (reconstruct_view); a stereo calibration (two cameras) needs the second camera's
capture folder too (reconstruct_stereo_view)."""
import os

import picoscan


def is_stereo_calibration(calibration_file):
    return picoscan.calibration_kind(calibration_file) == picoscan.CalibrationKind.Stereo


def check_second_folder(calibration_file, second_capture_folder, folder_must_exist=True):
    """Raises picoscan.Error (naming SecondCaptureFolder) when the second folder does not fit the
    calibration's kind: required for a stereo calibration, refused for a camera-projector one. A view
    kept in the document needs the folder named, not its captures (folder_must_exist False)."""
    if is_stereo_calibration(calibration_file):
        if not second_capture_folder:
            raise picoscan.Error("SecondCaptureFolder: %s is a stereo calibration (two cameras): give the second "
                                 "camera's capture folder" % calibration_file)
        if folder_must_exist and not os.path.isdir(second_capture_folder):
            raise picoscan.Error("%s: second capture folder does not exist" % second_capture_folder)
    elif second_capture_folder:
        raise picoscan.Error("SecondCaptureFolder: %s is a camera-projector calibration; reconstructing with a second "
                             "camera needs a stereo calibration of both cameras" % calibration_file)


def read_any_calibration(calibration_file):
    """picoscan.StereoCalibration for a stereo calibration file, picoscan.Calibration otherwise."""
    if is_stereo_calibration(calibration_file):
        return picoscan.read_stereo_calibration(calibration_file)
    return picoscan.read_calibration(calibration_file)


def reconstruct(capture_folder, calibration_file, manifest_file="", min_contrast=15.0, min_modulation=4.0,
                binary_only=False, clean=False, max_grazing_deg=80.0, second_capture_folder="", progress=None):
    """Returns (view, calibration, clean_report or None, stereo statistics or None); the calibration is a
    picoscan.Calibration or a picoscan.StereoCalibration. Raises picoscan.Error naming the bad input."""
    if not capture_folder or not os.path.isdir(capture_folder):
        raise picoscan.Error("%s: capture folder does not exist" % (capture_folder or "(no capture folder)"))
    if not calibration_file or not os.path.isfile(calibration_file):
        raise picoscan.Error("%s: calibration file does not exist" % (calibration_file or "(no calibration file)"))
    check_second_folder(calibration_file, second_capture_folder)
    if second_capture_folder:
        calibration = picoscan.read_stereo_calibration(calibration_file)
        options = picoscan.StereoReconstructOptions()
    else:
        calibration = picoscan.read_calibration(calibration_file)
        options = picoscan.ReconstructOptions()
    options.manifest_path = manifest_file or ""
    options.decode.min_contrast = min_contrast
    options.decode.min_modulation = min_modulation
    options.decode.binary_only = binary_only
    options.clean = clean
    options.cleaning.max_grazing_deg = max_grazing_deg
    if second_capture_folder:
        result = picoscan.reconstruct_stereo_view(capture_folder, second_capture_folder, calibration, calibration_file,
                                                  options, progress)
        return result.view, calibration, result.cleaning, result.statistics
    result = picoscan.reconstruct_view(capture_folder, calibration, calibration_file, options, progress)
    return result.view, calibration, result.cleaning, None


def stereo_summary(statistics):
    """One line of what the two cameras matched, for the ScanView's StereoReport."""
    if statistics is None:
        return ""
    return "%d of %d decoded pixels triangulated; left-right consistency %.1f %%, %d ambiguous, %d off the epipolar line" % (
        statistics.valid, statistics.left_decoded, 100.0 * statistics.left_right_consistency(), statistics.ambiguous,
        statistics.epipolar_rejected)
