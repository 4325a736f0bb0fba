"""Fit at picked point task panel: the region (the face grown from the picked point, a ball or a box
around it, or a lasso drawn in the 3D view), the kind, the scan's noise, a constraint to a fitted
feature and snapping to nominal sizes are set before anything is computed. The region is shown
in the 3D view while the fields change; the fit runs on a worker thread (the core's fit_at_point
and fit_in_lasso recipes) and adds one Part primitive, in one undo step."""
import FreeCAD
import FreeCADGui
from PySide import QtCore, QtGui

import picoscan
from picoscan_wb.commands.base import run_guarded
from picoscan_wb.operations import region_fit
from picoscan_wb.operations.placement import placed_points
from picoscan_wb.progress import run_in_background

REGIONS = (("Face grown from the point", "grown"), ("Ball around the point", "ball"),
           ("Box around the point", "box"), ("Lasso drawn in the 3D view", "lasso"))
KINDS = (("Automatic (the simplest that fits)", None), ("Plane", "plane"), ("Cylinder", "cylinder"),
         ("Sphere", "sphere"), ("Cone", "cone"))
CONSTRAINTS = (("None", None), ("Parallel", "parallel"), ("Perpendicular", "perpendicular"), ("Coaxial", "coaxial"))
FEATURE_TYPES = ("Part::Plane", "Part::Cylinder", "Part::Cone", "Part::Sphere")


def length_box(value, maximum, special=None, tip=""):
    box = QtGui.QDoubleSpinBox()
    box.setRange(0, maximum)
    box.setDecimals(3)
    box.setSuffix(" mm")
    box.setValue(value)
    if special:
        box.setSpecialValueText(special)
    box.setToolTip(tip)
    return box


def document_to_screen(view):
    """4 x 4 map (rows) from document coordinates to the 3D view's pixels (x right, y up, as Coin's
    mouse events give them), from the camera's view volume."""
    import numpy

    viewer = view.getViewer()
    size = viewer.getSoRenderManager().getViewportRegion().getViewportSizePixels().getValue()
    width, height = float(size[0]), float(size[1])
    volume = view.getCameraNode().getViewVolume(width / height)
    # Coin's matrices act on row vectors: ndc = point x M.
    world_to_ndc = numpy.array(volume.getMatrix().getValue(), dtype=float).T
    ndc_to_pixels = numpy.array([[width / 2, 0, 0, width / 2], [0, height / 2, 0, height / 2],
                                 [0, 0, 1, 0], [0, 0, 0, 1]])
    return ndc_to_pixels @ world_to_ndc


class FitRegionTaskPanel:
    """The command that opens this panel keeps it as its `panel` (for tests and macros)."""

    def __init__(self, source, seed):
        self.source = source
        self.seed = tuple(seed)  # document coordinates
        self.cloud = None        # the scan's points, fetched on the first preview or fit
        self.created = None
        self.fit = None
        self.lasso = []          # screen pixels of the lasso's corners
        self.lasso_matrix = None
        self.lasso_callback = None
        self.preview = None
        self.form = QtGui.QWidget()
        self.form.setWindowTitle("PicoScan fit at picked point")
        layout = QtGui.QFormLayout(self.form)
        seed_text = "(%.3f, %.3f, %.3f) mm on %s" % (self.seed + (source.Label,))
        layout.addRow("Picked point", QtGui.QLabel(seed_text))

        self.region = QtGui.QComboBox()
        self.region.addItems([text for text, _ in REGIONS])
        self.region.setToolTip("Which points are fitted: the face under the point up to its edges (grown as the "
                               "plane, sphere, cylinder or cone that fits it, over points within 3 x the scan's "
                               "noise of it; a point on an edge is refused), every point within the radius, a box "
                               "along the document's axes, or the points under a lasso")
        layout.addRow("Region", self.region)
        self.radius = length_box(30.0, 10000, tip="Grown face and ball: points farther from the picked point "
                                                  "are left out")
        layout.addRow("Radius", self.radius)
        self.box = [length_box(5.0, 10000, tip="Half the box's size along the document's %s axis" % axis)
                    for axis in "XYZ"]
        box_row = QtGui.QWidget()
        box_layout = QtGui.QHBoxLayout(box_row)
        box_layout.setContentsMargins(0, 0, 0, 0)
        for spin in self.box:
            box_layout.addWidget(spin)
        layout.addRow("Box half size (X, Y, Z)", box_row)
        self.draw_lasso = QtGui.QPushButton("Draw lasso")
        self.draw_lasso.setCheckable(True)
        self.draw_lasso.setToolTip("Click the lasso's corners in the 3D view; a right click closes it")
        layout.addRow("Lasso", self.draw_lasso)
        self.region_count = QtGui.QLabel("")
        layout.addRow("Points in the region", self.region_count)
        self.show_region = QtGui.QCheckBox("Show the region in the 3D view")
        self.show_region.setChecked(True)
        layout.addRow("", self.show_region)

        self.kind = QtGui.QComboBox()
        self.kind.addItems([text for text, _ in KINDS])
        self.kind.setToolTip("Automatic: for a grown face, the simplest of plane, sphere, cylinder and cone whose "
                             "grown face holds 90 % of the largest one's points; for a ball, box or lasso, the "
                             "simplest whose RMS is within 1.5 x the noise (or 1.1 x the best RMS)")
        layout.addRow("Kind", self.kind)
        self.noise = length_box(0.0, 10, special="from the scan",
                                tip="The scan's noise (sigma). Given, a region no kind fits within 3 x it (two "
                                    "faces at once) is refused; 0: a grown face estimates it from the scan "
                                    "around the point, a ball, box or lasso takes the best fit's RMS")
        layout.addRow("Noise", self.noise)
        self.constraint = QtGui.QComboBox()
        self.constraint.addItems([text for text, _ in CONSTRAINTS])
        self.constraint.setToolTip("Plane: parallel or perpendicular (its normal); cylinder: parallel, "
                                   "perpendicular or coaxial (its axis); cone: parallel or coaxial; sphere: coaxial "
                                   "(its centre on the reference's axis)")
        layout.addRow("Constraint", self.constraint)
        self.reference = QtGui.QComboBox()
        self.reference.setToolTip("The fitted plane, cylinder, cone or sphere the constraint refers to")
        self.references = [o for o in source.Document.Objects if o.TypeId in FEATURE_TYPES]
        for obj in self.references:
            self.reference.addItem(obj.Label)
        layout.addRow("Reference", self.reference)
        self.snap_step = length_box(0.0, 1000, special="no snapping",
                                    tip="A cylinder's or sphere's diameter is set to the nearest multiple of this "
                                        "when it is within the snap tolerance and the refit still fits")
        layout.addRow("Snap diameter to", self.snap_step)
        self.snap_tolerance = length_box(0.05, 100, tip="Largest change of the diameter by snapping")
        layout.addRow("Snap tolerance", self.snap_tolerance)

        self.timer = QtCore.QTimer()
        self.timer.setSingleShot(True)
        self.timer.setInterval(250)
        self.timer.timeout.connect(self.update_preview)
        for signal in (self.region.currentIndexChanged, self.radius.valueChanged, self.show_region.toggled,
                       *(spin.valueChanged for spin in self.box)):
            signal.connect(self.schedule_preview)
        self.region.currentIndexChanged.connect(self.enable_fields)
        self.constraint.currentIndexChanged.connect(self.enable_fields)
        self.draw_lasso.toggled.connect(self.toggle_lasso)
        self.enable_fields()
        self.schedule_preview()

    # ---- what the fields say ----
    def region_kind(self):
        return REGIONS[self.region.currentIndex()][1]

    def set_region(self, kind):
        self.region.setCurrentIndex([k for _, k in REGIONS].index(kind))

    def set_kind(self, kind):
        self.kind.setCurrentIndex([k for _, k in KINDS].index(kind))

    def set_constraint(self, constraint, reference=None):
        self.constraint.setCurrentIndex([c for _, c in CONSTRAINTS].index(constraint))
        if reference is not None:
            self.reference.setCurrentIndex(self.references.index(reference))

    def enable_fields(self, *_):
        region = self.region_kind()
        self.radius.setEnabled(region in ("grown", "ball"))
        for spin in self.box:
            spin.setEnabled(region == "box")
        self.draw_lasso.setEnabled(region == "lasso")
        self.reference.setEnabled(CONSTRAINTS[self.constraint.currentIndex()][1] is not None)

    def options(self):
        """picoscan.PickedFitOptions from the fields (the core checks their ranges)."""
        constraint = CONSTRAINTS[self.constraint.currentIndex()][1]
        reference = None
        if constraint:
            if not self.references:
                raise picoscan.Error("Reference: a %s constraint needs a fitted plane, cylinder, cone or sphere in "
                                     "the document" % constraint)
            reference = self.references[self.reference.currentIndex()]
        region = self.region_kind()
        return region_fit.picked_options(
            region="grown" if region == "lasso" else region, radius_mm=self.radius.value(),
            box_half_size_mm=[spin.value() for spin in self.box], placement=self.source.Placement,
            kind=KINDS[self.kind.currentIndex()][1], noise_mm=self.noise.value(), constraint=constraint,
            reference=reference, snap_step_mm=self.snap_step.value(), snap_tolerance_mm=self.snap_tolerance.value())

    def points(self):
        if self.cloud is None:
            from picoscan_wb.objects import cloud_of

            self.cloud = cloud_of(self.source)
        return self.cloud

    # ---- the lasso ----
    def toggle_lasso(self, drawing):
        view = self.view()
        if view is None:
            return
        from pivy import coin

        if drawing and self.lasso_callback is None:
            self.lasso = []
            self.lasso_matrix = document_to_screen(view)
            self.lasso_callback = view.addEventCallbackPivy(coin.SoMouseButtonEvent.getClassTypeId(), self.on_click)
        elif not drawing and self.lasso_callback is not None:
            view.removeEventCallbackPivy(coin.SoMouseButtonEvent.getClassTypeId(), self.lasso_callback)
            self.lasso_callback = None
            self.schedule_preview()

    def on_click(self, callback_node):
        from pivy import coin

        event = callback_node.getEvent()
        callback_node.setHandled()  # while drawing, clicks are the lasso's, not selection or navigation
        if event.getState() != coin.SoButtonEvent.DOWN:
            return
        if event.getButton() == coin.SoMouseButtonEvent.BUTTON1:
            self.lasso.append(tuple(float(v) for v in event.getPosition().getValue()))
            self.schedule_preview()
        elif event.getButton() == coin.SoMouseButtonEvent.BUTTON2:
            self.draw_lasso.setChecked(False)  # closes the lasso

    # ---- the preview ----
    def view(self):
        view = FreeCADGui.ActiveDocument.ActiveView if FreeCADGui.ActiveDocument else None
        return view if view is not None and hasattr(view, "getSceneGraph") else None

    def schedule_preview(self, *_):
        self.timer.start()

    def selected_region(self):
        """Indices of the region's points (the same selection the fit will use), selected off the GUI
        thread (a large cloud takes a while; the progress dialog shows only after 0.3 s)."""
        cloud = self.points()
        options = self.options()
        if self.region_kind() == "lasso":
            if len(self.lasso) < 3:
                return []
            import numpy

            matrix = numpy.array(self.source.Placement.toMatrix().A).reshape(4, 4)
            screen, polygon = [tuple(r) for r in self.lasso_matrix @ matrix], list(self.lasso)
            select = lambda progress: picoscan.select_in_polygon(cloud, screen, polygon)  # noqa: E731
        elif self.region_kind() == "grown":  # the face the fit will take: grown as the kind that fits it
            seed, placement = self.seed, self.source.Placement
            select = lambda progress: region_fit.grown_face(cloud, seed, options, placement, progress).region  # noqa: E731
        else:
            local = tuple(self.source.Placement.inverse().multVec(FreeCAD.Vector(*self.seed)))
            select = lambda progress: picoscan.select_region(cloud, local, options.selection, progress)  # noqa: E731
        return run_in_background("Selecting the region", select)

    def update_preview(self):
        try:
            region = self.selected_region()
        except (picoscan.Error, ValueError) as error:  # a field out of range: said in the panel, not a box
            self.region_count.setText(str(error))
            self.remove_preview()
            return
        self.region_count.setText("%d" % len(region))
        self.remove_preview()
        view = self.view()
        if view is None or not self.show_region.isChecked() or not region:
            return
        from pivy import coin
        import numpy

        points = numpy.asarray(self.points().points)[numpy.asarray(region)]
        if len(points) > 200000:
            points = points[:: len(points) // 200000 + 1]
        points = placed_points(points, self.source.Placement)
        self.preview = coin.SoSeparator()
        material = coin.SoMaterial()
        material.diffuseColor = (1.0, 0.35, 0.1)
        style = coin.SoDrawStyle()
        style.pointSize = 4
        coordinates = coin.SoCoordinate3()
        coordinates.point.setValues(0, len(points), points.tolist())
        for node in (material, style, coordinates, coin.SoPointSet()):
            self.preview.addChild(node)
        self.scene = view.getSceneGraph()
        self.scene.addChild(self.preview)

    def remove_preview(self):
        if self.preview is not None:
            self.scene.removeChild(self.preview)
            self.preview = None

    # ---- OK and Cancel ----
    def compute(self):
        self.timer.stop()  # no preview starts while the fit runs
        options = self.options()
        cloud = self.points()
        placement = self.source.Placement
        if self.region_kind() == "lasso":
            if len(self.lasso) < 3:
                raise picoscan.Error("Lasso: draw at least 3 corners in the 3D view (a right click closes it)")
            matrix, polygon = self.lasso_matrix, list(self.lasso)
            work = lambda progress: region_fit.fit_in_lasso(cloud, matrix, polygon, options, placement, progress)
        else:
            seed = self.seed
            work = lambda progress: region_fit.fit_at_point(cloud, seed, options, placement, progress)
        picked = run_in_background("Fitting the picked region", work)
        self.fit = picked.fit
        obj = region_fit.add_fitted(self.source.Document, cloud, picked.fit, placement)
        FreeCAD.Console.PrintMessage("%s: %s\n" % (obj.Label, picked.fit.report))
        return obj

    def finish(self):
        if self.lasso_callback is not None:
            self.draw_lasso.setChecked(False)
        self.timer.stop()  # after the lasso, which asks for a preview when it closes
        self.remove_preview()
        FreeCADGui.Control.closeDialog()

    def accept(self):
        self.created = run_guarded("Fit at picked point", self.compute)
        if self.created is None:
            return False  # the message is shown; the panel stays open for corrections
        self.finish()
        return True

    def reject(self):
        self.finish()
        return True
