"""Fuse view files: posed PicoScan view PLYs (each holding its pose, as MeshLab's 'PicoScan: Save
Views for Project' writes them) merged and meshed by the core's fuse_view_files, which reads them
one at a time: 16-32 full-resolution views never need to be in memory together, as they would
be as ScanViews of a document. The result is a Mesh feature; the views stay files."""
import FreeCAD

import picoscan
from picoscan_wb.objects.scan_mesh import FILLS, freecad_mesh
from picoscan_wb.progress import run_in_background

METHODS = ("Poisson", "AdvancingFront")


def fuse_view_files(doc, paths, method="Poisson", fill="Poisson", sample_spacing_mm=None, name="FusedViews"):
    """Fuses the view files and adds the mesh as a Mesh feature (its Label says how it was filled);
    returns (the feature, the core's FuseResult). Bad input raises picoscan.Error naming the file or
    the parameter and leaves `doc` unchanged."""
    paths = [str(path) for path in paths]
    if method not in METHODS:
        raise picoscan.Error("Fuse view files: method must be one of %s, not %r" % (", ".join(METHODS), method))
    if fill not in FILLS:
        raise picoscan.Error("Fuse view files: fill must be one of %s, not %r" % (", ".join(FILLS), fill))
    options = picoscan.MeshOptions()
    options.method = getattr(picoscan.MeshMethod, method)
    options.fill = getattr(picoscan.MeshFill, fill)
    if sample_spacing_mm is not None:
        options.sample_spacing_mm = sample_spacing_mm
    fused = run_in_background("Fusing %d view files" % len(paths),
                              lambda progress: picoscan.fuse_view_files(paths, options, progress))
    obj = doc.addObject("Mesh::Feature", name)
    obj.Mesh = freecad_mesh(fused.mesh)
    FreeCAD.Console.PrintMessage("%s: %d view files, %d points fused: %s\n" % (
        obj.Label, len(paths), len(fused.merged), fused.check.summary()))
    return obj, fused
