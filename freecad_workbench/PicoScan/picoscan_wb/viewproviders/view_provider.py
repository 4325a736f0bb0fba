"""View provider of the PicoScan objects: the default display of their Points/Mesh with an icon."""
from picoscan_wb import icon_path


class ViewProvider:
    def __init__(self, vobj, icon):
        vobj.Proxy = self
        self.icon = icon

    def attach(self, vobj):
        self.Object = vobj.Object

    def getIcon(self):
        return icon_path(self.icon)

    def getDisplayModes(self, vobj):
        """FreeCAD's own modes, and "Shaded" for a ScanView or Stitch of a document saved before they
        were drawn lit: FreeCAD builds that mode when it attaches the view provider, only if the object
        has its Normal property by then, and such an object gets it later (in onDocumentRestored)."""
        from picoscan_wb.objects import is_scan_view, is_stitch

        obj = vobj.Object
        return ["Shaded"] if (is_scan_view(obj) or is_stitch(obj)) and not hasattr(obj, "Normal") else []

    def claimChildren(self):
        source = getattr(self.Object, "Source", None)
        return [source] if source is not None else []

    def __getstate__(self):
        return {"icon": self.icon}

    def __setstate__(self, state):
        self.icon = state.get("icon", "picoscan_scan")


class DeviationViewProvider(ViewProvider):
    """A Deviation map's: its points in their colours, and the colour legend in the 3D view
    (deviation_legend) while the map is shown, following every recompute."""

    def __init__(self, vobj):
        super().__init__(vobj, "picoscan_deviation")

    def attach(self, vobj):
        from picoscan_wb.viewproviders.deviation_legend import Legend

        super().attach(vobj)
        self.legend = Legend(vobj.RootNode)
        self.show_legend()

    def show_legend(self):
        legend = getattr(self, "legend", None)
        if legend is None:
            return
        obj = self.Object
        tolerance = float(getattr(getattr(obj, "Tolerance", None), "Value", 0) or 0)
        range_mm = float(getattr(getattr(obj, "ColourRange", None), "Value", 0) or 0)
        legend.update(tolerance, range_mm, obj.ViewObject.Visibility)

    def updateData(self, obj, prop):
        if prop == "Summary":  # set last by every recompute: the tolerance and range are the map's
            self.show_legend()

    def onChanged(self, vobj, prop):
        if prop == "Visibility":
            self.show_legend()


class ShadedPointsViewProvider(ViewProvider):
    """A cloud with a normal per point (a Stitch's Normal property, a Points::PropertyNormalList)
    drawn lit by its normals: FreeCAD's own "Shaded" mode of Points, as for a cloud read with normals.
    Faces turned towards the light are bright, those turned away dark, so the shape reads without
    meshing. FreeCAD builds that mode when the view provider's proxy is set (and when a document is
    reopened) if the object has the Normal property by then: the object's proxy adds it first."""

    def getDefaultDisplayMode(self):
        return "Shaded"
