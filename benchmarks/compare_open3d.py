#!/usr/bin/python3
"""PicoScan against Open3D 0.16, side by side on the same views.

Two parts on a simulated turntable (the seed rig, 8 views 45 degrees apart at 25 degrees
elevation, independent camera noise per view): the built-in mechanical part speckle-painted,
and the same part in plain uniform grey. The views are simulated once through the picoscan
Python module (cached under --data) with their true poses and the true part mesh.

Registration, for each of the 8 neighbouring pairs around the ring, both tools get the same
two view PLY files and are timed from reading the files to the pose:
  global  no initial guess: PicoScan 'stitch A B' (ORB on the white frames, FPFH, RANSAC,
          point-to-plane ICP, the gates) against Open3D FPFH + RANSAC + point-to-plane ICP;
  icp     from the true pose knocked by 2 degrees and 2 mm: PicoScan 'stitch A B
          --initial-poses' against Open3D point-to-plane ICP.
PicoScan is timed twice: as the 'picoscan stitch' process (start-up, reading, registering,
writing the merged cloud), and in-process through the picoscan module (reading both views and
align_views, the registration 'stitch' runs), timed inside this Python as Open3D is.
Errors: the rotation angle and the shift of the moving view's centroid between the found
and the true relative pose; a pair is right when both are under 1 degree and 1 mm.

Model, all 8 views of each part: PicoScan's stitch (no guess) then its mesh (Poisson, its
default fill), against Open3D's multiway registration (the neighbouring global results as a
pose graph with the loop closed, optimised) then its screened Poisson (depth 9). Both
meshes are judged against the true part: the volume, whether the mesh is closed (Open3D's
is_watertight), and the distances truth -> mesh (over the whole outer surface of the true
part, the unseen bottom included) and mesh -> truth (per vertex). The true part is built of
solids standing on each other (the boss is sunk 1 mm into the block): the faces where they
meet lie inside the part and are left out, and its volume is that of the union (see TruePart).
Whole pipelines are timed inside this Python for both tools: PicoScan through its module
(read_view_ply, stitch_views and mesh_points: what 'picoscan stitch' and 'picoscan mesh'
run, without the processes' start-up and files), Open3D through open3d.

Whole pipelines (--pipelines, run on its own), all 8 views of each part, from the view files
to the mesh: PicoScan's stitch (automatic mode, no guess) then its mesh, against Open3D's own
pipeline as its tutorials give it: FPFH + RANSAC + point-to-plane ICP for each neighbouring
pair, the poses chained from view 0, the clouds merged, its Poisson (depth 9), then the
vertices of the lowest 1 % of Poisson density removed. Same measures as the model, with the
wall and CPU time.

Two placements (--placements, run on its own): the same whole pipelines on 16 views of each
part, 8 standing and 8 laid on its side (turned 20 degrees, so that the face it stood on is
seen). PicoScan: stitch_views with the second placement's views marked as such (as 'stitch
STANDING... --then SIDE...'), then its mesh. Open3D: each placement chained as above, the
second placement's merged cloud registered onto the first's by the same FPFH + RANSAC + ICP
(left out of the model when Open3D finds no fit), then its Poisson. A second table gives, for
each tool, the views of each placement placed right in the model, and the join: right or
wrong against the true pose of the second placement's first view (1 degree and 1 mm at its
centroid), or not joined and why, with the wall and CPU time of each placement's alignment and
of the join (PicoScan's from its progress reports: each placement made one cloud and
registered, summed over every way its automatic mode tried). A third table gives each model
against issue 12's targets (TARGETS: every view right, volume within 0.5 %, truth -> mesh mean
15 um, p95 40 um, max 150 um, mesh -> truth p95 40 um, max 150 um), pass or FAIL with the figure.

Run with Debian's python3 (it has open3d, numpy and the module's ABI):
    /usr/bin/python3 benchmarks/compare_open3d.py [--build build] [--data build/bench-compare]
        [--baseline OLD/picoscan]  (an earlier build on the same pairs, global registration: before and after)
    /usr/bin/python3 benchmarks/compare_open3d.py --pipelines  (the whole pipelines only)
    /usr/bin/python3 benchmarks/compare_open3d.py --placements  (the whole pipelines, two placements)
        [--no-open3d]       (PicoScan's pipeline only)
        [--reuse-stitch]    (PicoScan's merged cloud and poses from the last run: only meshed again)
With --pipelines or --placements, PicoScan's merged cloud, poses and mesh are written to
DATA/PART.../picoscan/ (merged.ply, poses.txt, mesh.ply), and for each model the script prints
where each maximum lies, in the model frame and in the part's own frame (the frame of
picoscan.mechanical_part()), with the true surface's normal there.
"""
import argparse
import copy
import os
import re
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np
import open3d as o3d

PARTS = ("speckled", "plain")


def read_poses(path):
    """Poses in the format 'picoscan stitch' writes: a name line, then 4 rows of 4 numbers;
    a view left out is marked NOT-ALIGNED on its name line and comes back as None."""
    with open(path) as f:
        lines = [line for line in f if line.strip() and not line.startswith("#")]
    return [None if "NOT-ALIGNED" in lines[k] else np.array([[float(v) for v in lines[k + 1 + r].split()] for r in range(4)])
            for k in range(0, len(lines), 5)]


def write_poses(path, poses):
    """As read_poses reads them: a view left out (None) is written NOT-ALIGNED, as the identity."""
    with open(path, "w") as f:
        for i, pose in enumerate(poses):
            f.write("view_%d%s\n" % (i, " NOT-ALIGNED" if pose is None else ""))
            for row in (np.eye(4) if pose is None else pose):
                f.write(" ".join("%.9f" % v for v in row) + "\n")


def simulate(build, directory, part_kind, placements=("views",)):
    """8 turntable views of the mechanical part (painted or plain) per placement, their truth
    and the true mesh. Placements: "views" (the part standing, the pairs' views), or
    "standing" and "side" (then laid on its side, turned 20 degrees, so that the face it stood
    on is seen; independent camera noise)."""
    picoscan = picoscan_module(build)
    part = picoscan.mechanical_part()
    part_to_camera = []
    for placement in placements:
        os.makedirs(os.path.join(directory, placement), exist_ok=True)
        options = picoscan.TurntableScanOptions()
        options.plan.top_view = False
        if part_kind == "plain":
            part.colours = np.zeros((0, 3), np.uint8)  # no paint: uniform albedo
            options.part_albedo = 0.6                  # grey plastic
        if placement == "side":
            options.plan.placement = picoscan.PartPlacement.OnItsSide
            options.plan.placement_turn_deg = 20
            options.camera.seed = 101

        def on_view(simulated):
            path = os.path.join(directory, placement, simulated.name + ".ply")
            picoscan.write_view_ply(simulated.view, path, False)
            print("  %s: %d points" % (path, simulated.cleaning.remaining), file=sys.stderr)

        part_to_camera += [np.asarray(p) for p in picoscan.simulate_turntable_scan(
            part, picoscan.seed_rig_calibration(), options, on_view)]
    truth = picoscan.transformed(part, part_to_camera[0])  # model frame: the first view's camera
    picoscan.write_stl(truth, os.path.join(directory, "truth.stl"), False)
    write_poses(os.path.join(directory, "part_pose.txt"), [part_to_camera[0]])
    write_poses(os.path.join(directory, "true_poses.txt"),
                [part_to_camera[0] @ np.linalg.inv(p) for p in part_to_camera])


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


def children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


class Clock:
    """Wall and CPU seconds (all threads; with child=True, of the child processes)."""
    def __init__(self, child=False):
        self.cpu_now = children_cpu if child else time.process_time
        self.wall, self.cpu = time.perf_counter(), self.cpu_now()

    def read(self):
        return time.perf_counter() - self.wall, self.cpu_now() - self.cpu


def picoscan_pair(picoscan, fixed, moving, work, initial=None):
    out = os.path.join(work, "pair.ply")
    command = [picoscan, "stitch", fixed, moving, "--out", out]
    if initial is not None:
        write_poses(os.path.join(work, "initial.txt"), [np.eye(4), initial])
        command += ["--initial-poses", os.path.join(work, "initial.txt")]
    clock = Clock(child=True)
    result = subprocess.run(command, capture_output=True, text=True)
    seconds = clock.read()
    if result.returncode != 0:
        return None, seconds
    return read_poses(os.path.join(work, "pair.poses.txt"))[1], seconds


def picoscan_module(build):
    sys.path.insert(0, os.path.join(build, "freecad_workbench", "PicoScan"))  # where the build puts the module
    import picoscan
    return picoscan


def picoscan_in_process(module, fixed, moving, initial=None):
    """What 'stitch A B' does up to the pose (reading both views, align_views with the same
    options), but inside this running Python, as Open3D is timed: no process start-up, no
    merged cloud written."""
    clock = Clock()
    views = [module.read_view_ply(fixed), module.read_view_ply(moving)]
    options = module.RegistrationOptions()
    if initial is not None:
        options.initial_poses = [np.eye(4), initial]
    alignment = module.align_views(views, ["fixed", "moving"], options)
    seconds = clock.read()
    moved = alignment.views[1]
    return (np.asarray(moved.pose) if moved.aligned else None), seconds


def open3d_load(path, voxel_mm):
    return o3d.io.read_point_cloud(path).voxel_down_sample(voxel_mm)


def open3d_global(fixed, moving):
    clock = Clock()
    _, fine = open3d_register(open3d_load(fixed, 0.7), open3d_load(moving, 0.7))
    return fine.transformation, clock.read()


def open3d_register(target, source):
    """Open3D's global registration of two clouds (0.7 mm voxels): FPFH on 2 mm voxels,
    mutual-filter RANSAC, point-to-plane ICP. Both results (RANSAC's, then ICP's: the
    source -> target transform, its fitness and inlier RMSE)."""
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
    return coarse, fine


def open3d_icp(fixed, moving, initial):
    clock = Clock()
    target, source = open3d_load(fixed, 0.7), open3d_load(moving, 0.7)
    reg = o3d.pipelines.registration
    fine = reg.registration_icp(source, target, 3.0, initial, reg.TransformationEstimationPointToPlane(),
                                reg.ICPConvergenceCriteria(max_iteration=100))
    return fine.transformation, clock.read()


def summary(name, errors, times):
    good = [e for e in errors if e is not None and e[0] < 1.0 and e[1] < 1.0]
    wrong = sum(1 for e in errors if e is not None and not (e[0] < 1.0 and e[1] < 1.0))
    refused = sum(1 for e in errors if e is None)
    if good:
        angles, shifts = [e[0] for e in good], [e[1] for e in good]
        accuracy = "%.4f / %.4f | %.4f / %.4f" % (np.median(angles), max(angles), np.median(shifts), max(shifts))
    else:
        accuracy = "- | -"
    return "| %s | %d / %d / %d | %s | %.2f / %.2f |" % (name, len(good), wrong, refused, accuracy,
                                                      np.median([t[0] for t in times]), np.median([t[1] for t in times]))


def mesh_volume(mesh):
    """Signed volume by the divergence theorem (meaningful for a closed, outward mesh)."""
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.triangles)
    return float(np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6.0)


def collapsed(mesh):
    """Which triangles have two corners at one position (in float32, as Open3D's search
    stores them). Debian's Open3D 0.16 aborts the whole Python on such a triangle when it
    searches for the closest point (an Eigen assertion, `m_coeffs.w()==Scalar(0)` in
    AlignedVector3::squaredNorm, inside RaycastingScene's closest-point query), and Poisson
    meshes can hold them."""
    corners = np.asarray(mesh.vertices, np.float32)[np.asarray(mesh.triangles)]
    same = lambda a, b: (corners[:, a] == corners[:, b]).all(axis=1)
    return same(0, 1) | same(1, 2) | same(2, 0)


def scene_of(mesh):
    """Open3D's closest-point search over a mesh, without its collapsed triangles: each has no
    area, and where it is not on the mesh's border its edges are its neighbours' edges too, so
    no distance changes. Primitive ids count the kept triangles."""
    scene = o3d.t.geometry.RaycastingScene()
    kept = np.asarray(mesh.triangles)[~collapsed(mesh)]
    scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, np.float32)), o3d.core.Tensor(kept.astype(np.uint32)))
    return scene


def inside(scene, normals, points):
    """Whether each point lies inside a closed solid: behind the face nearest to it. (Open3D's
    own occupancy test casts rays, and its ray casting finds no hit at all on this machine.)"""
    closest = scene.compute_closest_points(o3d.core.Tensor(np.asarray(points, np.float32)))
    faces = closest["primitive_ids"].numpy().astype(np.int64)
    return np.einsum("ij,ij->i", points - closest["points"].numpy(), normals[faces]) < 0


class TruePart:
    """The true part (truth.stl) as the meshes are judged against it. The simulated part is
    built of closed solids standing on each other: the mechanical part's boss is sunk 1 mm into
    the block, so truth.stl also holds faces inside the part (the block's top face under the
    boss, the boss's foot and its bottom cap). No scan can see those, and a point on the block's
    top face under the middle of the boss is 7 mm from the part's surface: sampled as 'true
    surface', they put a 7 mm maximum on any right mesh. So the surface samples are taken over
    the outer surface only (a sample of one solid lying inside another is dropped), and the
    volume is that of the union (the solids' volumes less their overlaps, by Monte Carlo in
    the boxes where they overlap). mesh -> truth still measures to every true face (the inner
    ones only meet the outer surface at the boss's foot)."""

    def __init__(self, path, samples=200000):
        mesh = o3d.io.read_triangle_mesh(path)
        mesh.merge_close_vertices(1e-6)
        mesh.remove_degenerate_triangles()  # the boss's caps are quads folded into fan slices
        mesh.compute_triangle_normals()
        self.mesh = mesh
        self.scene = scene_of(mesh)
        clusters = np.asarray(mesh.cluster_connected_triangles()[0])
        solids = []
        for c in range(int(clusters.max()) + 1):
            solid = o3d.geometry.TriangleMesh(mesh)
            solid.remove_triangles_by_mask(clusters != c)
            solid.remove_unreferenced_vertices()
            solid.compute_triangle_normals()
            solids.append(solid)  # closed in space, though not as a graph (its quads' grids meet at T-junctions)
        scenes = [scene_of(solid) for solid in solids]
        normals = [np.asarray(solid.triangle_normals)[~collapsed(solid)] for solid in solids]
        o3d.utility.random.seed(1)  # the same surface samples in every run
        area = sum(solid.get_surface_area() for solid in solids)
        outer, self.inner_samples = [], 0
        for k, solid in enumerate(solids):
            count = max(1, round(samples * solid.get_surface_area() / area))
            points = np.asarray(solid.sample_points_uniformly(count).points)
            within = np.zeros(len(points), bool)
            for other in range(len(solids)):
                if other != k:
                    within |= inside(scenes[other], normals[other], points)
            self.inner_samples += int(within.sum())
            outer.append(points[~within].astype(np.float32))
        self.outer_samples = np.concatenate(outer)
        rng = np.random.default_rng(1)
        self.volume = sum(mesh_volume(solid) for solid in solids)
        for a in range(len(solids)):
            for b in range(a + 1, len(solids)):
                low = np.maximum(solids[a].get_min_bound(), solids[b].get_min_bound())
                high = np.minimum(solids[a].get_max_bound(), solids[b].get_max_bound())
                if np.any(high <= low):
                    continue
                points = rng.uniform(low, high, size=(200000, 3))
                both = inside(scenes[a], normals[a], points) & inside(scenes[b], normals[b], points)
                self.volume -= float(both.mean() * np.prod(high - low))
        print("true part: %d solids, %d of %d surface samples inside another solid (dropped), volume %.2f cm3 "
              "(the solids' sum %.2f cm3)" % (len(solids), self.inner_samples, self.inner_samples + len(self.outer_samples),
                                             self.volume / 1000, mesh_volume(mesh) / 1000), file=sys.stderr)


def distances(truth, mesh):
    """truth -> mesh over the true part's outer surface samples (about 200 000, the same for
    every mesh), and mesh -> truth per vertex (mm), over the vertices with finite coordinates
    (a NaN query aborts Open3D's search as a collapsed triangle does); and how many were not."""
    to_mesh = scene_of(mesh).compute_distance(o3d.core.Tensor(truth.outer_samples)).numpy()
    vertices = np.asarray(mesh.vertices, np.float32)
    finite = np.isfinite(vertices).all(axis=1)
    to_truth = truth.scene.compute_distance(o3d.core.Tensor(vertices[finite])).numpy()
    return to_mesh, to_truth, int((~finite).sum())


def part_to_model(module, directory):
    """The pose of the part's own frame (picoscan.mechanical_part()) in the model frame: written
    by simulate; for views simulated before it was, recovered from truth.stl (the part's faces
    in the same order, moved) by a least-squares fit of the corners. None when they do not fit."""
    path = os.path.join(directory, "part_pose.txt")
    if os.path.exists(path):
        return read_poses(path)[0]
    part, truth = module.mechanical_part(), module.read_stl(os.path.join(directory, "truth.stl"))
    source = np.asarray(part.vertices, np.float64)[np.asarray(part.faces)].reshape(-1, 3)
    target = np.asarray(truth.vertices, np.float64)[np.asarray(truth.faces)].reshape(-1, 3)
    if source.shape != target.shape:
        return None
    source_mean, target_mean = source.mean(axis=0), target.mean(axis=0)
    u, _, vt = np.linalg.svd((source - source_mean).T @ (target - target_mean))
    turn = (u @ np.diag([1, 1, np.sign(np.linalg.det(u @ vt))]) @ vt).T
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = turn, target_mean - turn @ source_mean
    if np.abs(source @ turn.T + pose[:3, 3] - target).max() > 1e-3:
        return None
    return pose


def where_maxima(name, figures, truth, part_pose):
    """Prints where a model's two maxima lie: the point (truth -> mesh: the true surface's
    sample; mesh -> truth: the mesh vertex), in the model frame and in the part's frame, and
    the normal of the true face nearest to it in the part's frame (which face or edge it is)."""
    to_part = np.linalg.inv(part_pose) if part_pose is not None else None
    closest = truth.scene.compute_closest_points(
        o3d.core.Tensor(np.array([figures["to_mesh_at"], figures["to_truth_at"]], np.float32)))
    triangles = closest["primitive_ids"].numpy().astype(np.int64)
    normals = np.asarray(truth.mesh.triangle_normals)[~collapsed(truth.mesh)][triangles]
    for k, (label, value, at) in enumerate((("truth -> mesh", figures["to_mesh_max"], figures["to_mesh_at"]),
                                            ("mesh -> truth", figures["to_truth_max"], figures["to_truth_at"]))):
        text = "%s: %s max %.3f mm at model (%.3f, %.3f, %.3f)" % (name, label, value, *at)
        if to_part is not None:
            text += ", part (%.3f, %.3f, %.3f), true face normal (%.2f, %.2f, %.2f)" % (
                *(to_part[:3, :3] @ at + to_part[:3, 3]), *(to_part[:3, :3] @ normals[k]))
        print(text)


def right_views(truth, poses, centroids):
    """Views placed within 1 degree and 1 mm (at their centroid) of the truth."""
    return sum(1 for k, pose in enumerate(poses)
               if pose is not None and all(e < 1.0 for e in pose_error(truth[k], pose, centroids[k])))


def open3d_model(views, pair_results):
    """Open3D's multiway registration: neighbouring global fits as odometry, the last one closing
    the loop, optimised as a pose graph; then screened Poisson of the merged cloud."""
    clock = Clock()
    reg = o3d.pipelines.registration
    clouds = [open3d_load(v, 0.7) for v in views]
    graph = reg.PoseGraph()
    pose = np.eye(4)
    graph.nodes.append(reg.PoseGraphNode(pose))
    count = len(views)
    for k in range(count):
        fixed, moving = k, (k + 1) % count
        transform = np.asarray(pair_results[k])  # moving -> fixed
        information = reg.get_information_matrix_from_point_clouds(clouds[moving], clouds[fixed], 1.5, transform)
        if moving != 0:
            pose = pose @ transform
            graph.nodes.append(reg.PoseGraphNode(pose))
            graph.edges.append(reg.PoseGraphEdge(moving, fixed, transform, information, uncertain=False))
        else:
            graph.edges.append(reg.PoseGraphEdge(moving, fixed, transform, information, uncertain=True))
    reg.global_optimization(graph, reg.GlobalOptimizationLevenbergMarquardt(),
                            reg.GlobalOptimizationConvergenceCriteria(),
                            reg.GlobalOptimizationOption(max_correspondence_distance=1.5, edge_prune_threshold=0.25,
                                                         reference_node=0))
    merged = o3d.geometry.PointCloud()
    for k, cloud in enumerate(clouds):
        merged += o3d.geometry.PointCloud(cloud).transform(graph.nodes[k].pose)
    merged = merged.voxel_down_sample(0.4)
    run = Pipeline()
    run.mesh, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(merged, depth=9)
    run.poses = [np.asarray(node.pose) for node in graph.nodes]
    run.seconds["all"] = clock.read()
    return run


def placement_of(stage):
    """Which part of PicoScan's stitch a progress report belongs to: 'placement N' (aligning
    that placement's views), 'join' (each placement made one cloud and registered to the
    others) or 'other' (the refinement of every view, the merge)."""
    match = re.search(r"placement (\d+): ", stage)
    if match:
        return "placement " + match.group(1)
    if "merging each placement" in stage or "registering placement" in stage:
        return "join"
    return "other"


class StageClock:
    """A progress callback for stitch_views: the wall and CPU seconds spent in each part of
    the stitch (placement_of), from one report to the next; summed over every way 'automatic'
    tried (features, then the turntable round)."""
    def __init__(self):
        self.seconds = {}
        self.part, self.clock = "other", Clock()

    def __call__(self, fraction, stage):
        self.switch(placement_of(stage))
        return True

    def switch(self, part):
        wall, cpu = self.clock.read()
        before = self.seconds.get(self.part, (0.0, 0.0))
        self.seconds[self.part] = (before[0] + wall, before[1] + cpu)
        self.part, self.clock = part, Clock()


class Pipeline:
    """One tool's run from the view files to the mesh: the mesh (Open3D's; None when there is
    none), each view's pose in the model (None when left out), for each placement after the
    first its join (the placement frame -> model pose, None when not joined, and why), and the
    wall and CPU seconds of each placement's alignment, of the joins and of everything."""
    def __init__(self):
        self.mesh, self.poses, self.joins, self.problems = None, [], [], []
        self.seconds = {}


def picoscan_pipeline(module, placements, keep, reuse=False):
    """PicoScan's whole pipeline inside this Python, timed as Open3D's is: the views read,
    stitch_views (what 'picoscan stitch A... --then B...' runs: automatic mode, each placement
    aligned, then the placements joined by shape, then every view refined), then mesh_points
    with the defaults of 'picoscan mesh' (Poisson, its default fill). The merged cloud, the
    poses and the mesh are written to the folder `keep`; with reuse, the stitch is read back
    from there (no joins then, and the time is the meshing's only)."""
    os.makedirs(keep, exist_ok=True)
    merged_path, poses_path = os.path.join(keep, "merged.ply"), os.path.join(keep, "poses.txt")
    if reuse:
        run, clock = Pipeline(), Clock()
        run.poses = read_poses(poses_path)
        points, merged = module.read_ply(merged_path), module.PointCloud()  # as 'picoscan mesh' reads it
        merged.points, merged.normals, merged.colours = points.vertices, points.normals, points.colours
        mesh = module.mesh_points(merged, module.MeshOptions())
        module.write_ply(mesh, os.path.join(keep, "mesh.ply"))
        run.mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(np.asarray(mesh.vertices, np.float64)),
                                             o3d.utility.Vector3iVector(np.asarray(mesh.faces, np.int32)))
        run.seconds = {"all": clock.read()}
        return run
    run, clock = Pipeline(), Clock()
    paths = [path for views in placements for path in views]
    views = [module.read_view_ply(path) for path in paths]
    names = ["%s_%s" % (os.path.basename(os.path.dirname(path)), os.path.basename(path)) for path in paths]
    options = module.StitchOptions()
    options.automatic = True
    if len(placements) > 1:
        options.placement_of_view = [p for p, views in enumerate(placements) for _ in views]
    stages = StageClock()
    stitched = module.stitch_views(views, names, options, stages)
    stages.switch("other")
    run.poses = [np.asarray(view.pose) if view.aligned else None for view in stitched.alignment.views]
    for placement in stitched.alignment.placements[1:]:
        run.joins.append(np.asarray(placement.pose) if placement.aligned else None)
        run.problems.append(placement.problem)
    write_poses(poses_path, run.poses)
    module.write_ply(stitched.merged, merged_path)
    if len(stitched.merged):
        mesh = module.mesh_points(stitched.merged, module.MeshOptions())
        module.write_ply(mesh, os.path.join(keep, "mesh.ply"))
        run.mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(np.asarray(mesh.vertices, np.float64)),
                                             o3d.utility.Vector3iVector(np.asarray(mesh.faces, np.int32)))
    run.seconds = dict(stages.seconds)
    if len(placements) == 1:  # align_views reports no placements: the stitch is placement 1's alignment
        run.seconds = {"placement 1": tuple(sum(s[k] for s in stages.seconds.values()) for k in range(2))}
    run.seconds["all"] = clock.read()
    return run


def open3d_chain(views):
    """Each neighbouring pair by open3d_global, the poses chained from the first view; the
    poses and the views' clouds (with their normals) merged in the first view's frame."""
    poses = [np.eye(4)]
    for k in range(len(views) - 1):
        transform, _ = open3d_global(views[k], views[k + 1])  # view k+1 -> view k
        poses.append(poses[-1] @ np.asarray(transform))
    merged = o3d.geometry.PointCloud()
    for view, pose in zip(views, poses):
        merged += open3d_load(view, 0.7).transform(pose)
    return poses, merged


def open3d_join(model, placement):
    """A placement's merged cloud registered onto the model's by open3d_register: the
    placement -> model transform, or None and why when Open3D found no fit (RANSAC or ICP with
    no inlier correspondence; Open3D then returns the identity, which is not a result)."""
    try:
        coarse, fine = open3d_register(model, placement)
    except RuntimeError as error:
        return None, "Open3D failed: %s" % error
    if coarse.fitness == 0 or fine.fitness == 0:
        return None, "no inlier correspondence (RANSAC fitness %.3f, ICP fitness %.3f)" % (coarse.fitness, fine.fitness)
    return np.asarray(fine.transformation), ""


def open3d_pipeline(placements):
    """Open3D's pipeline as its tutorials give it: each neighbouring pair of a placement by
    open3d_global (FPFH + RANSAC + point-to-plane ICP), the poses chained from the placement's
    first view, its views' clouds (with their normals, turned with them) merged; each further
    placement's merged cloud registered onto the first's by the same global registration (left
    out when Open3D finds no fit); the joined clouds thinned to 0.4 mm, Poisson at depth 9.
    Gives the raw Poisson mesh, and the same run with the mesh cropped by density (the
    vertices of the lowest 1 % of density removed, as the Poisson tutorial does)."""
    run, clock = Pipeline(), Clock()
    merged = o3d.geometry.PointCloud()
    for p, views in enumerate(placements):
        placement_clock = Clock()
        poses, cloud = open3d_chain(views)
        run.seconds["placement %d" % (p + 1)] = placement_clock.read()
        if p == 0:
            join = np.eye(4)
        else:
            join_clock = Clock()
            join, problem = open3d_join(merged, cloud)
            run.seconds["join"] = join_clock.read()
            run.joins.append(join)
            run.problems.append(problem)
        if join is None:
            run.poses += [None] * len(poses)
            continue
        run.poses += [join @ pose for pose in poses]
        merged += cloud.transform(join)
    merged = merged.voxel_down_sample(0.4)
    run.mesh, densities = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(merged, depth=9)
    run.seconds["all"] = clock.read()
    cropped = copy.copy(run)
    cropped.mesh = o3d.geometry.TriangleMesh(run.mesh)
    densities = np.asarray(densities)
    cropped.mesh.remove_vertices_by_mask(densities < np.quantile(densities, 0.01))
    cropped.seconds = dict(run.seconds, all=clock.read())
    return run, cropped


# Issue 12's measured targets for a complete model: (heading, the figure's key, its limit).
# Volume as a fraction of the true part's, distances in mm.
TARGETS = (("volume within 0.5 %", "volume_error", 0.005),
           ("truth -> mesh mean <= 15 um", "to_mesh_mean", 0.015),
           ("truth -> mesh p95 <= 40 um", "to_mesh_p95", 0.040),
           ("truth -> mesh max <= 150 um", "to_mesh_max", 0.150),
           ("mesh -> truth p95 <= 40 um", "to_truth_p95", 0.040),
           ("mesh -> truth max <= 150 um", "to_truth_max", 0.150))


def model_figures(run, truth):
    """The measures of one tool's mesh against the true part (None without a mesh): closed
    (Open3D's is_watertight), volume and its error, truth -> mesh mean / p95 / max, mesh ->
    truth p95 / max (None without a finite vertex) and the vertices left out as not finite."""
    if run.mesh is None or not run.mesh.has_triangles():
        return None
    to_mesh, to_truth, not_finite = distances(truth, run.mesh)
    volume = mesh_volume(run.mesh)
    vertices = np.asarray(run.mesh.vertices)
    vertices = vertices[np.isfinite(vertices).all(axis=1)]
    return {"watertight": run.mesh.is_watertight(), "volume": volume, "volume_error": volume / truth.volume - 1,
            "to_mesh_mean": to_mesh.mean(), "to_mesh_p95": np.percentile(to_mesh, 95), "to_mesh_max": to_mesh.max(),
            "to_mesh_at": truth.outer_samples[int(np.argmax(to_mesh))].astype(np.float64),
            "to_truth_p95": np.percentile(to_truth, 95) if len(to_truth) else None,
            "to_truth_max": to_truth.max() if len(to_truth) else None,
            "to_truth_at": vertices[int(np.argmax(to_truth))] if len(to_truth) else None, "not_finite": not_finite}


def pipeline_row(name, run, figures, placed):
    """One line of the model table: the same measures for every tool's mesh."""
    if figures is None:
        return "| %s | %s | no mesh | - | - | - | %.0f / %.0f |" % (name, placed, *run.seconds["all"])
    print("%s: %d of %d triangles with two corners at one position, left out of the distance search"
          % (name, collapsed(run.mesh).sum(), len(run.mesh.triangles)), file=sys.stderr)
    volume_text = "%.2f (%+.2f %%)" % (figures["volume"] / 1000, 100 * figures["volume_error"])
    if not figures["watertight"]:
        volume_text = "open (%s)" % volume_text  # an open mesh encloses no volume: indicative only
    to_truth_text = "-" if figures["to_truth_max"] is None else "%.3f / %.3f" % (figures["to_truth_p95"],
                                                                               figures["to_truth_max"])
    if figures["not_finite"]:
        to_truth_text += " (%d vertices not finite, left out)" % figures["not_finite"]
    return ("| %s | %s | %s | %s | %.3f / %.3f / %.3f | %s | %.0f / %.0f |" % (
        name, placed, "yes" if figures["watertight"] else "no", volume_text, figures["to_mesh_mean"],
        figures["to_mesh_p95"], figures["to_mesh_max"], to_truth_text, *run.seconds["all"]))


def targets_row(name, figures, views, right):
    """One line of the targets table: each of issue 12's targets passed or failed, with the
    figure. Every view must be placed right; an open mesh encloses no volume (fails it)."""
    cells = ["%s (%d of %d)" % ("pass" if right == views else "FAIL", right, views)]
    for _, key, limit in TARGETS:
        value = None if figures is None else figures[key]
        if value is None or (key == "volume_error" and not figures["watertight"]):
            cells.append("FAIL (%s)" % ("no mesh" if figures is None else "open" if value is not None else "-"))
        elif key == "volume_error":
            cells.append("%s (%+.2f %%)" % ("pass" if abs(value) <= limit else "FAIL", 100 * value))
        else:
            cells.append("%s (%.0f um)" % ("pass" if value <= limit else "FAIL", 1000 * value))
    return "| %s | %s |" % (name, " | ".join(cells))


def placements_row(name, run, truth, centroids, sizes):
    """One line of the placements table: per placement, its views placed right in the model
    and the time to align them; per join, right / wrong (against the true pose of the
    placement's first view, at its centroid) or not joined and why, and its time."""
    cells, first = [], 0
    for p, size in enumerate(sizes):
        right = right_views(truth[first:first + size], run.poses[first:first + size], centroids[first:first + size])
        cells.append("%d of %d right, %.0f / %.0f s" % (right, size, *run.seconds["placement %d" % (p + 1)]))
        if p > 0:
            join = run.joins[p - 1]
            if join is None:
                verdict = "not joined: %s" % run.problems[p - 1]
            else:
                error = pose_error(truth[first], join, centroids[first])
                verdict = "%s (%.3f deg, %.3f mm)" % ("right" if max(error) < 1.0 else "WRONG", *error)
            cells.append("%s, %.0f / %.0f s" % (verdict, *run.seconds["join"]))
        first += size
    return "| %s | %s |" % (name, " | ".join(cells))


def print_model_table(rows, views=8):
    print("| model | views merged / right (of %d) | watertight | volume cm3 (vs true) | "
          "truth -> mesh mean / p95 / max (mm) | mesh -> truth p95 / max (mm) | time wall / CPU (s) |" % views)
    print("|---|---|---|---|---|---|---|")
    print("\n".join(rows))


def print_targets_table(rows):
    print("\nIssue 12's targets (pass / FAIL, the figure):\n")
    print("| model | every view right | %s |" % " | ".join(heading for heading, _, _ in TARGETS))
    print("|---|---|%s" % ("---|" * len(TARGETS)))
    print("\n".join(rows))


def print_placements_table(rows, sizes):
    columns = ["placement 1: views right, time wall / CPU"]
    for p in range(1, len(sizes)):
        columns += ["placement %d: views right, time wall / CPU" % (p + 1),
                    "placement %d joined to placement 1: against the truth, time wall / CPU" % (p + 1)]
    print("| pipeline | %s |" % " | ".join(columns))
    print("|---|%s" % ("---|" * len(columns)))
    print("\n".join(rows) + "\n")


def part_views(args, part, placements=("views",)):
    """A part's folder, true poses and view files (those of each placement in turn), simulated
    first when missing."""
    directory = os.path.join(args.data, part if placements == ("views",) else part + "-" + "-".join(placements))
    if not os.path.exists(os.path.join(directory, "true_poses.txt")):
        print("simulating the %s part's views into %s" % (part, directory), file=sys.stderr)
        simulate(os.path.abspath(args.build), directory, part, placements)
    truth = read_poses(os.path.join(directory, "true_poses.txt"))
    per_placement = len(truth) // len(placements)
    return directory, truth, [os.path.join(directory, placement, "view_%d.ply" % k)
                              for placement in placements for k in range(per_placement)]


def compare_pipelines(args, module, placements=("views",)):
    """The --pipelines and --placements runs: both whole pipelines on each part's views (with
    two placements, both tools get the standing views, then the side views); prints the
    placements table and the model table, and with two placements the table of issue 12's
    targets."""
    placement_table, model_table, targets_table = [], [], []
    for part in args.parts.split(","):
        directory, truth, views = part_views(args, part, placements)
        size = len(views) // len(placements)
        by_placement = [views[k:k + size] for k in range(0, len(views), size)]
        sizes = [size] * len(placements)
        truth_part = TruePart(os.path.join(directory, "truth.stl"))
        centroids = [np.asarray(o3d.io.read_point_cloud(v).get_center()) for v in views]
        part_pose = part_to_model(module, directory)
        picoscan = picoscan_pipeline(module, by_placement, os.path.join(directory, "picoscan"), args.reuse_stitch)
        runs = [("PicoScan stitch + mesh", picoscan)]
        open3d_cropped = None
        if not args.no_open3d:
            open3d_raw, open3d_cropped = open3d_pipeline(by_placement)
            runs += [("Open3D chained pairs + Poisson", open3d_raw),
                     ("Open3D chained pairs + Poisson, cropped by density", open3d_cropped)]
        for name, run in runs:
            right = right_views(truth, run.poses, centroids)
            placed = "%d / %d" % (sum(p is not None for p in run.poses), right)
            figures = model_figures(run, truth_part)
            model_table.append(pipeline_row("%s: %s" % (part, name), run, figures, placed))
            print(model_table[-1], file=sys.stderr)
            targets_table.append(targets_row("%s: %s" % (part, name), figures, len(views), right))
            if figures is not None and figures["to_truth_at"] is not None:
                where_maxima("%s: %s" % (part, name), figures, truth_part, part_pose)
            if run is not open3d_cropped and not args.reuse_stitch:  # the crop changes the mesh only
                placement_table.append(placements_row("%s: %s" % (part, name.replace(" + Poisson", "")), run, truth,
                                                      centroids, sizes))
                print(placement_table[-1], file=sys.stderr)
    if placement_table:  # none when the stitch was reused
        print_placements_table(placement_table, sizes)
    print_model_table(model_table, len(views))
    if len(placements) > 1:  # the targets are those of a complete model: two placements
        print_targets_table(targets_table)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", default="build", help="the build tree (core/picoscan, the picoscan module)")
    parser.add_argument("--picoscan", help="the picoscan binary (default: BUILD/core/picoscan)")
    parser.add_argument("--data", default="build/bench-compare", help="simulated views (made when missing)")
    parser.add_argument("--parts", default=",".join(PARTS), help="speckled,plain")
    parser.add_argument("--no-model", action="store_true", help="registration of the pairs only")
    parser.add_argument("--model-only", action="store_true", help="the models only (Open3D's global pairs still feed its pose graph)")
    parser.add_argument("--repeat", type=int, default=1,
                        help="time each pair N times, every tool in turn each round, and keep the fastest round "
                             "(a slow spell of the machine then does not decide the comparison)")
    parser.add_argument("--baseline", help="another picoscan binary (an earlier build) run on the same pairs")
    parser.add_argument("--pipelines", action="store_true",
                        help="only the whole pipelines: PicoScan stitch + mesh against Open3D's chained pairs + Poisson")
    parser.add_argument("--placements", action="store_true",
                        help="only the whole pipelines on two placements (standing, then on its side) of 8 views each")
    parser.add_argument("--no-open3d", action="store_true", help="with --pipelines or --placements: PicoScan's pipeline only")
    parser.add_argument("--reuse-stitch", action="store_true",
                        help="with --pipelines or --placements: PicoScan's merged cloud and poses as the last run "
                             "wrote them (DATA/PART.../picoscan/), only meshed again (no joins table)")
    args = parser.parse_args()
    if (args.no_open3d or args.reuse_stitch) and not (args.pipelines or args.placements):
        parser.error("--no-open3d and --reuse-stitch go with --pipelines or --placements")
    picoscan = os.path.abspath(args.picoscan or os.path.join(args.build, "core", "picoscan"))
    if args.pipelines or args.placements:
        compare_pipelines(args, picoscan_module(os.path.abspath(args.build)),
                          ("standing", "side") if args.placements else ("views",))
        return
    registration_table, model_table = [], []
    for part in args.parts.split(","):
        directory, truth, views = part_views(args, part)
        count = len(truth)
        pairs = [(k, (k + 1) % count) for k in range(count)]
        rng = np.random.default_rng(1)
        tools = ("PicoScan", "PicoScan in-process", "Open3D") + (("PicoScan before",) if args.baseline else ())
        rows = {(kind, tool): ([], []) for kind in ("global", "icp") for tool in tools
                if kind == "global" or tool != "PicoScan before"}
        module = picoscan_module(os.path.abspath(args.build))
        open3d_found = []
        with tempfile.TemporaryDirectory() as work:
            for a, b in pairs:
                true_relative = np.linalg.inv(truth[a]) @ truth[b]
                centroid = np.asarray(o3d.io.read_point_cloud(views[b]).get_center())
                initial = disturbed(true_relative, centroid, 2.0, 2.0, rng)
                if args.model_only:
                    open3d_found.append(open3d_global(views[a], views[b])[0])
                    continue
                runs = {}
                for _ in range(args.repeat):  # every tool once per round, so a slow spell hits them all
                    round_runs = {
                        ("global", "PicoScan"): lambda: picoscan_pair(picoscan, views[a], views[b], work),
                        ("global", "Open3D"): lambda: open3d_global(views[a], views[b]),
                        ("icp", "PicoScan"): lambda: picoscan_pair(picoscan, views[a], views[b], work, initial),
                        ("icp", "Open3D"): lambda: open3d_icp(views[a], views[b], initial),
                        ("global", "PicoScan in-process"): lambda: picoscan_in_process(module, views[a], views[b]),
                        ("icp", "PicoScan in-process"): lambda: picoscan_in_process(module, views[a], views[b],
                                                                                     initial),
                    }
                    if args.baseline:
                        round_runs[("global", "PicoScan before")] = lambda: picoscan_pair(args.baseline, views[a],
                                                                                          views[b], work)
                    for key, run in round_runs.items():
                        found, seconds = run()
                        if key in runs:  # the first round's pose; the fastest round's time
                            seconds = tuple(min(x, y) for x, y in zip(runs[key][1], seconds))
                            found = runs[key][0]
                        runs[key] = (found, seconds)
                open3d_found.append(runs[("global", "Open3D")][0])
                for key, (found, seconds) in runs.items():
                    error = None if found is None else pose_error(true_relative, np.asarray(found), centroid)
                    rows[key][0].append(error)
                    rows[key][1].append(seconds)
                    print("%s view_%d <- view_%d %-6s %-15s %s  %.2f s (CPU %.2f s)" % (part, a, b, key[0], key[1],
                          "refused" if error is None else "%.4f deg %.4f mm" % error, *seconds), file=sys.stderr)
            for kind, label in (("global", "global, no guess"), ("icp", "ICP from 2 deg / 2 mm off")):
                for tool in [t for t in tools if (kind, t) in rows and rows[(kind, t)][0]]:
                    registration_table.append(summary("%s, %s: %s" % (part, label, tool), *rows[(kind, tool)]))
            if args.no_model:
                continue
            truth_part = TruePart(os.path.join(directory, "truth.stl"))
            centroids = [np.asarray(o3d.io.read_point_cloud(v).get_center()) for v in views]
            for name, run in (("PicoScan stitch + mesh", picoscan_pipeline(module, [views])),
                              ("Open3D pose graph + Poisson", open3d_model(views, open3d_found))):
                placed = "%d / %d" % (sum(p is not None for p in run.poses), right_views(truth, run.poses, centroids))
                model_table.append(pipeline_row("%s: %s" % (part, name), run, model_figures(run, truth_part), placed))
                print(model_table[-1], file=sys.stderr)
    if registration_table:  # none with --model-only
        print("| registration | pairs right / wrong / refused | rotation error median / max (deg) | "
              "shift error median / max (mm) | median time per pair, wall / CPU (s) |")
        print("|---|---|---|---|---|")
        print("\n".join(registration_table) + "\n")
    if model_table:
        print_model_table(model_table)


if __name__ == "__main__":
    main()
