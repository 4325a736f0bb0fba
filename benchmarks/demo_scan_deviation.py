"""How far a simulated scan of the demo part lies from the true part: the noise floor of the
deviation map that docs/freecad.md gives for the rebuilt body. The core's turntable session
(simulate_turntable_scan, camera noise sigma = 1 DN), its first VIEWS views moved into the part's
frame by their true poses, measured against the true part.

    PYTHONPATH=build/freecad_workbench/PicoScan /usr/bin/python3 benchmarks/demo_scan_deviation.py VIEWS SHIFTS
"""
import sys
import time

import numpy

import picoscan

views_wanted = int(sys.argv[1]) if len(sys.argv) > 1 else 3
shifts = int(sys.argv[2]) if len(sys.argv) > 2 else 16
options = picoscan.TurntableScanOptions()
plan = options.plan
plan.top_view = False
plan.turntable_views = 8
options.plan = plan
patterns = options.patterns
patterns.shifts = shifts
options.patterns = patterns
part = picoscan.mechanical_part()
collected = []
started = time.monotonic()


def on_view(simulated):
    points = numpy.asarray(picoscan.to_point_cloud(simulated.view).points, dtype=numpy.float64)
    to_part = numpy.linalg.inv(numpy.asarray(simulated.part_to_camera))
    collected.append(points @ to_part[:3, :3].T + to_part[:3, 3])
    print("%s: %d points, %.1f s" % (simulated.name, len(points), time.monotonic() - started), flush=True)


try:  # stopped by its progress after the views wanted
    picoscan.simulate_turntable_scan(part, picoscan.seed_rig_calibration(), options, on_view,
                                     lambda fraction, stage: len(collected) < views_wanted)
except picoscan.Error:
    pass
deviation = picoscan.DeviationOptions()
deviation.max_distance_mm = 1.0
result = picoscan.measure_deviation(numpy.concatenate(collected).astype(numpy.float32), part, deviation)
s = result.statistics
print("%d views, %d phase shifts, against the true part: %d points (%d ignored), mean %.4f mm, mean |d| %.4f mm, "
      "sigma %.4f mm, p95 |d| %.4f mm, max |d| %.4f mm, %.1f %% within 0.05 mm" % (
          len(collected), shifts, s.count, s.ignored, s.mean_mm, s.mean_abs_mm, s.sigma_mm, s.p95_abs_mm, s.max_abs_mm,
          100 * s.within_tolerance))
distances = numpy.abs(numpy.asarray(result.distances_mm))
distances = distances[numpy.isfinite(distances)]
print("|d| percentiles 50/90/99: %.4f / %.4f / %.4f mm; robust sigma (median |d| / 0.6745) %.4f mm" % (
    *numpy.percentile(distances, (50, 90, 99)), numpy.median(distances) / 0.6745))
