// Cylindrical faces of a solid: a wall of facets left between two planar faces (a drilled hole, a
// boss, a shaft) that lies on a cylinder square to both becomes one B-rep cylinder, its two loops
// circles.
#pragma once

#include "picoscan/solid.h"

#include <string>
#include <vector>

namespace picoscan::detail {

struct CylinderRegion {
    std::vector<size_t> faces;        // the model's faces it replaces: one-facet faces and planar strips of its wall
    size_t planes[2] = {0, 0};        // the planar faces at its ends
    size_t wires[2] = {0, 0};         // the wire of each that it bounds
    cv::Vec3d origin, axis, x_axis;   // origin: on the axis, in the plane of planes[0]
    double radius_mm = 0, rms_mm = 0;  // radius_mm: at origin
    double slope = 0;                 // a cone: the radius grows by this per mm along the axis (0: a cylinder)
    // A chamfer ring (bent): from bend_level on, away from planes[0], the wall goes on as another
    // cylinder or cone about the same axis, its radius growing by far_slope per mm from the circle
    // where the two meet (two faces sharing that circle).
    bool bent = false;
    double bend_level = 0, far_slope = 0;
    bool beyond_bend(double height) const { return bent && (height - bend_level) * bend_level > 0; }
    double slope_at(double height) const { return beyond_bend(height) ? far_slope : slope; }
    double radius_at(double height) const {  // height along the axis from origin
        return beyond_bend(height) ? radius_mm + slope * bend_level + far_slope * (height - bend_level) : radius_mm + slope * height;
    }
    bool hole = false;                // the solid is outside the cylinder
    size_t end_facets = 0;            // facets at its ends the cylinder and planes are continued over
    double end_mm = 0, end_volume_mm3 = 0;  // the farthest of them, and the volume between them and those surfaces
};

// The regions of `model` that make cylindrical faces, with the fitted cylinders. Along each planar
// face's normal: walls of one-facet faces and planar strips square to it (within 60 degrees) that go
// all round a circle, with the facets next to them within two edge lengths of the cylinder or of a
// plane square to it (a smooth mesh's rounded ends: the cylinder and the planes are continued over
// them while that changes the volume by at most 0.01 %), bounded by two planar faces square to the
// axis and nothing else, whose facets' normals face away from the axis wherever they are (a prism's
// flat sides bunch them into one direction each) and whose vertices' distances from the axis do not
// follow a prism's sides; only faces marked in `eligible` (all when it is empty: the normals and
// distances are then read on the mesh's own vertices, not checked again). A cylinder's wall that goes
// on into a cone before it meets one of its planes (a chamfer ring) gives one bent region: the
// cylinder, the cone about its axis and the circle where they meet. Each wall near a cylinder but
// refused is said in `notes` with the reason, as is each piece of the surface left that lies near a
// cylinder along no planar face's normal.
std::vector<CylinderRegion> cylinder_regions(const PlanarFaceModel& model, const PlanarFaceOptions& options,
                                             const std::vector<char>& eligible, std::vector<std::string>& notes);

// Replaces each region's facets by its cylinder: one cylindrical face (at the end of the faces), a
// circle in each planar face instead of the loop it bounded (those planar faces lose their
// triangulations, which do not follow the circles), and the seam between the circles. A bent
// region gives two faces (each with its seam) sharing the circle at its bend.
void add_cylinder_faces(PlanarFaceModel& model, const std::vector<CylinderRegion>& regions);

}  // namespace picoscan::detail
