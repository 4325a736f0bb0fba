"""Commands that turn scans into CAD: Mesh, Make solid, Fit primitives, Cross-section, Show rig,
Encoding view."""
import os
import tempfile

import FreeCAD
import FreeCADGui

import picoscan

from picoscan_wb.commands.base import Command, captures_on_disk, selected_meshes, selected_scan_views, show_message
from picoscan_wb.objects import cloud_of, deviation_map, is_scan_view, is_stitch
from picoscan_wb.operations import encoding, primitives, rig, section, solid


def output_folder(doc, name):
    """Beside the saved document, else in a temporary folder."""
    base = os.path.dirname(doc.FileName) if doc.FileName else tempfile.mkdtemp(prefix="picoscan_")
    folder = os.path.join(base, name)
    os.makedirs(folder, exist_ok=True)
    return folder


def open_image(path):
    import ImageGui

    ImageGui.open(path)


def selected_clouds():
    return [obj for obj in FreeCADGui.Selection.getSelection() if is_scan_view(obj) or is_stitch(obj)]


def selected_placements():
    """The selected groups that hold ScanViews, each one placement of the part, as
    (views, placement of each view from 1); empty when no such group is selected."""
    groups = [obj for obj in FreeCADGui.Selection.getSelection() if obj.isDerivedFrom("App::DocumentObjectGroup")]
    views, numbers = [], []
    for number, group in enumerate([g for g in groups if any(is_scan_view(o) for o in g.Group)], start=1):
        members = [o for o in group.Group if is_scan_view(o)]
        views += members
        numbers += [number] * len(members)
    return views, numbers


class StitchCommand(Command):
    icon = "picoscan_stitch"
    menu = "Stitch views"
    tooltip = ("Register the selected ScanViews into one model and merge their points; a panel shows the views and "
               "sets the mode (automatic, features, turntable round, known turntable axis) first. For a part scanned "
               "in several placements, put each placement's ScanViews in a group and select the groups, in order")

    def IsActive(self):
        return len(selected_scan_views()) >= 2 or len(selected_placements()[0]) >= 2

    def Activated(self):
        from picoscan_wb.taskpanels.stitch import StitchTaskPanel

        views, placements = selected_placements()
        if views and selected_scan_views():
            show_message("PicoScan: " + self.menu, "Stitch views: select either ScanViews (one placement) or groups of "
                                                   "ScanViews (one placement each), not both")
            return
        if not views:
            views, placements = selected_scan_views(), []
        self.panel = StitchTaskPanel(views, placements)  # the open panel, for tests and macros
        FreeCADGui.Control.showDialog(self.panel)


class MeshCommand(Command):
    icon = "picoscan_mesh"
    menu = "Mesh"
    tooltip = ("Mesh the selected ScanView (Grid: its pixel grid) or Stitch: Poisson (watertight) or "
               "advancing front (open surfaces)")

    def IsActive(self):
        return bool(selected_clouds())

    def Activated(self):
        from picoscan_wb.taskpanels.mesh import MeshTaskPanel

        self.panel = MeshTaskPanel(selected_clouds()[0])  # the open panel, for tests and macros
        FreeCADGui.Control.showDialog(self.panel)


class MakeSolidCommand(Command):
    icon = "picoscan_solid"
    menu = "Make solid"
    tooltip = "Part solid from the selected mesh when it is closed, manifold and not self-intersecting"

    def IsActive(self):
        return bool(selected_meshes())

    def run(self):
        mesh = selected_meshes()[0]
        return solid.make_solid(mesh.Document, mesh)


class FitPrimitivesCommand(Command):
    icon = "picoscan_primitives"
    menu = "Fit primitives"
    tooltip = "Find planes, cylinders, spheres and cones in the scan (a ScanView or a Stitch) and add them as Part primitives"

    def IsActive(self):
        return bool(selected_clouds())

    def run(self):
        source = selected_clouds()[0]
        group, created = primitives.fit_primitives(source.Document, cloud_of(source), label="Primitives of " + source.Label,
                                                   placement=source.Placement)
        for obj, shape in created:
            FreeCAD.Console.PrintMessage("%s: %s\n" % (obj.Label, shape))
        return group


class FitRegionCommand(Command):
    icon = "picoscan_fit_region"
    menu = "Fit at picked point"
    tooltip = ("Fit a plane, cylinder, sphere or cone to the region around the point picked on a ScanView or "
               "Stitch (the face it is on, a ball, a box or a lasso), with constraints and snapping set in a task panel")

    def IsActive(self):
        return any(is_scan_view(s.Object) or is_stitch(s.Object) for s in FreeCADGui.Selection.getSelectionEx()
                   if s.PickedPoints)

    def Activated(self):
        from picoscan_wb.taskpanels.region_fit import FitRegionTaskPanel

        picked = [s for s in FreeCADGui.Selection.getSelectionEx() if s.PickedPoints
                  and (is_scan_view(s.Object) or is_stitch(s.Object))][0]
        self.panel = FitRegionTaskPanel(picked.Object, picked.PickedPoints[-1])  # the open panel, for tests and macros
        FreeCADGui.Control.showDialog(self.panel)


class CrossSectionCommand(Command):
    icon = "picoscan_section"
    menu = "Cross-section"
    tooltip = ("Cut the selected mesh with a plane across X, Y or Z: a Sketch of fitted, constrained lines and arcs "
               "(and, for a scan, a profile plot)")

    def IsActive(self):
        return bool(selected_meshes())

    def Activated(self):
        from picoscan_wb.taskpanels.section import CrossSectionTaskPanel

        self.panel = CrossSectionTaskPanel(selected_meshes()[0], self.section)  # the open panel, for tests and macros
        FreeCADGui.Control.showDialog(self.panel)

    @staticmethod
    def section(mesh, axis, position_mm, tolerance_mm, band_mm=picoscan.DEFAULT_SECTION_BAND_MM):
        sketch = section.cross_section(mesh.Document, mesh, axis=axis, offset_mm=position_mm, tolerance_mm=tolerance_mm,
                                       band_mm=band_mm)
        source = getattr(mesh, "Source", None)
        if is_scan_view(source):
            path = os.path.join(output_folder(mesh.Document, "sections"), sketch.Name + "_profile.png")
            sketch.ProfilePlot = section.hybrid_vs_binary_plot(source, axis, position_mm, path)
            open_image(sketch.ProfilePlot)
        return sketch


def _has_points(obj):
    return (hasattr(obj, "Points") and obj.Points.CountPoints > 0) or (hasattr(obj, "Mesh") and obj.Mesh.CountPoints > 0)


def _has_surface(obj):
    return (hasattr(obj, "Shape") and not obj.Shape.isNull() and bool(obj.Shape.Faces)) or \
        (hasattr(obj, "Mesh") and obj.Mesh.CountFacets > 0)


class DeviationMapCommand(Command):
    icon = "picoscan_deviation"
    menu = "Deviation map"
    tooltip = ("Colour the scan (selected first) by its signed distance to the model (selected second: any Part shape "
               "or mesh), with the figures and an HTML report; recomputes when the model changes")

    def IsActive(self):
        selection = FreeCADGui.Selection.getSelection()
        return len(selection) == 2 and _has_points(selection[0]) and _has_surface(selection[1])

    def run(self):
        selection = FreeCADGui.Selection.getSelection()
        if len(selection) != 2:
            raise picoscan.Error("Deviation map: select the scan, then the reference model (%d selected)" % len(selection))
        scan, reference = selection
        doc = scan.Document
        report = os.path.join(output_folder(doc, "deviation"), "%s_vs_%s.html" % (scan.Name, reference.Name))
        result = deviation_map.create(doc, scan, reference, report_file=report)
        FreeCAD.Console.PrintMessage("%s: %s\n" % (result.Label, result.Summary))
        open_image(report + ".png")
        return result


class BestFitCommand(Command):
    icon = "picoscan_bestfit"
    menu = "Best fit to model"
    tooltip = ("Move the scan (selected first) onto the model (selected second) by trimmed point-to-plane ICP "
               "from where it is now; the scan's Placement takes the move")

    def IsActive(self):
        return DeviationMapCommand.IsActive(self)

    def run(self):
        from picoscan_wb.operations import alignment

        selection = FreeCADGui.Selection.getSelection()
        if len(selection) != 2:
            raise picoscan.Error("Best fit: select the scan, then the model (%d selected)" % len(selection))
        scan, reference = selection
        result = alignment.best_fit(scan, reference)
        FreeCAD.Console.PrintMessage("%s: best fit in %d steps, rms %.4f mm over %d points\n" % (
            scan.Label, result.iterations, result.rms_mm, result.pairs))
        scan.Document.recompute()
        return result


def selected_features():
    """The selection as (object, sub-element) pairs in the order picked: each picked face or vertex,
    or the whole object when nothing inside it was picked."""
    features = []
    for selection in FreeCADGui.Selection.getSelectionEx():
        names = [name for name in selection.SubElementNames if name]
        features += [(selection.Object, name) for name in names] if names else [(selection.Object, "")]
    return features


def _is_feature(feature):
    obj, sub = feature
    return bool(sub) or getattr(obj, "FitKind", "") in ("Plane", "Sphere")


class DatumAlignCommand(Command):
    icon = "picoscan_datum"
    menu = "Datum alignment (3-2-1)"
    tooltip = ("Put a scan into its part's coordinate system: select the scan, then a primary plane (Z), a secondary "
               "plane (X along their line) and an origin plane or point; add the model's three matching faces to move "
               "the scan onto the model. Select the model's three faces, then the scan's three, to move the model onto "
               "the scan. Axes point into the material.")

    def IsActive(self):
        return len(selected_features()) in (3, 4, 6, 7)

    def run(self):
        from picoscan_wb.operations import datum

        features = selected_features()
        if not _is_feature(features[0]):
            moving, features = features[0][0], features[1:]
        else:
            owners = set(obj.Name for obj, _ in features[:3])
            if len(owners) != 1:
                raise picoscan.Error("Datum alignment: select the object to move first, or three faces of it")
            moving = features[0][0]
        if len(features) not in (3, 6):
            raise picoscan.Error("Datum alignment: select 3 datums (primary, secondary, origin), or 3 on the object to "
                                 "move and then 3 matching ones on the fixed object (%d selected)" % len(features))
        # The primitives fitted on the scan (the Fit primitives group of a fitted datum) travel with it.
        groups = {parent.Name: parent for obj, _ in features[:3] if getattr(obj, "FitKind", "")
                  for parent in obj.InList if parent.TypeId == "App::DocumentObjectGroup"}
        carried = [member for group in groups.values() for member in group.Group if getattr(member, "FitKind", "")]
        frame, fixed, move = datum.align(moving, features[:3], features[3:] or None, carried=carried)
        FreeCAD.Console.PrintMessage("%s: datum frame %s; moved by %s\n" % (moving.Label, datum.frame_report(frame), move))
        moving.Document.recompute()
        return frame


def _fitted(obj):
    return getattr(obj, "FitKind", "") in ("Plane", "Cylinder", "Sphere")


def selected_fitted_features():
    """Fitted features picked, or every fitted feature of a picked group (Fit primitives' result)."""
    features = []
    for obj in FreeCADGui.Selection.getSelection():
        features += [m for m in obj.Group if _fitted(m)] if obj.TypeId == "App::DocumentObjectGroup" else \
            ([obj] if _fitted(obj) else [])
    return features


class MeasurementsCommand(Command):
    icon = "picoscan_measure"
    menu = "Measurements"
    tooltip = ("Distances and angles between the selected fitted features (or all those of a selected Fit primitives "
               "group), with their fit uncertainty, in a table written as CSV")

    def IsActive(self):
        return len(selected_fitted_features()) >= 2

    def run(self):
        from picoscan_wb.objects import measurements

        features = selected_fitted_features()
        doc = features[0].Document
        result = measurements.create(doc, features)
        result.CsvFile = os.path.join(output_folder(doc, "measurements"), result.Name + ".csv")
        doc.recompute()
        FreeCAD.Console.PrintMessage("%s: %d rows, written to %s\n" % (result.Label, len(result.Table), result.CsvFile))
        return result


class PartFrameCommand(Command):
    icon = "picoscan_part_frame"
    menu = "Part frame (Z up)"
    tooltip = ("Place the selected ScanViews and Stitches in their part frame: Z up on the turntable's axis, else on "
               "the base plane they stand on (replaces their Placement)")

    def IsActive(self):
        return bool(selected_clouds())

    def run(self):
        from picoscan_wb.operations import datum

        for obj in selected_clouds():
            frame = datum.place_in_part_frame(obj)
            FreeCAD.Console.PrintMessage("%s: part frame from its %s\n" % (obj.Label, frame.basis))
        FreeCAD.ActiveDocument.recompute()


class ShowRigCommand(Command):
    icon = "picoscan_rig"
    menu = "Show rig"
    tooltip = ("Camera and projector frusta at their calibrated poses: of the selected ScanView's calibration "
               "(while its file is on disk), or of a calibration file chosen when no ScanView is selected")

    def IsActive(self):
        views = selected_scan_views()
        return FreeCAD.ActiveDocument is not None and (not views or os.path.isfile(views[0].CalibrationFile or ""))

    def run(self):
        views = selected_scan_views()
        if views:
            calibration = views[0].CalibrationFile
        else:
            from PySide import QtGui

            calibration, _ = QtGui.QFileDialog.getOpenFileName(FreeCADGui.getMainWindow(), "Calibration of the rig",
                                                               "", "Calibration (*.yml *.yaml *.xml *.json)")
            if not calibration:
                return None
        return rig.show_rig(FreeCAD.ActiveDocument, calibration)


class EncodingViewCommand(Command):
    icon = "picoscan_encoding"
    menu = "Encoding view"
    tooltip = ("False-colour pictures of the selected ScanView's decoded projector codes, modulation and pixel "
               "status, from its capture folder (while that is on disk)")

    def IsActive(self):
        return any(captures_on_disk(view) for view in selected_scan_views())

    def run(self):
        view = [view for view in selected_scan_views() if captures_on_disk(view)][0]
        folder = output_folder(view.Document, view.Name + "_encoding")
        paths = encoding.encoding_images(view.CaptureFolder, folder, view.ManifestFile)
        for path in paths.values():
            open_image(path)
        return paths
