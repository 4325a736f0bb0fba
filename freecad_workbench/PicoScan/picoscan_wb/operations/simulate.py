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


def scaled_stereo_rig(rig, scale):
    """The seed stereo rig with both cameras' resolution scaled, its stereo calibration derived again."""
    if scale == 1.0:
        return rig
    rig.left = scaled_calibration(rig.left, scale)
    rig.right = scaled_calibration(rig.right, scale)
    rig.stereo = picoscan.stereo_from_projector_calibrations(rig.left, rig.right)
    return rig


def _require_empty(folder):
    if os.path.exists(folder) and (not os.path.isdir(folder) or os.listdir(folder)):
        raise picoscan.Error("%s: output folder must be empty or new" % folder)


def simulate_stereo_scan(folder, second_folder, scene, camera_scale=1.0, shifts=8, noise_dn=1.0, seed=1,
                         baseline_mm=200.0, progress=None):
    """Renders `scene` (first camera's frame) with the seed stereo rig, two cameras `baseline_mm` apart
    with the projector between them: the first camera's capture set into `folder`, the second's into
    `second_folder` (both empty or new), and the stereo calibration as folder/stereo.yml (the projector
    is not calibrated). Returns the stereo calibration file's path."""
    _require_empty(folder)
    _require_empty(second_folder)
    if os.path.realpath(folder) == os.path.realpath(second_folder):
        raise picoscan.Error("%s: the two cameras need different capture folders" % second_folder)
    rig = scaled_stereo_rig(picoscan.seed_stereo_rig(baseline_mm), camera_scale)
    patterns = picoscan.PatternOptions()
    patterns.shifts = shifts
    options = picoscan.SimulationOptions()
    options.noise_sigma_dn = noise_dn
    options.seed = seed
    first, second = picoscan.simulate_stereo_capture(picoscan.make_pattern_sequence(patterns), rig, scene, options,
                                                     progress)
    os.makedirs(folder, exist_ok=True)
    os.makedirs(second_folder, exist_ok=True)
    picoscan.write_capture_set(first, folder)
    picoscan.write_capture_set(second, second_folder)
    calibration_file = os.path.join(folder, "stereo.yml")
    picoscan.write_stereo_calibration(rig.stereo, calibration_file)
    return calibration_file


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
    _require_empty(folder)
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


def _rotation_deg(about_x, about_y, about_z):
    """Rotation about x, then y, then z (degrees)."""
    import numpy

    def about(axis, degrees):
        c, s = numpy.cos(numpy.radians(degrees)), numpy.sin(numpy.radians(degrees))
        i, j = [k for k in range(3) if k != axis]
        matrix = numpy.eye(3)
        matrix[i, i], matrix[i, j], matrix[j, i], matrix[j, j] = c, -s, s, c
        return matrix

    return about(2, about_z) @ about(1, about_y) @ about(0, about_x)


# Board poses tilted up to ~30 degrees in different directions, 370..430 mm away: (centre, tilts).
BOARD_POSES = [((0, 0, 400), (0, 0, 0)), ((-30, -20, 380), (25, -20, 5)), ((30, -20, 380), (25, 20, -5)),
               ((-30, 20, 420), (-25, -20, 10)), ((30, 20, 420), (-25, 20, -10)), ((0, 0, 370), (15, 15, 30)),
               ((-40, 0, 400), (0, -30, 0)), ((40, 0, 400), (0, 30, 0))]


def simulate_board_poses(folder, inner_corners=(9, 6), square_mm=18.0, camera_scale=0.5, progress=None):
    """Capture sets of a chessboard in BOARD_POSES, one folder each (pose_00, ...), for calibrating.
    Returns (folders, board spec text, the true calibration)."""
    import numpy

    calibration = scaled_calibration(picoscan.seed_rig_calibration(), camera_scale)
    patterns = picoscan.PatternOptions()
    patterns.shifts = 8
    sequence = picoscan.make_pattern_sequence(patterns)
    middle = numpy.array([(inner_corners[0] - 1) / 2 * square_mm, (inner_corners[1] - 1) / 2 * square_mm, 0.0])
    folders = []
    for index, (centre, tilts) in enumerate(BOARD_POSES):
        rotation = _rotation_deg(*tilts)
        scene = picoscan.Scene()
        scene.add_board(rotation, numpy.asarray(centre, float) - rotation @ middle, inner_corners, square_mm, 12.0)
        options = picoscan.SimulateOptions().camera  # the core's realistic webcam (slightly defocused)
        options.seed = index + 1
        captures = picoscan.simulate_capture(sequence, calibration, scene, options, progress)
        folders.append(os.path.join(folder, "pose_%02d" % index))
        os.makedirs(folders[-1], exist_ok=True)
        picoscan.write_capture_set(captures, folders[-1])
    return folders, "chessboard:%dx%d:%g" % (inner_corners[0], inner_corners[1], square_mm), calibration


def simulate_turntable(folder, view_indices=(0, 1, 2), camera_scale=1.0, progress=None):
    """Views of the built-in speckle-painted mechanical part on a turntable (45 degree steps, seen
    from 25 degrees above), one capture folder each (view_N, with calibration.yml).
    Returns [(capture folder, calibration file)] and the true view -> first view transforms."""
    import numpy

    plan = picoscan.TurntablePlan()
    plan.top_view = False
    part_to_camera = picoscan.turntable_part_poses(plan)
    part = picoscan.mechanical_part()
    calibration = scaled_calibration(picoscan.seed_rig_calibration(), camera_scale)
    patterns = picoscan.PatternOptions()
    patterns.shifts = 8
    sequence = picoscan.make_pattern_sequence(patterns)
    recipe = picoscan.TurntableScanOptions()  # the core's turntable session: part albedo, exposure, defocus
    scans, truth = [], []
    first = numpy.asarray(part_to_camera[view_indices[0]])
    for index in view_indices:
        scene = picoscan.Scene()
        scene.add_mesh(picoscan.transformed(part, part_to_camera[index]), recipe.part_albedo)
        options = recipe.camera
        # One noise seed for every view (the figures in docs/freecad.md were measured so).
        options.seed = 1
        captures = picoscan.simulate_capture(sequence, calibration, scene, options, progress)
        view_folder = os.path.join(folder, "view_%d" % index)
        os.makedirs(view_folder, exist_ok=True)
        picoscan.write_capture_set(captures, view_folder)
        calibration_file = os.path.join(view_folder, "calibration.yml")
        picoscan.write_calibration(calibration, calibration_file)
        scans.append((view_folder, calibration_file))
        truth.append(first @ numpy.linalg.inv(numpy.asarray(part_to_camera[index])))
    return scans, truth


def simulate_placements(folder, part, placements, camera_scale=0.5, part_albedo=None, progress=None):
    """A part scanned in several placements, each one turntable round of the core's turntable
    session (simulate_turntable_scan): `placements` lists (picoscan.PartPlacement, turn in degrees
    about the table, first noise seed). Each view's captures go to FOLDER/placement_P/view_K with
    its calibration.yml. Returns [(capture folder, calibration file, placement number from 1)] and
    the true view -> model (first view) transforms."""
    import numpy

    calibration = scaled_calibration(picoscan.seed_rig_calibration(), camera_scale)
    top = float(numpy.asarray(part.vertices)[:, 2].max())
    scans, part_to_camera = [], []
    for number, (placement, turn_deg, seed) in enumerate(placements, start=1):
        options = picoscan.TurntableScanOptions()
        plan = options.plan
        plan.top_view = False  # one turntable round per placement
        plan.part_middle_height_mm = top / 2
        plan.placement = placement
        plan.placement_turn_deg = turn_deg
        options.plan = plan
        camera = options.camera
        camera.seed = seed
        options.camera = camera
        if part_albedo is not None:
            options.part_albedo = part_albedo

        def write(simulated, number=number):
            view_folder = os.path.join(folder, "placement_%d" % number, simulated.name)
            os.makedirs(view_folder, exist_ok=True)
            picoscan.write_capture_set(simulated.captures, view_folder)
            calibration_file = os.path.join(view_folder, "calibration.yml")
            picoscan.write_calibration(calibration, calibration_file)
            scans.append((view_folder, calibration_file, number))

        part_to_camera += [numpy.asarray(pose) for pose in
                           picoscan.simulate_turntable_scan(part, calibration, options, write, progress)]
    first = part_to_camera[0]
    return scans, [first @ numpy.linalg.inv(pose) for pose in part_to_camera]
