"""Side by side: the Cross-section's 17 cuts (the section and its Band) as the FreeCAD host made
them until 2026-11-24 (a Python loop of picoscan.cut_mesh, each welding the mesh's vertices
again) and as the core makes them now (picoscan.cut_mesh_section: one weld, 17 cuts). Both on the
same mesh, alternating, in one process; prints the median of each and checks that both give the
same points.

    PYTHONPATH=build/freecad_workbench/PicoScan python3 benchmarks/section_band_cuts.py [FACETS]
"""
import statistics
import sys
import time

import numpy

import picoscan


def sphere(facets):
    """A closed UV sphere of radius 20 mm with about `facets` triangles (vertices repeated per
    triangle, as FreeCAD's meshes come to the core)."""
    rows = max(8, int((facets / 4) ** 0.5))
    columns = 2 * rows
    theta = numpy.linspace(0, numpy.pi, rows + 1)
    phi = numpy.linspace(0, 2 * numpy.pi, columns, endpoint=False)
    grid = numpy.stack([20 * numpy.sin(theta)[:, None] * numpy.cos(phi), 20 * numpy.sin(theta)[:, None] * numpy.sin(phi),
                        20 * numpy.cos(theta)[:, None] + 0 * phi], axis=-1).reshape(-1, 3)
    a = (numpy.arange(rows)[:, None] * columns + numpy.arange(columns)).ravel()
    b = (numpy.arange(rows)[:, None] * columns + (numpy.arange(columns) + 1) % columns).ravel()
    faces = numpy.concatenate([numpy.stack([a, b, b + columns], 1), numpy.stack([a, b + columns, a + columns], 1)])
    mesh = picoscan.Mesh()
    mesh.vertices = grid[faces.ravel()].astype(numpy.float32)
    mesh.faces = numpy.arange(3 * len(faces), dtype=numpy.int32).reshape(-1, 3)
    return mesh


def host_loop(mesh, band):
    """The former operations/section.py: one cut_mesh per height."""
    section = picoscan.cut_mesh(mesh, (0, 0, 3), (1, 0, 0), (0, 1, 0))
    cuts = [picoscan.ParallelCut(offset, line.points) for offset in picoscan.section_band_offsets(band)
            for line in picoscan.cut_mesh(mesh, (0, 0, 3 + offset), (1, 0, 0), (0, 1, 0))]
    return section, cuts


def core_call(mesh, band):
    cut = picoscan.cut_mesh_section(mesh, (0, 0, 3), (1, 0, 0), (0, 1, 0), band)
    return cut.polylines, cut.parallel_cuts


def main():
    facets = int(sys.argv[1]) if len(sys.argv) > 1 else 200000
    mesh = sphere(facets)
    band = picoscan.DEFAULT_SECTION_BAND_MM
    a, b = host_loop(mesh, band), core_call(mesh, band)
    assert len(a[1]) == len(b[1]) and all(numpy.array_equal(p.points, q.points) and p.offset_mm == q.offset_mm
                                          for p, q in zip(a[1], b[1]))
    times = {host_loop: [], core_call: []}
    for _ in range(5):
        for way in (host_loop, core_call):
            start = time.perf_counter()
            way(mesh, band)
            times[way].append(time.perf_counter() - start)
    print("%d facets, %d vertices, 17 cuts: host loop of cut_mesh %.3f s, cut_mesh_section %.3f s (medians of 5)" % (
        len(mesh.faces), len(mesh.vertices), statistics.median(times[host_loop]), statistics.median(times[core_call])))


if __name__ == "__main__":
    main()
