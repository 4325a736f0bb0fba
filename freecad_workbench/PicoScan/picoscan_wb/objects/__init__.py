"""Parametric document objects (FeaturePython). Their results that FreeCAD cannot store (the organised
view of a scan) are kept in memory and recomputed on demand after a document is reopened."""


def proxy_type(obj):
    return getattr(getattr(obj, "Proxy", None), "Type", "")


def is_scan_view(obj):
    return proxy_type(obj) == "PicoScan::ScanView"


def is_scan_mesh(obj):
    return proxy_type(obj) == "PicoScan::ScanMesh"


def has_mesh(obj):
    return obj is not None and hasattr(obj, "Mesh") and obj.Mesh.CountFacets > 0
