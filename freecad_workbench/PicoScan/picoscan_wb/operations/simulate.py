"""Simulated scans: the core's virtual rig renders a capture set as a real camera would.
Hardware capture is issue 5 (`picoscan capture`); its capture sets are imported like these."""
import os

import picoscan


def scaled_calibration(calibration, scale):
    """The same rig with the camera resolution scaled (fewer pixels: faster tests and previews)."""
    if scale == 1.0:
        return calibration
    width, height = calibration.camera_size
    calibration.camera_size = (int(round(width * scale)), int(round(height * scale)))
    matrix = calibration.camera_matrix
    matrix[0, 0] *= scale
    matrix[1, 1] *= scale
    # Pixel centres at integer coordinates: scale about the corner of the first pixel.
    matrix[0, 2] = (matrix[0, 2] + 0.5) * scale - 0.5
    matrix[1, 2] = (matrix[1, 2] + 0.5) * scale - 0.5
    calibration.camera_matrix = matrix
    return calibration


def shaft_scene(radius_mm=12.5, length_mm=80.0, distance_mm=400.0, background_mm=460.0):
    """A shaft (capped cylinder, axis along the camera's y) in front of a flat background."""
    scene = picoscan.Scene()
    scene.add_plane((0, 0, background_mm), (0, 0, -1))
    scene.add_cylinder((0, -length_mm / 2, distance_mm), (0, 1, 0), radius_mm, length_mm)
    return scene


SCENES = ("Demo part", "Shaft", "Scene file")


def make_scene(kind, scene_file=""):
    if kind == "Demo part":
        return picoscan.demo_scene()
    if kind == "Shaft":
        return shaft_scene()
    if kind == "Scene file":
        if not scene_file or not os.path.isfile(scene_file):
            raise picoscan.Error("%s: scene file does not exist" % (scene_file or "(no scene file)"))
        return picoscan.read_scene(scene_file)
    raise picoscan.Error("%s: unknown scene (one of %s)" % (kind, ", ".join(SCENES)))


def simulate_scan(folder, scene, camera_scale=1.0, shifts=8, noise_dn=1.0, seed=1, progress=None):
    """Renders the capture set of `scene` with the seed-like rig into `folder` (which must be empty
    or new) and writes the rig as folder/calibration.yml. Returns the calibration file's path."""
    if os.path.exists(folder) and (not os.path.isdir(folder) or os.listdir(folder)):
        raise picoscan.Error("%s: output folder must be empty or new" % folder)
    calibration = scaled_calibration(picoscan.seed_rig_calibration(), camera_scale)
    patterns = picoscan.PatternOptions()
    patterns.shifts = shifts
    options = picoscan.SimulationOptions()
    options.noise_sigma_dn = noise_dn
    options.seed = seed
    captures = picoscan.simulate_capture(picoscan.make_pattern_sequence(patterns), calibration, scene, options, progress)
    os.makedirs(folder, exist_ok=True)
    picoscan.write_capture_set(captures, folder)
    calibration_file = os.path.join(folder, "calibration.yml")
    picoscan.write_calibration(calibration, calibration_file)
    return calibration_file
