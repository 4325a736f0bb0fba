"""Mesh -> Part solid: one planar B-rep face per facet, built on shared vertices and edges.

The B-rep is written directly in OpenCASCADE's BREP text format and read back, so no sewing and
no face-by-face shell construction is needed: the time grows linearly with the facets. Whether
the result is a solid is decided on the mesh first (closed, manifold, consistently oriented, no
self-intersections, no degenerate facets: what makes a polyhedral B-rep valid), then by the
solid's volume against the mesh's; OpenCASCADE's own validity check (BRepCheck, the slowest part
by far) runs on meshes up to CHECK_FACETS facets."""
import os
import tempfile

import numpy
import Part

import picoscan

MAX_FACETS = 2000000   # about 1.4 GB of BREP text: beyond this, Fit primitives or a coarser mesh
CHECK_FACETS = 20000   # up to here OpenCASCADE's BRepCheck confirms the solid too
VOLUME_TOLERANCE = 1e-3


def _mesh_problem(mesh, points, facets):
    """Why the mesh cannot bound a solid, or None."""
    if not mesh.isSolid():
        return "the mesh is not closed (a single scan is a surface); mesh stitched views with Poisson to get a closed one"
    if mesh.hasNonManifolds():
        return "the mesh has non-manifold edges (more than two facets on an edge); repair it first"
    if mesh.hasNonUniformOrientedFacets():
        return "the mesh's facets are not consistently oriented; repair it first"
    corners = points[facets]
    areas = numpy.linalg.norm(numpy.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    scale = float(numpy.ptp(points, axis=0).max()) or 1.0
    degenerate = int(numpy.count_nonzero(areas < 1e-12 * scale * scale))
    if degenerate:
        return "the mesh has %d degenerate (zero-area) facets; repair it first" % degenerate
    if mesh.hasSelfIntersections():
        return "the mesh intersects itself; repair it first"
    return None


def _format_rows(pattern, rows):
    return "".join(map(pattern.__mod__, map(tuple, rows.tolist())))


def write_brep(points, facets, path, tolerance_mm=1e-7):
    """A closed, outward-oriented triangle mesh as a BREP solid: vertices, straight edges shared by
    two facets, one planar face per facet (its wire in the facet's order), a shell and the solid."""
    vertex_count, facet_count = len(points), len(facets)
    pairs = numpy.concatenate([facets[:, [0, 1]], facets[:, [1, 2]], facets[:, [2, 0]]])
    low, high = pairs.min(axis=1), pairs.max(axis=1)
    keys, edge_of = numpy.unique(low * vertex_count + high, return_inverse=True)
    starts, ends = keys // vertex_count, keys % vertex_count
    edge_count = len(keys)
    edge_of = edge_of.reshape(3, facet_count).T
    forward = (pairs[:, 0] == low).reshape(3, facet_count).T
    directions = points[ends] - points[starts]
    lengths = numpy.linalg.norm(directions, axis=1)
    directions /= lengths[:, None]
    corners = points[facets]
    normals = numpy.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= numpy.linalg.norm(normals, axis=1)[:, None]
    x_axes = corners[:, 1] - corners[:, 0]
    x_axes /= numpy.linalg.norm(x_axes, axis=1)[:, None]
    y_axes = numpy.cross(normals, x_axes)
    # TShapes are referred to by their place counted from the end of the list (the last is 1):
    # vertices, edges, then a wire and its face per facet, the shell and the solid.
    total = vertex_count + edge_count + 2 * facet_count + 2
    vertex_refs = total - numpy.arange(vertex_count)
    edge_refs = total - vertex_count - numpy.arange(edge_count)
    wire_refs = total - vertex_count - edge_count - 2 * numpy.arange(facet_count)
    face_refs = wire_refs - 1
    signed_edges = numpy.where(forward, 1, -1) * edge_refs[edge_of]
    with open(path, "w") as stream:
        stream.write("DBRep_DrawableShape\n\nCASCADE Topology V1, (c) Matra-Datavision\nLocations 0\nCurve2ds 0\n")
        stream.write("Curves %d\n" % edge_count)
        stream.write(_format_rows("1 %.17g %.17g %.17g %.17g %.17g %.17g\n", numpy.hstack([points[starts], directions])))
        stream.write("Polygon3D 0\nPolygonOnTriangulations 0\nSurfaces %d\n" % facet_count)
        stream.write(_format_rows("1" + " %.17g" * 12 + "\n", numpy.hstack([corners[:, 0], normals, x_axes, y_axes])))
        stream.write("Triangulations 0\n\nTShapes %d\n" % total)
        stream.write(_format_rows("Ve\n%g\n%%.17g %%.17g %%.17g\n0 0\n\n0101101\n*\n" % tolerance_mm, points))
        edge_rows = numpy.column_stack([numpy.arange(1, edge_count + 1), lengths, vertex_refs[starts], vertex_refs[ends]])
        stream.write(_format_rows("Ed\n %g 1 1 0\n1  %%d 0 0 %%.17g\n0\n\n0101000\n+%%d 0 -%%d 0 *\n" % tolerance_mm,
                                  edge_rows))
        signs = numpy.where(signed_edges > 0, "+", "-").tolist()
        magnitudes = numpy.abs(signed_edges).tolist()
        face_rows = [(s[0], m[0], s[1], m[1], s[2], m[2], k + 1, wire) for k, (s, m, wire) in
                     enumerate(zip(signs, magnitudes, wire_refs.tolist()))]
        pattern = "Wi\n\n0101100\n%%s%%d 0 %%s%%d 0 %%s%%d 0 *\nFa\n0  %g %%d 0\n\n0101000\n+%%d 0 *\n" % tolerance_mm
        stream.write("".join(map(pattern.__mod__, face_rows)))
        stream.write("Sh\n\n0101100\n%s *\n" % " ".join("+%d 0" % r for r in face_refs.tolist()))
        stream.write("So\n\n1100000\n+2 0 *\n\n+1 0\n")


def solid_of_mesh(mesh, label="mesh"):
    """Part.Solid of a closed FreeCAD mesh (placement applied). Raises picoscan.Error saying why not."""
    if mesh.CountFacets == 0:
        raise picoscan.Error("%s: the mesh is empty" % label)
    if mesh.CountFacets > MAX_FACETS:
        raise picoscan.Error("%s: %d facets, more than %d; use a coarser mesh or Fit primitives" % (
            label, mesh.CountFacets, MAX_FACETS))
    vertices, facet_list = mesh.Topology
    points = numpy.array([tuple(p) for p in vertices], dtype=numpy.float64)
    facets = numpy.array(facet_list, dtype=numpy.int64)
    problem = _mesh_problem(mesh, points, facets)
    if problem:
        raise picoscan.Error("%s: %s" % (label, problem))
    corners = points[facets]
    signed_volume = float(numpy.einsum("ij,ij->i", corners[:, 0], numpy.cross(corners[:, 1], corners[:, 2])).sum()) / 6
    if signed_volume < 0:  # facets oriented inwards: turn them outwards
        facets = facets[:, ::-1].copy()
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "solid.brep")
        write_brep(points, facets, path)
        shape = Part.Shape()
        shape.read(path)
    volume = abs(signed_volume)
    if shape.ShapeType != "Solid" or abs(shape.Volume - volume) > VOLUME_TOLERANCE * volume:
        raise picoscan.Error("%s: the solid built from the mesh has volume %.6g mm3, the mesh %.6g mm3" % (
            label, shape.Volume, volume))
    if mesh.CountFacets <= CHECK_FACETS and not shape.isValid():
        raise picoscan.Error("%s: OpenCASCADE finds the solid built from this mesh invalid" % label)
    return shape


def make_solid(doc, mesh_object):
    """Adds a Part::Feature holding the solid. Raises picoscan.Error (document unchanged) when the
    mesh cannot bound one; the message says why and what to do instead."""
    solid = solid_of_mesh(mesh_object.Mesh, mesh_object.Label)
    feature = doc.addObject("Part::Feature", mesh_object.Name + "Solid")
    feature.Label = mesh_object.Label + " solid"
    feature.Shape = solid
    return feature
