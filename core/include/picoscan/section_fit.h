// Fitted sections: a planar section of a scan (a 2D polyline, in mm) split into lines, arcs and
// circles, each within a tolerance of its points, with the joints between them (tangent or a
// corner) and the constraints a designer would add (horizontal, vertical, parallel,
// perpendicular, equal radius) wherever the points still fit within the tolerance with them.
// A CAD host turns the result into an editable, constrained sketch.
#pragma once

#include "picoscan/cloud.h"
#include "picoscan/progress.h"

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace picoscan {

enum class SectionElementKind { Line, Arc, Circle };

struct SectionFitOptions {
    // Largest distance of a point to its element while the elements are grown. 0: 5 x the noise
    // estimated from the polyline (the median over its points of the RMS of line fits, or circle
    // fits where they fit twice as well, or lines meeting at corners where they fit 4 times as
    // well, over runs of noise_window_mm), at least min_tolerance_mm. A cut of a scan mesh
    // wavers along a side by more than that short-range noise, so neighbours are then joined
    // where one fit raises their squared residuals less than 2 times with an RMS still within
    // the tolerance: such an element's largest distance (max_mm) may exceed the tolerance, its
    // RMS never does. Elements spanning less than 1 mm, and arcs of less than 1 mm radius between
    // lines, are taken as corners a mesh rounded and go to their neighbours.
    double tolerance_mm = 0;
    double min_tolerance_mm = 0.005;
    // fit_section_polylines, tolerance 0: the noise (sigma) of the scan the mesh was made from
    // (section_mesh measures it when given the scan): the tolerance is then 5 x this, not 5 x the cut's
    // noise. A mesher that flattens the faces (a sharpened Poisson surface) leaves a cut of them
    // nanometres of noise, which says nothing of how well the scan knows the part. 0: unknown.
    double scan_noise_mm = 0;
    // The noise is measured over runs this long (at least 7 points). A scan's cut also wavers by
    // bumps about 1 mm long, the same in every view (most likely phase errors at the paint's
    // speckles: a plain part's cuts have none). 2 mm runs read mostly the quiet stretches between
    // them (0.0036-0.0057 mm on the demo scan), and a tolerance of 5 x that split a side at a bump
    // in 3 of 46 cuts. 4 mm runs read 0.0062-0.0085 mm there, and the same as 2 mm on white noise.
    double noise_window_mm = 4.0;
    int min_line_points = 4;
    int min_arc_points = 8;
    double max_arc_radius_mm = 2000;  // flatter arcs are lines
    // A joint is tangent when the two fits can touch within half the tolerance and run on in
    // directions closer than this there (not a cusp).
    double tangent_angle_deg = 2.0;
    double snap_angle_deg = 2.0;      // constraints are only tried for directions closer than this
    // fit_section_polylines: a polyline of fewer points is no feature of the part (a crumb of a
    // mesh, a few facets grazed): it is left out, with the reason.
    int min_polyline_points = 16;
    // fit_section_polylines, with the tolerance from the noise: a polyline whose own noise is
    // above the section's tolerance is left out only when it is above this too. A mesher that
    // flattens the sides (a Poisson surface) leaves the outline no noise, so the section's
    // tolerance falls to min_tolerance_mm while a hole the scan measured still scatters by
    // 0.01-0.03 mm; 0.03 mm is the tolerance the demo scan's own cuts get (5 x their 0.006 mm of
    // noise), and a guessed surface scatters by more (0.04-0.3 mm). Such a polyline is fitted
    // with the tolerance of its own noise.
    double loop_noise_limit_mm = 0.03;
    // fit_section_polylines: an open chain whose ends are at most this far apart (and at most a
    // tenth of its length) is fitted as a loop. A cut of a closed part is closed; a chain is
    // open only where the scan's mesh has a hole, e.g. a gap of 0.3 mm in the middle of the demo
    // scan's right side at z = 12 mm, which would split that side in two.
    double max_bridged_gap_mm = 3.0;
    // The Band's check (fit_extruded_section): a trend of the cuts' offsets with their height is
    // taken as the part's shape, not noise, when its change over the cuts is above this part of
    // the tolerance (and 3 standard errors). Each cut used lies within the tolerance, so a trend
    // below this could move an element by at most about half of it.
    double band_trend_fraction = 0.25;
};

struct SectionElement {
    SectionElementKind kind = SectionElementKind::Line;
    // In the order of the polyline: start is where the element begins, end where it ends; they
    // are the joints with the neighbouring elements (intersections, tangent points).
    cv::Vec2d start, end;
    cv::Vec2d centre;                  // arc and circle
    double radius_mm = 0;              // arc and circle
    bool counter_clockwise = true;     // arc: the polyline runs counter-clockwise around the centre
    // The element's points start at first_point and run to the next element's first_point (indices
    // wrap on closed polylines); point_count counts those it was fitted to (fewer on a faceted cut).
    int first_point = 0, point_count = 0;
    // Distances of the element's points to it: all of them (point_count), the ends its final fit left
    // out included. An element whose rms_mm is above the tolerance is refused (Error("polyline", ...)),
    // never returned: this is the one acceptance test.
    double rms_mm = 0, max_mm = 0;
    // A faceted cut (a mesh's curved face cut along its facets' chords): where at least 4 chords in a
    // row turn alike (by at most 20 deg each, the turn per length within 25 %) and their ends lie on
    // one circle within the tolerance, whatever their length, the points strictly inside those chords
    // (on the chord, not on the curve) are left out of the fit; so too, when a polyline cannot be split
    // into elements within the tolerance otherwise, the points inside straight runs shorter than 1 mm.
    // The residuals above are then those of the points fitted (the chords' ends, on the curve), and
    // an arc's or circle's chord_sag_mm its largest chord sag c^2 / (8 r): how far inside it such
    // points may lie. 0 otherwise.
    double chord_sag_mm = 0;
    // Standard errors of the fit, from the points it used (parallel cuts included) by the block
    // jackknife: the fit repeated without each run of about 1 mm along the element, since a
    // scan's deviations are shared over about that (its bumps, a facet). NaN for an element of
    // fewer than 3 runs. A line's direction; an arc's or circle's radius.
    double angle_sigma_deg = 0;        // line
    double radius_sigma_mm = 0;        // arc and circle
    bool tangent_to_next = false;      // smooth joint with the next element (closed: the last with the first)
    // The Band: how many parallel cuts the element was fitted with (0: the section's own cut only),
    // and, when cuts followed it but their offsets from it trend with their height (the part is not
    // prismatic there: a drafted wall, a sphere, a cone), why it was fitted to its own cut alone.
    int band_cuts = 0;
    std::string band_note;
};

enum class SectionConstraintKind { Horizontal, Vertical, Parallel, Perpendicular, EqualRadius };

struct SectionConstraint {
    SectionConstraintKind kind = SectionConstraintKind::Horizontal;
    int first = 0, second = -1;        // element indices (second: -1 for horizontal and vertical)
    double max_mm = 0;                 // largest point distance with the constraint applied
};

struct SectionFit {
    std::vector<SectionElement> elements;
    std::vector<SectionConstraint> constraints;  // each one keeps the points within tolerance
    bool closed = false;
    double tolerance_mm = 0;           // used
    double noise_mm = 0;               // estimated from the polyline
};

// Where a plane cuts a mesh: polylines in the plane's own 2D frame, x along u_axis and y along
// v_axis from `origin` (the plane's normal is u x v). Triangles are joined across shared edges
// (vertices are welded by position first), so a closed surface gives closed loops; an open scan
// gives open chains too.
struct SectionPolyline {
    std::vector<cv::Vec2d> points;
    bool closed = false;  // the last point joins the first (which is not repeated)
};
// Throws Error("u_axis"/"v_axis", ...) unless they are orthonormal, Error("cancelled", ...) when
// `progress` answers false (it is told every 65 536 vertices and triangles).
std::vector<SectionPolyline> cut_mesh(const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis,
                                      const cv::Vec3d& v_axis, const ProgressCallback& progress = nullptr);

// Fits one polyline (closed: the last point joins the first; do not repeat the first point).
// Throws Error("polyline", ...) for fewer than 4 distinct points or non-finite coordinates,
// Error("tolerance_mm", ...) for a negative tolerance. Also Error("polyline", ...) when it cannot be
// split into elements within the tolerance, e.g. a closed polyline that runs round as one curve but is
// no circle within it (a faceted hole cut through one facet's middle point): one arc round it would
// leave the closing gap out of the sketch.
SectionFit fit_section(const std::vector<cv::Vec2d>& polyline, bool closed, const SectionFitOptions& options = {});

// A parallel cut of the Band: the section's profile offset_mm from its plane (along the plane's
// normal), in the same 2D frame. One cut of a mesh gives one of these per polyline.
struct ParallelCut {
    double offset_mm = 0;
    std::vector<cv::Vec2d> points;
};

// The same for a prismatic outline (e.g. a block's sides, cut across their height) cut several
// times: the elements are found on `polyline` as fit_section finds them, then each line, arc and
// circle is fitted again to its own points and to the points of the `parallel_cuts` (the same
// profile at other heights, in the same 2D frame) that lie within the tolerance of it and between
// its own points' ends. One cut of a mesh holds few independent samples (the noise is shared
// along each facet): n cuts a facet apart hold about n times as many, and a short line's
// direction is known about sqrt(n) times better. The residuals stay those of `polyline`.
// Each element checks that the part is prismatic there: where the mean offsets of its cuts from
// it trend with their height (a straight or quadratic trend whose change over the cuts is more
// than 3 standard errors and more than band_trend_fraction of the tolerance), it is fitted to
// `polyline` alone and band_note says why; unless the trend goes once the cuts at a face's end are
// left out (those at the band's ends, or next to a height that no longer follows the element or only
// grazes it: a mesh rounds the face's edge there) and at least 4 cuts, most of them, remain.
// An arc or circle whose radius is not known within the tolerance (its standard error above the
// tolerance and above 1 % of the radius: a short sliver of a curve) is refused, unless it is a
// fillet tangent to both neighbours (their lines fix it):
// Error("polyline", ...).
SectionFit fit_extruded_section(const std::vector<cv::Vec2d>& polyline, bool closed,
                                const std::vector<ParallelCut>& parallel_cuts, const SectionFitOptions& options = {});

// A section's polylines fitted as one: one noise for all (the median over the short runs of every
// polyline of at least min_polyline_points, so mostly the biggest one's), one tolerance from it
// (or the one given). A polyline is left out, with a one-line reason, when it has fewer than
// min_polyline_points points, when its own noise is above that tolerance and (unless the
// tolerance is given) above loop_noise_limit_mm (a crumb of a mesh, e.g. a small loop a Poisson
// surface leaves inside the part, whose own noise would set a tolerance loose enough to fit it as
// a circle), or when it cannot be split into elements within the tolerance (or holds an arc whose
// radius it cannot tell: fit_extruded_section). An open chain with
// a small gap (max_bridged_gap_mm) is fitted as a loop: its SectionFit is closed. Throws Error("polyline", ...) when the biggest polyline is left out
// (a sketch without its outline must not look like a fit), Error("polylines", ...) when none is
// given, Error("tolerance_mm", ...) for a negative tolerance, Error("cancelled", ...) when
// `progress` (told before each polyline) answers false.
struct LeftOutPolyline {
    int index = 0;                     // in the polylines given
    int point_count = 0;               // distinct points
    bool closed = false;
    cv::Vec2d centre{0, 0};            // the mean of its points, to find it
    double across_mm = 0;              // the larger side of its bounding box
    std::string reason;
};
// The hosts' default *Band*: a section's elements are refitted with 16 more cuts spread evenly over
// +- this from the plane (passed as parallel_cuts). One cut of the demo scan gives its 11.3 mm
// chamfer's direction within 0.108 degrees (worst of 42 heights), bands of +-1, 2, 3, 4 mm within
// 0.051, 0.044, 0.038, 0.028 degrees: the scan's bumps recur over about 1 mm of height too.
constexpr double kDefaultSectionBandMm = 3.0;
constexpr int kSectionBandCuts = 16;

struct SectionFits {
    // In the order of the polylines, each with the section's noise and tolerance, or its own where
    // its noise is above the section's tolerance and within loop_noise_limit_mm.
    std::vector<SectionFit> fits;
    std::vector<int> fitted_index;     // the polyline each fit is of
    std::vector<LeftOutPolyline> left_out;
    double noise_mm = 0, tolerance_mm = 0;  // noise_mm: the cut's (from its points), whatever the tolerance came from
};
SectionFits fit_section_polylines(const std::vector<SectionPolyline>& polylines,
                                  const std::vector<ParallelCut>& parallel_cuts = {},
                                  const SectionFitOptions& options = {}, const ProgressCallback& progress = nullptr);

// The Band's offsets from the section's plane: kSectionBandCuts spread evenly over +-band_mm, the
// section itself (0) left out; none for band_mm = 0. Throws Error("band_mm", ...) unless band_mm is
// finite and not negative.
std::vector<double> section_band_offsets(double band_mm);

// A section of a mesh with its Band, ready for fit_section_polylines: the plane's own cut and the
// cuts at section_band_offsets(band_mm) along the plane's normal (u x v), in the same 2D frame.
struct MeshSection {
    std::vector<SectionPolyline> polylines;
    std::vector<ParallelCut> parallel_cuts;  // one per polyline of each parallel cut, with its offset
};
// Cuts as cut_mesh does (the vertices welded once for all the cuts). Throws cut_mesh's errors,
// Error("band_mm", ...) as section_band_offsets, Error("plane", ...) when the plane misses the mesh
// or only grazes it (no polyline of 4 points or more: nothing to fit), and Error("cancelled", ...)
// when `progress` (told every 65 536 vertices and triangles of each cut) answers false.
MeshSection cut_mesh_section(const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis, const cv::Vec3d& v_axis,
                             double band_mm = kDefaultSectionBandMm, const ProgressCallback& progress = nullptr);

// A section's plane and its drawing's frame, as picoscan section and MeshLab's Fit Cross-section draw
// it: x (u) square to Z (to Y for a plane nearly across Z), y (v) completing a right-handed frame
// with the unit normal towards the viewer. Throws Error("normal", ...) for a zero or non-finite normal.
struct SectionPlane {
    cv::Vec3d origin, normal, u, v;
};
SectionPlane section_plane(const cv::Vec3d& origin, const cv::Vec3d& normal);
// The plane across axis 0, 1 or 2 (x, y, z) at `at` mm, seen as the right (y, z), front (x, z; looking
// along +y) or top (x, y) view. Throws Error("axis", ...) for another axis.
SectionPlane section_plane_across(int axis, double at);

// The whole Cross-section, as every host runs it (FreeCAD's Cross-section, picoscan section, MeshLab's
// Fit Cross-section): the default tolerance (5 x the noise of the scan the mesh was made from, when
// the host has it; else 5 x the cut's), the mesh cut with its Band (cut_mesh_section), the polylines
// fitted together (fit_section_polylines), and the report. The hosts only translate: the plane and
// the scan in, the sketch or drawing and the report out.
enum class SectionToleranceSource { Given, ScanNoise, CutNoise };
struct MeshSectionFit {
    MeshSection section;
    SectionFits fits;
    // The noise (sigma) of the scan, measured on its points (estimate_scan_noise); 0 without a scan.
    double scan_noise_mm = 0;
    SectionToleranceSource tolerance_source = SectionToleranceSource::CutNoise;
    // One line: the tolerance and where it came from; from the cut, it says to set it (a mesher that
    // flattens the faces leaves their cut nanometres of noise, no measure of the scan).
    std::string tolerance_from;
    // The plane, the cuts, the noise and tolerance (tolerance_from), each fitted polyline with one line
    // per element (section_element_text) and each polyline left out (left_out_text).
    std::vector<std::string> report;
};
// `scan`: the points the mesh was made from (a view or a stitched cloud, in the mesh's frame: their
// noise sets the tolerance), or null. Throws Error("scan", ...) for a scan given with options.tolerance_mm or
// options.scan_noise_mm set (one source of the tolerance), with too few points to measure its
// noise, or that is not the mesh's scan (check_scan_of_mesh), and cut_mesh_section's and fit_section_polylines' errors. `progress` hears the noise and
// the cut (0 to 0.5) and the fit (0.5 to 1); answering false cancels: Error("cancelled", ...).
MeshSectionFit section_mesh(const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis, const cv::Vec3d& v_axis,
                            double band_mm = kDefaultSectionBandMm, const SectionFitOptions& options = {},
                            const ProgressCallback& progress = nullptr, const PointCloud* scan = nullptr);
// Whether `scan` (with its measured noise) is the scan `mesh` was made from, before its noise sets a
// section's tolerance: a host lets the user pick any point cloud. Only its points in the mesh's
// bounding box grown by kScanOfMeshMarginFraction of its diagonal are judged: a stitched scan keeps
// the table or turntable round the part, which the mesh left out (the simulated demo scan with a
// table disc of 60 mm radius: 39 % of its points near the mesh, refused when every point was
// judged; 96.6 % of those judged). At least kScanOfMeshFewestPoints must lie there, and at least
// kScanOfMeshShare of them (an even subset of at most 4000) within kScanOfMeshNoiseWidths x its noise of
// the mesh, or within kScanOfMeshDiagonalFraction of the diagonal when that is more (a mesh deviates
// from a noise-free scan by its own spacing). A scan of another part, or this one's in another frame
// (even moved along a block's faces, which most of its points still touch), has far fewer. Throws
// Error("scan", ...) with the share, the limit, the median distance and how many points were not judged.
constexpr double kScanOfMeshNoiseWidths = 3.0;
constexpr double kScanOfMeshDiagonalFraction = 0.001;
constexpr double kScanOfMeshShare = 0.8;
constexpr double kScanOfMeshMarginFraction = 0.02;
constexpr size_t kScanOfMeshFewestPoints = 100;
struct ScanOfMeshCheck {
    size_t checked = 0;      // points measured against the mesh
    size_t outside_box = 0;  // finite points beyond the grown box, not judged
    double share = 0;        // of those checked, within limit_mm of the mesh
    double limit_mm = 0, margin_mm = 0;
};
ScanOfMeshCheck check_scan_of_mesh(const PointCloud& scan, const Mesh& mesh, double scan_noise_mm);

// One element as the report gives it: kind, size (with its standard error), where, its points and
// residuals, its chords' sag on a faceted cut, tangency, and the Band's part (or why none).
std::string section_element_text(const SectionElement& element);
// A polyline left out: loop or chain, its number (from 1), points, size, where, and why.
std::string left_out_text(const LeftOutPolyline& left);

// A fitted section as a drawing, in millimetres in the section's 2D frame (left-out polylines are
// not drawn). SVG: one path per line and arc, a circle element per circle, the section's y up (SVG's
// y runs down, so it is negated). DXF: R12 ASCII with LINE, ARC and CIRCLE entities, which CAD tools
// read. Write them with write_file_atomically (file_output.h).
std::string section_svg(const SectionFits& fits);
std::string section_dxf(const SectionFits& fits);
// An element's extent: a line's length, an arc's swept angle (degrees, positive), 360 for a circle.
double swept_angle_deg(const SectionElement& element);

std::string to_string(SectionElementKind kind);
std::string to_string(SectionConstraintKind kind);

}  // namespace picoscan
