"""Parametric document objects (FeaturePython). Their results that FreeCAD cannot store (the organised
view of a scan) are kept in memory and recomputed on demand after a document is reopened."""
import functools
import sys


def input_errors():
    """Errors that come from the user's input or files; anything else is a bug and keeps its traceback."""
    import picoscan

    return (picoscan.Error, OSError, ValueError)


class _BriefErrors:
    """FreeCAD prints a Python traceback for any exception of an object's execute. For bad input the
    user needs the one-line reason: sys.tracebacklimit is 0 from such an error until the recompute
    that met it has ended (FreeCAD formats the error after execute returns)."""

    saved = None
    active = False
    observer_added = False

    def slotRecomputedDocument(self, doc):
        restore_tracebacks()


_brief = _BriefErrors()


def _shorten_tracebacks():
    import FreeCAD

    if not _brief.observer_added:
        FreeCAD.addDocumentObserver(_brief)
        _brief.observer_added = True
    if not _brief.active:
        _brief.saved, _brief.active = getattr(sys, "tracebacklimit", None), True
    sys.tracebacklimit = 0


def restore_tracebacks():
    if _brief.active:
        if _brief.saved is None:
            if hasattr(sys, "tracebacklimit"):
                del sys.tracebacklimit
        else:
            sys.tracebacklimit = _brief.saved
        _brief.active = False


# The core names an option it refuses as a config file would ("decode.min_contrast: must be 0..255");
# in FreeCAD the user set a property, so the message names that instead.
PROPERTY_OF_OPTION = {
    "decode.min_contrast": "MinContrast",
    "decode.min_modulation": "MinModulation",
    "cleaning.max_grazing_deg": "MaxGrazingAngle",
    "mesh.grid.pixel_step": "PixelStep",
    "mesh.grid.max_edge_factor": "MaxEdgeFactor",
    "mesh.sample_spacing_mm": "SampleSpacing",
    "mesh.max_hole_diameter_mm": "MaxHoleDiameter",
    "mesh.target_faces": "TargetFaces",
    "mesh.fill": "Fill",
    "registration.icp_max_distance_mm": "IcpMaxDistance",
    "registration.min_overlap": "MinOverlap",
}


def _naming_the_property(obj, error):
    """The error, with the core's option name replaced by obj's property (and obj's label) when it names one."""
    import picoscan

    option, _, rest = str(error).partition(":")
    prop = PROPERTY_OF_OPTION.get(option)
    if isinstance(error, picoscan.Error) and prop and hasattr(obj, prop):
        return picoscan.Error("%s: %s:%s" % (obj.Label, prop, rest))
    return error


def brief_input_errors(execute):
    """Decorates a proxy's execute: bad input is reported in one line, without a traceback, naming the
    property at fault."""
    @functools.wraps(execute)
    def wrapper(self, obj):
        restore_tracebacks()  # a new computation: real bugs keep their traceback
        try:
            return execute(self, obj)
        except input_errors() as error:
            _shorten_tracebacks()
            named = _naming_the_property(obj, error)
            if named is error:
                raise
            raise named from None
    return wrapper


class DocumentObjectProxy:
    """What every PicoScan proxy shares: its Type, kept across save and reopen."""

    TYPE = ""

    def __init__(self, obj):
        obj.Proxy = self
        self.Type = self.TYPE

    def onDocumentRestored(self, obj):
        self.Type = self.TYPE

    def __getstate__(self):
        return {"Type": self.Type}

    def __setstate__(self, state):
        self.Type = state.get("Type", self.TYPE)


def proxy_type(obj):
    return getattr(getattr(obj, "Proxy", None), "Type", "")


def is_scan_view(obj):
    return proxy_type(obj) == "PicoScan::ScanView"


def is_stitch(obj):
    return proxy_type(obj) == "PicoScan::Stitch"


def is_scan_mesh(obj):
    return proxy_type(obj) == "PicoScan::ScanMesh"


def has_mesh(obj):
    return obj is not None and hasattr(obj, "Mesh") and obj.Mesh.CountFacets > 0


def cloud_of(obj):
    """picoscan.PointCloud (with normals) of a ScanView or a Stitch."""
    import picoscan

    if is_scan_view(obj):
        return picoscan.to_point_cloud(obj.Proxy.scan_view(obj)[0])
    if is_stitch(obj):
        return obj.Proxy.merged_cloud(obj)
    raise picoscan.Error("%s: not a ScanView or a Stitch" % getattr(obj, "Label", obj))


def recompute_now(obj):
    """Recomputes obj alone and, when that worked, clears its Touched mark as the document's recompute
    does (obj.recompute() leaves it: the tree would show a fresh object as needing a recompute).
    Returns whether it worked."""
    if obj.recompute() and obj.isValid():
        obj.purgeTouched()
        return True
    return False


def add_or_remove(doc, type_name, name, setup):
    """The one way PicoScan adds a computed object: add it, let setup(obj) set its proxy and
    properties, recompute it, and remove it again when that failed, so bad input leaves the
    document as it was. Raises picoscan.Error with the object's error."""
    import picoscan

    obj = doc.addObject(type_name, name)
    try:
        setup(obj)
        recompute_now(obj)
        restore_tracebacks()
        if not obj.isValid():
            raise picoscan.Error(obj.getStatusString())
    except Exception:
        doc.removeObject(obj.Name)
        raise
    return obj


def millimetres(value):
    """A length property's value in mm (documents saved before lengths had units hold plain floats)."""
    return float(getattr(value, "Value", value))
