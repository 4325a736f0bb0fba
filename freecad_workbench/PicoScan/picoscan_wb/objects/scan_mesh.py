"""ScanMesh: a scan (ScanView) -> Mesh. Grid meshing joins neighbouring camera pixels without
bridging depth jumps; Poisson and advancing front come with the core's mesh stage."""
import os
import tempfile

import FreeCAD
import Mesh

import picoscan
from picoscan_wb.objects import is_scan_view
from picoscan_wb.operations.reconstruct import camera_focal_px

TYPE = "PicoScan::ScanMesh"
METHODS = ["Grid"]


def freecad_mesh(mesh):
    """FreeCAD Mesh from a picoscan.Mesh, through a binary STL (fast for millions of facets)."""
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "mesh.stl")
        picoscan.write_stl(mesh, path)
        return Mesh.Mesh(path)


class ScanMesh:
    def __init__(self, obj):
        obj.Proxy = self
        self.Type = TYPE
        obj.addProperty("App::PropertyLink", "Source", "Mesh", "The ScanView to mesh")
        obj.addProperty("App::PropertyEnumeration", "Method", "Mesh", "Meshing method")
        obj.addProperty("App::PropertyInteger", "PixelStep", "Grid", "Join every n-th pixel (n*n fewer triangles)")
        obj.addProperty("App::PropertyFloat", "MaxEdgeFactor", "Grid", "Longest edge in pixel footprints; longer ones are depth jumps")
        obj.addProperty("App::PropertyString", "Check", "Result", "Facets, open edges, closed or not", 1)
        obj.Method = METHODS
        obj.Method = "Grid"
        obj.PixelStep = 2
        obj.MaxEdgeFactor = 8.0

    def execute(self, obj):
        if not is_scan_view(obj.Source):
            raise picoscan.Error("%s: Source must be a ScanView" % obj.Label)
        if obj.PixelStep < 1:
            raise picoscan.Error("%s: PixelStep must be at least 1" % obj.Label)
        view, calibration = obj.Source.Proxy.scan_view(obj.Source)
        options = picoscan.GridMeshOptions()
        options.pixel_step = obj.PixelStep
        options.max_edge_factor = obj.MaxEdgeFactor
        result = freecad_mesh(picoscan.grid_mesh(view, camera_focal_px(calibration), options))
        obj.Mesh = result
        obj.Check = "%d facets, %d points, %s" % (result.CountFacets, result.CountPoints,
                                                   "closed" if result.isSolid() else "open (a single view is a surface)")

    def onDocumentRestored(self, obj):
        self.Type = TYPE

    def __getstate__(self):
        return {"Type": self.Type}

    def __setstate__(self, state):
        self.Type = state.get("Type", TYPE)


def create(doc, source, method="Grid", pixel_step=2, name="ScanMesh"):
    if not is_scan_view(source):
        raise picoscan.Error("%s: select a ScanView to mesh" % getattr(source, "Label", "selection"))
    obj = doc.addObject("Mesh::FeaturePython", name)
    ScanMesh(obj)
    obj.Source = source
    obj.Method = method
    obj.PixelStep = pixel_step
    if FreeCAD.GuiUp:
        from picoscan_wb.viewproviders.view_provider import ViewProvider
        ViewProvider(obj.ViewObject, "picoscan_mesh")
        source.ViewObject.Visibility = False
    obj.recompute()
    return obj
