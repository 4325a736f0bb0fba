"""Posed view PLY files of the mechanical part standing on a 140 mm turntable disc, as
bench_fuse_scale makes its views: each view is the ray-cast truth of every lit camera pixel
(picoscan.Simulator) with noise along the camera ray, posed into view 0's frame and written
with write_view_ply. Used by test_fuse_stream.py (small camera, few views) and, run as a
script, to measure what fusing full-resolution view files costs:

    /usr/bin/python3 turntable_view_files.py make FOLDER VIEWS [SCALE]
    /usr/bin/time -v /usr/bin/python3 turntable_view_files.py fuse-files FOLDER [open]
    /usr/bin/time -v /usr/bin/python3 turntable_view_files.py fuse-whole FOLDER [open]
(fuse-files: picoscan.fuse_view_files, one view at a time; fuse-whole: every view read first, then
picoscan.fuse_views of the list; default MeshOptions, or with "open" fill open)
    /usr/bin/python3 turntable_view_files.py project FOLDER   (FOLDER/project.mlp for meshlabserver -p)
"""
import glob
import os
import sys

import numpy

import picoscan


def scaled_rig(scale):
    """The seed rig with its camera scaled by `scale` (1: the full 1600 x 1200)."""
    calibration = picoscan.seed_rig_calibration()
    if scale != 1:
        width, height = calibration.camera_size
        calibration.camera_size = (int(round(width * scale)), int(round(height * scale)))
        matrix = calibration.camera_matrix
        matrix[:2, :2] *= scale
        matrix[:2, 2] = (matrix[:2, 2] + 0.5) * scale - 0.5
        calibration.camera_matrix = matrix
    return calibration


def part_on_disc():
    scene = picoscan.Scene()
    scene.add_mesh(picoscan.mechanical_part(), 0.85)
    scene.add_cylinder((0, 0, -5), (0, 0, 1), 70, 5, 0.6)
    return scene


def noisy_view(geometry, calibration, seed, noise_mm=0.02):
    """The ray-cast truth of every lit pixel, moved along its camera ray by Gaussian noise."""
    truth = numpy.asarray(geometry.points, dtype=numpy.float64)
    normals = numpy.asarray(geometry.normals, dtype=numpy.float64)
    lit = (numpy.asarray(geometry.lit) > 0) & numpy.isfinite(truth).all(axis=2)
    rays = truth / numpy.linalg.norm(numpy.where(lit[..., None], truth, 1.0), axis=2)[..., None]
    towards_camera = numpy.where(((normals * rays).sum(axis=2) > 0)[..., None], -normals, normals)
    noise = numpy.random.default_rng(seed).normal(0.0, noise_mm, lit.shape)[..., None]
    points = numpy.where(lit[..., None], truth + rays * noise, numpy.nan).astype(numpy.float32)
    grey = numpy.clip(255 * numpy.asarray(geometry.shading), 0, 255).astype(numpy.uint8)
    view = picoscan.ScanView()
    view.points = points
    view.normals = numpy.where(lit[..., None], towards_camera, numpy.nan).astype(numpy.float32)
    view.colours = numpy.repeat(numpy.where(lit, grey, 0)[..., None], 3, axis=2).astype(numpy.uint8)
    view.camera_matrix = calibration.camera_matrix
    view.camera_distortion = calibration.camera_distortion
    return view


def make_view_files(folder, view_count, scale=1.0):
    """Writes view_00.ply .. (view_count of them, 360 / view_count degrees apart) into `folder`;
    returns their paths in order."""
    os.makedirs(folder, exist_ok=True)
    calibration = scaled_rig(scale)
    plan = picoscan.TurntablePlan()
    plan.turntable_views = view_count
    plan.top_view = False
    poses = [numpy.asarray(pose) for pose in picoscan.turntable_part_poses(plan)]
    scene = part_on_disc()
    paths = []
    for index, pose in enumerate(poses):
        simulator = picoscan.Simulator(calibration, picoscan.transformed(scene, pose))
        view = noisy_view(simulator.geometry(), calibration, seed=index + 1)
        view.pose = poses[0] @ numpy.linalg.inv(pose)  # into view 0's frame
        paths.append(os.path.join(folder, "view_%02d.ply" % index))
        picoscan.write_view_ply(view, paths[-1])
    return paths


def view_files(folder):
    paths = sorted(glob.glob(os.path.join(folder, "view_[0-9][0-9].ply")))
    if not paths:
        raise SystemExit("%s: no view_NN.ply files (make them first)" % folder)
    return paths


def write_meshlab_project(folder):
    """FOLDER/project.mlp: every view file as a MeshLab layer, its pose as the layer's transform."""
    layers = []
    for path in view_files(folder):
        pose = numpy.asarray(picoscan.read_view_ply(path).pose)
        # Each number followed by a space: MeshLab splits the matrix at spaces only.
        matrix = "\n".join("".join("%.12g " % value for value in row) for row in pose)
        name = os.path.basename(path)
        layers.append('  <MLMesh label="%s" filename="%s" visible="1">\n   <MLMatrix44>\n%s\n</MLMatrix44>\n  </MLMesh>\n' % (
            name, name, matrix))
    project = os.path.join(folder, "project.mlp")
    with open(project, "w") as out:
        out.write("<!DOCTYPE MeshLabDocument>\n<MeshLabProject>\n <MeshGroup>\n%s </MeshGroup>\n <RasterGroup/>\n"
                  "</MeshLabProject>\n" % "".join(layers))
    return project


def main(arguments):
    if len(arguments) >= 3 and arguments[0] == "make":
        paths = make_view_files(arguments[1], int(arguments[2]), float(arguments[3]) if len(arguments) > 3 else 1.0)
        print("wrote %d views to %s" % (len(paths), arguments[1]))
        return 0
    if len(arguments) == 2 and arguments[0] == "project":
        print("wrote", write_meshlab_project(arguments[1]))
        return 0
    if len(arguments) in (2, 3) and arguments[0] in ("fuse-files", "fuse-whole") and arguments[2:] in ([], ["open"]):
        paths = view_files(arguments[1])
        options = picoscan.MeshOptions()
        if arguments[2:] == ["open"]:
            options.fill = picoscan.MeshFill.Open
        if arguments[0] == "fuse-files":
            fused = picoscan.fuse_view_files(paths, options)
        else:
            views = [picoscan.read_view_ply(path) for path in paths]
            fused = picoscan.fuse_views(views, options)
        print("%s: %d views, %d points, %d vertices, %d faces; %s" % (
            arguments[0], len(paths), len(fused.merged), len(fused.mesh.vertices), len(fused.mesh.faces),
            fused.check.summary()))
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
