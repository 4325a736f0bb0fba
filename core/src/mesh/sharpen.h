// Sharp edges restored on a smooth (Poisson) mesh from the planes of the measured points.
#pragma once

#include "mesh/cgal_types.h"

#include <vector>

namespace picoscan::detail {

struct SharpenReport {
    size_t planes = 0;           // planar regions found in the points
    size_t edge_vertices = 0;    // vertices near two or three of them that the points agree with
    size_t cut_edges = 0;        // mesh edges split where they cross a feature line
    size_t corners = 0;          // vertices put on the meeting point of three planes
    size_t hole_vertices = 0;    // vertices made on a hole's fitted wall where Poisson guessed it
    size_t merged_cuts = 0;      // cuts of a face on one line close together, made one vertex
    size_t reverted = 0;         // moves undone (all the way back) because they folded triangles
    bool undone = false;         // the whole sharpening undone: its mesh had faces crossing that did not before
    std::vector<int> crossing_merged_cuts;  // when undone: merged cuts among the crossing faces' vertices
};

// The planar regions of the points are found (region growing); where the mesh runs near two
// or three of them meeting at an angle (an edge, a corner) and the points there lie on those
// planes (a fillet's points do not: it is left round), the mesh's edges that cross the line
// where the planes meet are split on it, and the vertices go onto their own plane, the line
// or the corner. A hole's unseen wall is rebuilt on the cylinder fitted to its seen wall.
// Moves that fold a triangle or make the mesh cross itself are pulled back,
// part way or all the way.
SharpenReport sharpen_edges(Mesh& mesh, const std::vector<PointWithNormal>& points, double spacing_mm);

}  // namespace picoscan::detail
