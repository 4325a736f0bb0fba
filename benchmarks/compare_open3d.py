#!/usr/bin/python3
"""Registration side by side: PicoScan against Open3D 0.16 on the same views.

The views are the 360-degree turntable scan of 'picoscan demo' (8 views around the
mechanical part plus one from above, each placed by hand to within a few degrees), with the
simulation's true poses. For every neighbouring pair of views both tools get the same two
PLY files and are timed from reading the files to the final pose:

  global  no initial guess: PicoScan 'stitch' (ORB on the white frames, FPFH when needed,
          RANSAC, point-to-plane ICP) against Open3D FPFH + RANSAC + point-to-plane ICP;
  icp     start from the true pose disturbed by 2 degrees and 2 mm: PicoScan 'stitch
          --initial-poses' against Open3D point-to-plane ICP.

Errors are the rotation angle and the shift of the moving view's centroid between the
found and the true relative pose. Run with Debian's python3 (it has open3d and numpy):
    /usr/bin/python3 benchmarks/compare_open3d.py [--picoscan build/core/picoscan] [--data DIR]
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import open3d as o3d


def read_poses(path):
    """Poses in the format 'picoscan stitch' writes: a name line, then 4 rows of 4 numbers."""
    poses = []
    with open(path) as f:
        lines = [line for line in f if line.strip() and not line.startswith("#")]
    for k in range(0, len(lines), 5):
        poses.append(np.array([[float(v) for v in lines[k + 1 + r].split()] for r in range(4)]))
    return poses


def write_poses(path, poses):
    with open(path, "w") as f:
        for i, pose in enumerate(poses):
            f.write("view_%d\n" % i)
            for row in pose:
                f.write(" ".join("%.9f" % v for v in row) + "\n")


def pose_error(truth, found, centroid):
    relative = np.linalg.inv(truth) @ found
    angle = np.degrees(np.arccos(np.clip((np.trace(relative[:3, :3]) - 1) / 2, -1, 1)))
    moved = relative[:3, :3] @ centroid + relative[:3, 3]
    return angle, float(np.linalg.norm(moved - centroid))


def disturbed(pose, centroid, degrees, mm, rng):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = np.radians(degrees)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    turn = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    shift = rng.normal(size=3)
    shift *= mm / np.linalg.norm(shift)
    knock = np.eye(4)
    knock[:3, :3] = turn
    knock[:3, 3] = centroid - turn @ centroid + shift  # turned about the part, then shifted
    return knock @ pose


def picoscan_pair(picoscan, fixed, moving, work, initial=None):
    out = os.path.join(work, "pair.ply")
    command = [picoscan, "stitch", fixed, moving, "--out", out]
    if initial is not None:
        write_poses(os.path.join(work, "initial.txt"), [np.eye(4), initial])
        command += ["--initial-poses", os.path.join(work, "initial.txt")]
    start = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        return None, seconds
    return read_poses(os.path.join(work, "pair.poses.txt"))[1], seconds


def open3d_load(path, voxel_mm):
    cloud = o3d.io.read_point_cloud(path)
    return cloud.voxel_down_sample(voxel_mm)


def open3d_global(fixed, moving):
    start = time.perf_counter()
    target, source = open3d_load(fixed, 0.7), open3d_load(moving, 0.7)
    target_coarse, source_coarse = target.voxel_down_sample(2.0), source.voxel_down_sample(2.0)
    search = o3d.geometry.KDTreeSearchParamHybrid(radius=6.0, max_nn=100)
    target_features = o3d.pipelines.registration.compute_fpfh_feature(target_coarse, search)
    source_features = o3d.pipelines.registration.compute_fpfh_feature(source_coarse, search)
    reg = o3d.pipelines.registration
    coarse = reg.registration_ransac_based_on_feature_matching(
        source_coarse, target_coarse, source_features, target_features, True, 3.0,
        reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9), reg.CorrespondenceCheckerBasedOnDistance(3.0)],
        reg.RANSACConvergenceCriteria(100000, 0.999))
    fine = reg.registration_icp(source, target, 1.5, coarse.transformation, reg.TransformationEstimationPointToPlane(),
                                reg.ICPConvergenceCriteria(max_iteration=100))
    return fine.transformation, time.perf_counter() - start


def open3d_icp(fixed, moving, initial):
    start = time.perf_counter()
    target, source = open3d_load(fixed, 0.7), open3d_load(moving, 0.7)
    reg = o3d.pipelines.registration
    fine = reg.registration_icp(source, target, 3.0, initial, reg.TransformationEstimationPointToPlane(),
                                reg.ICPConvergenceCriteria(max_iteration=100))
    return fine.transformation, time.perf_counter() - start


def summary(name, errors, times, pairs):
    good = [e for e in errors if e is not None and e[0] < 1.0 and e[1] < 1.0]
    if good:
        angles = [e[0] for e in good]
        shifts = [e[1] for e in good]
        accuracy = "%.4f / %.4f | %.4f / %.4f" % (np.median(angles), max(angles), np.median(shifts), max(shifts))
    else:
        accuracy = "- | -"
    return "| %s | %d of %d | %s | %.2f |" % (name, len(good), pairs, accuracy, np.median(times))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--picoscan", default="build/core/picoscan")
    parser.add_argument("--data", default="build/bench-turntable", help="picoscan demo output (made when missing)")
    args = parser.parse_args()
    picoscan = os.path.abspath(args.picoscan)
    views_dir = os.path.join(args.data, "views")
    if not os.path.exists(os.path.join(args.data, "true_poses.txt")):
        print("making the views: picoscan demo --out %s" % args.data, file=sys.stderr)
        subprocess.run([picoscan, "demo", "--out", args.data], check=True, stdout=subprocess.DEVNULL)
    truth = read_poses(os.path.join(args.data, "true_poses.txt"))
    count = len(truth)
    ring = count - 1
    pairs = [(i, (i + 1) % ring) for i in range(ring)] + [(0, ring)]  # neighbours around, and the top view
    rng = np.random.default_rng(1)
    rows = {"global": {"PicoScan": ([], []), "Open3D": ([], [])}, "icp": {"PicoScan": ([], []), "Open3D": ([], [])}}
    with tempfile.TemporaryDirectory() as work:
        for a, b in pairs:
            fixed = os.path.join(views_dir, "view_%d.ply" % a)
            moving = os.path.join(views_dir, "view_%d.ply" % b)
            true_relative = np.linalg.inv(truth[a]) @ truth[b]
            centroid = np.asarray(o3d.io.read_point_cloud(moving).get_center())
            initial = disturbed(true_relative, centroid, 2.0, 2.0, rng)
            runs = {
                ("global", "PicoScan"): picoscan_pair(picoscan, fixed, moving, work),
                ("global", "Open3D"): open3d_global(fixed, moving),
                ("icp", "PicoScan"): picoscan_pair(picoscan, fixed, moving, work, initial),
                ("icp", "Open3D"): open3d_icp(fixed, moving, initial),
            }
            for (kind, tool), (found, seconds) in runs.items():
                error = None if found is None else pose_error(true_relative, np.asarray(found), centroid)
                rows[kind][tool][0].append(error)
                rows[kind][tool][1].append(seconds)
                print("view_%d <- view_%d %-6s %-8s %s  %.2f s" % (a, b, kind, tool,
                      "failed" if error is None else "%.4f deg %.4f mm" % error, seconds), file=sys.stderr)
    print("| registration | pairs within 1 deg / 1 mm | rotation error median / max (deg) | "
          "shift error median / max (mm) | median time (s) |")
    print("|---|---|---|---|---|")
    for kind, label in (("global", "global, no guess"), ("icp", "ICP from 2 deg / 2 mm off")):
        for tool in ("PicoScan", "Open3D"):
            errors, times = rows[kind][tool]
            print(summary("%s: %s" % (label, tool), errors, times, len(pairs)))


if __name__ == "__main__":
    main()
