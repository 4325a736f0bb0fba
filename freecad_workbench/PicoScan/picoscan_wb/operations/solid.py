"""Mesh -> Part solid. The core (`picoscan.planar_face_model`) checks that the mesh bounds a solid,
merges the facets that lie on one plane (within the scan's noise) into one planar face, keeps
the rest as triangles (and turns back into triangles the facets where a merged face's boundary
would touch or cross itself, leave its plane or nest wrongly: `model.refused_merges` says where),
makes a hole or boss between two planar faces one cylindrical face bounded by circles when its
facets lie on a cylinder square to both and their normals face away from its axis all round (a
prism's flat sides, its corners on the circle, keep one normal each and stay planar faces), or one conical face when they lie on a cone about such an
axis (a countersink, a chamfered boss; `model.cylinder_notes` says which were near one and why
they were not made), simplifies the other curved regions into fewer, larger triangles (every mesh vertex within
`simplify_mm`, by default 4 x the noise, of them; the volume kept within 0.05 %; the summary in
SolidReport says how many and how far: FreeCAD draws a solid in a time that grows with its faces),
and writes the B-rep in OpenCASCADE's BREP format (`picoscan.write_brep`), each face with its
own facets as its triangulation and each edge with its line on each face's plane; FreeCAD reads
it back and draws those triangles instead of meshing every face again (docs/freecad.md has the
figures). No sewing: the time grows linearly
with the facets. The solid's volume is checked against the mesh's, and OpenCASCADE's own
validity check (BRepCheck, the slowest part by far) runs when the solid has up to CHECK_FACES
faces; both run in another process (brep_check.py), then this one reads the B-rep."""
import os
import tempfile
import time

import Part

import picoscan
from picoscan_wb.objects.scan_mesh import core_mesh
from picoscan_wb.operations import brep_check
from picoscan_wb.progress import cancel_point, run_freecad_process, run_in_background, run_on_gui_thread

MAX_FACETS = 2000000   # beyond this, Fit primitives or a coarser mesh
CHECK_FACES = 20000    # up to here OpenCASCADE's BRepCheck confirms the solid too
VOLUME_TOLERANCE = 1e-3


def face_options(merge_planes=True, noise_mm=0.0, simplify_mm=0.0, cylinders=True):
    options = picoscan.PlanarFaceOptions()
    options.merge = merge_planes
    options.noise_mm = noise_mm
    options.simplify_mm = simplify_mm
    options.cylinders = cylinders
    return options


def solid_with_model(mesh, label="mesh", merge_planes=True, noise_mm=0.0, progress=None, check_valid=None):
    """(Part.Solid, picoscan.PlanarFaceModel, note) of a closed FreeCAD mesh. Raises picoscan.Error
    saying why not. check_valid: run OpenCASCADE's isValid() (default: up to CHECK_FACES faces).
    When the merged planar faces move the volume beyond the tolerance (regions of a coarse, curved
    mesh taken for planes) or make a solid OpenCASCADE finds invalid, the solid is made of the
    mesh's own triangles instead, and the note says so. Cylindrical faces (holes, bosses) are
    given up first (and conical ones with them): when the solid with them is refused, it is made again
    without them."""
    notes, merge, cylinders = [], merge_planes, merge_planes
    while True:
        try:
            shape, model = _solid_with_model(mesh, label, merge, cylinders, noise_mm, progress, check_valid)
            return shape, model, "; ".join(notes)
        except _MergedFacesRefused as refusal:
            if not merge:
                raise picoscan.Error(str(refusal)) from None
            if refusal.had_cylinders:
                notes.append("cylindrical faces not made: %s" % refusal)
                cylinders = False
            else:
                notes.append("planar faces not merged: %s" % refusal)
                merge = cylinders = False


class _MergedFacesRefused(Exception):
    """The solid of the merged faces is wrong; one of the mesh's own triangles may still be right."""

    def __init__(self, message, had_cylinders):
        super().__init__(message)
        self.had_cylinders = had_cylinders


def _has_curved_faces(model):
    return model.cylinder_faces + model.cone_faces > 0


def _solid_with_model(mesh, label, merge_planes, cylinders, noise_mm, progress, check_valid):
    if mesh.CountFacets == 0:
        raise picoscan.Error("%s: the mesh is empty" % label)
    if mesh.CountFacets > MAX_FACETS:
        raise picoscan.Error("%s: %d facets, more than %d; use a coarser mesh or Fit primitives" % (
            label, mesh.CountFacets, MAX_FACETS))
    try:
        # Through a file, which releases the GIL (mesh.Topology builds Python objects holding it).
        model = picoscan.planar_face_model(core_mesh(mesh, progress),
                                           face_options(merge_planes, noise_mm, cylinders=cylinders), progress)
    except picoscan.Error as error:
        raise picoscan.Error("%s: %s" % (label, str(error).replace("mesh: ", "", 1))) from None
    # FreeCAD's Mesh check holds the GIL (0.1 s for 64 000 facets) and cannot be stopped inside.
    cancel_point(progress, 0.0, "solid: self-intersections")
    if mesh.hasSelfIntersections():
        raise picoscan.Error("%s: the mesh intersects itself; repair it first" % label)
    if check_valid is None:
        check_valid = len(model.faces) <= CHECK_FACES
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "solid.brep")
        picoscan.write_brep(model, path, progress)
        shape, checked = _read_and_check(path, label, check_valid, progress)
    volume = model.mesh_volume_mm3
    if checked["type"] != "Solid" or abs(checked["volume"] - volume) > VOLUME_TOLERANCE * volume:
        raise _MergedFacesRefused("%s: the solid built from the mesh has volume %.6g mm3, the mesh %.6g mm3" % (
            label, checked["volume"], volume), _has_curved_faces(model))
    if check_valid and not checked["valid"]:
        if merge_planes:
            raise _MergedFacesRefused("%s: OpenCASCADE finds the solid of its merged faces invalid" % label,
                                      _has_curved_faces(model))
        raise picoscan.Error("%s: OpenCASCADE finds the solid built from this mesh invalid" % label)
    return shape, model


def _read_and_check(path, label, check_valid, progress):
    """(Part.Shape of the BREP file at path, brep_check's answer about it). FreeCAD's Part calls
    hold Python's GIL: the volume and the validity check run in another process, which Cancel
    stops at once; this one then reads the B-rep (the one step left here that holds the GIL and
    cannot be stopped: 0.1 s for 7 080 faces on an idle machine, 1 to 2 s at load 10 to 16). The
    text B-rep, not a binary copy: FreeCAD's binary format drops the faces' triangulations, and
    without them FreeCAD's view provider meshes every face again."""
    answers = run_freecad_process(brep_check.__file__, [path, "1" if check_valid else "0"], progress,
                                  "solid: {} (checked in another process)", "%s: checking the solid" % label)
    if not answers or "type" not in answers[-1]:
        raise picoscan.Error("%s: FreeCAD could not check the solid written for it (no answer)" % label)
    cancel_point(progress, 0.0, "solid: reading the B-rep")
    time.sleep(0.1)  # the dialog shows this stage before the read holds the GIL
    shape = Part.Shape()
    shape.read(path)
    return shape, answers[-1]


def solid_of_mesh(mesh, label="mesh", merge_planes=True, noise_mm=0.0, progress=None):
    """Part.Solid of a closed FreeCAD mesh (placement applied). Raises picoscan.Error saying why not."""
    return solid_with_model(mesh, label, merge_planes, noise_mm, progress)[0]


def make_solid(doc, mesh_object, merge_planes=True, noise_mm=0.0):
    """Adds a Part::Feature holding the solid. Raises picoscan.Error (document unchanged) when the
    mesh cannot bound one; the message says why and what to do instead. The solid is made off the
    GUI thread with the progress dialog (run_in_background); Cancel leaves the document unchanged."""
    mesh, label = mesh_object.Mesh.copy(), mesh_object.Label  # the worker reads no document object
    solid, model, note = run_in_background("Making a solid of " + label, lambda progress: solid_with_model(
        mesh, label, merge_planes, noise_mm, progress))
    feature = doc.addObject("Part::Feature", mesh_object.Name + "Solid")
    feature.Label = mesh_object.Label + " solid"
    # Drawing: FreeCAD's view provider runs OpenCASCADE's mesher on the GUI thread, which nothing
    # can move or stop; it keeps the faces' triangulations written with the B-rep, but still visits
    # every face and edge (about 0.1 ms each); the dialog says what the GUI waits for.
    run_on_gui_thread("Drawing the solid of %s (%d faces)" % (label, len(model.faces)),
                      lambda: setattr(feature, "Shape", solid))
    feature.addProperty("App::PropertyString", "SolidReport", "Solid", "How the faces were made", 1)
    feature.SolidReport = model.summary() + ("; " + note if note else "")
    return feature
