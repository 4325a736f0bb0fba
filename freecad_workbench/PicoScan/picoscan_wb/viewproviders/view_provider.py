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

    def claimChildren(self):
        source = getattr(self.Object, "Source", None)
        return [source] if source is not None else []

    def __getstate__(self):
        return {"icon": self.icon}

    def __setstate__(self, state):
        self.icon = state.get("icon", "picoscan_scan")
