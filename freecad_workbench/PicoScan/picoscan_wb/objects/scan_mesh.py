"""ScanMesh: a scan -> Mesh. Grid meshing joins neighbouring camera pixels of one ScanView without
bridging depth jumps; Poisson (watertight) and advancing front (open surfaces) mesh the cloud of a
ScanView or a Stitch with the core's CGAL meshing."""
import os
import tempfile

import FreeCAD
import Mesh

import picoscan
from picoscan_wb.objects import DocumentObjectProxy, add_or_remove, brief_input_errors, cloud_of, is_scan_view, is_stitch, millimetres
from picoscan_wb.progress import run_in_background

TYPE = "PicoScan::ScanMesh"
METHODS = ["Grid", "Poisson", "AdvancingFront"]
FILLS = ["Poisson", "Table", "Open"]  # picoscan.MeshFill: what closes the side the scan never saw


def freecad_mesh(mesh):
    """FreeCAD Mesh from a picoscan.Mesh, through a binary PLY: FreeCAD keeps the core's points and
    triangles as they are (same order, same corners), five times faster than an STL
    (benchmarks/freecad_mesh_handover.py). FreeCAD's STL reader stores every triangle starting
    from its third corner; that alone reversed the polylines of a section (the core's
    cut_mesh_section and Mesh.crossSections orient a loop by the corner order of the first triangle
    they cut, not by the triangles' winding), so a section's direction says nothing here."""
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "mesh.ply")
        picoscan.write_ply(mesh, path)
        return Mesh.Mesh(path)


def core_mesh(mesh, progress=None):
    """picoscan.Mesh from a FreeCAD Mesh (placement applied), through a binary PLY: FreeCAD's points
    and index triangles as they are, six times faster than an STL whose corners the core would merge
    again (benchmarks/freecad_mesh_handover.py). The core's reader reports to `progress` every
    65 536 records and hears Cancel there; FreeCAD's write (0.1 s for 460 k facets) cannot be stopped."""
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "mesh.ply")
        mesh.write(path)
        return picoscan.read_mesh(path, progress)


class ScanMesh(DocumentObjectProxy):
    TYPE = TYPE

    def __init__(self, obj):
        super().__init__(obj)
        obj.addProperty("App::PropertyLink", "Source", "Mesh", "The ScanView or Stitch to mesh")
        obj.addProperty("App::PropertyEnumeration", "Method", "Mesh", "Meshing method")
        obj.addProperty("App::PropertyInteger", "PixelStep", "Grid", "Join every n-th pixel (n*n fewer triangles)")
        obj.addProperty("App::PropertyFloat", "MaxEdgeFactor", "Grid", "Longest edge in pixel footprints; longer ones are depth jumps")
        obj.addProperty("App::PropertyLength", "SampleSpacing", "Surface", "The cloud is thinned to about this spacing first; 0 keeps all")
        obj.addProperty("App::PropertyLength", "MaxHoleDiameter", "Surface", "Holes up to this size are filled")
        obj.addProperty("App::PropertyInteger", "TargetFaces", "Surface", "Simplify to about this many faces; 0 keeps all")
        obj.addProperty("App::PropertyString", "Check", "Result", "Facets, open edges, closed or not", 1)
        self.add_fill(obj)
        obj.Method = METHODS
        obj.Method = "Grid"
        obj.PixelStep = 2
        obj.MaxEdgeFactor = 8.0
        defaults = picoscan.MeshOptions()
        obj.SampleSpacing = defaults.sample_spacing_mm
        obj.MaxHoleDiameter = defaults.max_hole_diameter_mm
        obj.TargetFaces = defaults.target_faces

    @staticmethod
    def add_fill(obj):
        obj.addProperty("App::PropertyEnumeration", "Fill", "Surface",
                        "Poisson: the unseen side closed by Poisson's guess, a flat cap at the table, or left "
                        "Open (nothing invented; one view meshes in seconds)")
        obj.Fill = FILLS
        obj.Fill = "Poisson"

    def onDocumentRestored(self, obj):
        super().onDocumentRestored(obj)
        if not hasattr(obj, "Fill"):  # documents saved before the property existed
            self.add_fill(obj)

    @brief_input_errors
    def execute(self, obj):
        if obj.Method == "Grid":
            mesh, obj.Check = self.grid(obj)
        else:
            mesh, obj.Check = self.surface(obj)
        mesh.Placement = obj.Source.Placement  # the mesh goes where its scan was placed (part frame, best fit)
        obj.Mesh = mesh

    def grid(self, obj):
        if not is_scan_view(obj.Source):
            raise picoscan.Error("%s: Grid meshing needs a single ScanView; mesh a Stitch with Poisson or "
                                 "AdvancingFront" % obj.Label)
        if obj.PixelStep < 1:
            raise picoscan.Error("%s: PixelStep must be at least 1" % obj.Label)
        view, calibration = obj.Source.Proxy.scan_view(obj.Source)
        options = picoscan.MeshOptions()
        options.method = picoscan.MeshMethod.Grid
        options.grid.pixel_step = obj.PixelStep
        options.grid.max_edge_factor = obj.MaxEdgeFactor
        # Off the GUI thread like the other methods: a full-resolution view has millions of facets.
        result = run_in_background("Meshing " + obj.Label, lambda progress: freecad_mesh(
            picoscan.mesh_view(view, options, progress)))
        return result, "%d facets, %d points, %s" % (result.CountFacets, result.CountPoints,
                                                      "closed" if result.isSolid() else "open (a single view is a surface)")

    def surface(self, obj):
        if not (is_scan_view(obj.Source) or is_stitch(obj.Source)):
            raise picoscan.Error("%s: Source must be a ScanView or a Stitch" % obj.Label)
        options = picoscan.MeshOptions()
        options.method = getattr(picoscan.MeshMethod, obj.Method)
        options.sample_spacing_mm = millimetres(obj.SampleSpacing)
        options.max_hole_diameter_mm = millimetres(obj.MaxHoleDiameter)
        options.target_faces = obj.TargetFaces
        options.fill = getattr(picoscan.MeshFill, obj.Fill)
        cloud = cloud_of(obj.Source)
        mesh = run_in_background("Meshing " + obj.Label, lambda progress: picoscan.mesh_points(cloud, options, progress))
        return freecad_mesh(mesh), picoscan.check_mesh(mesh).summary()


def create(doc, source, method="Grid", pixel_step=2, name="ScanMesh", sample_spacing_mm=None, target_faces=None,
           max_hole_diameter_mm=None, fill=None):
    """Meshes first and adds the object only when that worked (bad input leaves `doc` unchanged)."""
    if not (is_scan_view(source) or is_stitch(source)):
        raise picoscan.Error("%s: select a ScanView or a Stitch to mesh" % getattr(source, "Label", "selection"))
    if method not in METHODS:
        raise picoscan.Error("%s: meshing method must be one of %s" % (method, ", ".join(METHODS)))
    if fill is not None and fill not in FILLS:
        raise picoscan.Error("%s: fill must be one of %s" % (fill, ", ".join(FILLS)))

    def setup(obj):
        ScanMesh(obj)
        obj.Source = source
        obj.Method = method
        obj.PixelStep = pixel_step
        if sample_spacing_mm is not None:
            obj.SampleSpacing = sample_spacing_mm
        if target_faces is not None:
            obj.TargetFaces = target_faces
        if max_hole_diameter_mm is not None:
            obj.MaxHoleDiameter = max_hole_diameter_mm
        if fill is not None:
            obj.Fill = fill
        if FreeCAD.GuiUp:
            from picoscan_wb.viewproviders.view_provider import ViewProvider
            ViewProvider(obj.ViewObject, "picoscan_mesh")

    obj = add_or_remove(doc, "Mesh::FeaturePython", name, setup)
    if FreeCAD.GuiUp:
        source.ViewObject.Visibility = False
    return obj
