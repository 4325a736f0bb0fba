"""Mesh -> Part solid, for closed meshes small enough for OpenCASCADE (one B-rep face per triangle)."""
import FreeCAD
import Part

import picoscan

MAX_FACETS = 20000


def make_solid(doc, mesh_object, max_facets=MAX_FACETS, tolerance_mm=0.01):
    """Adds a Part::Feature holding the solid. Raises picoscan.Error (document unchanged) when the mesh
    is open or too big; the message says what to do instead."""
    mesh = mesh_object.Mesh
    if mesh.CountFacets == 0:
        raise picoscan.Error("%s: the mesh is empty" % mesh_object.Label)
    if not mesh.isSolid():
        raise picoscan.Error("%s: the mesh is not closed (a single scan is a surface); mesh stitched views with "
                             "Poisson to get a closed one" % mesh_object.Label)
    if mesh.CountFacets > max_facets:
        raise picoscan.Error("%s: %d facets, more than %d; a solid with one face per facet would be too heavy. "
                             "Use a coarser mesh or Fit primitives" % (mesh_object.Label, mesh.CountFacets, max_facets))
    shape = Part.Shape()
    shape.makeShapeFromMesh(mesh.Topology, tolerance_mm)
    solid = Part.makeSolid(Part.makeShell(shape.Faces))
    if not solid.isValid() or solid.Volume <= 0:
        raise picoscan.Error("%s: OpenCASCADE could not make a valid solid from this mesh" % mesh_object.Label)
    feature = doc.addObject("Part::Feature", mesh_object.Name + "Solid")
    feature.Label = mesh_object.Label + " solid"
    feature.Shape = solid
    return feature
