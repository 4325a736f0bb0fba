// The Cross-section in one call: the cut with its Band, the fit, the report.
#include "common/text_format.h"
#include "picoscan/deviation.h"
#include "picoscan/error.h"
#include "picoscan/region_fit.h"
#include "picoscan/section_fit.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string point_text(const cv::Vec2d& p) { return format("(%.4f, %.4f)", p[0], p[1]); }
std::string vector_text(const cv::Vec3d& v) { return format("(%.4f, %.4f, %.4f)", v[0], v[1], v[2]); }

// Progress of one part of the work mapped onto [from, from + share] of the whole.
ProgressCallback part_of(const ProgressCallback& progress, double from, double share) {
    if (!progress) return nullptr;
    return [progress, from, share](double fraction, const std::string& stage) {
        return progress(from + share * fraction, stage);
    };
}

// The jackknife needs 3 runs of about 1 mm: shorter elements have no standard error to give.
std::string sigma_text(double sigma) {
    return std::isfinite(sigma) ? format("sigma %.4f", sigma) : std::string("sigma unknown: under 3 mm of points");
}

// The scan's noise (estimate_scan_noise), its errors naming the scan.
double scan_noise(const PointCloud& scan, const SectionFitOptions& options) {
    if (options.tolerance_mm > 0)
        throw Error("scan", "sets the default tolerance: give either the scan or a tolerance, not both");
    if (options.scan_noise_mm > 0)
        throw Error("scan", "its noise is measured here: give either the scan or scan_noise_mm, not both");
    try {
        return estimate_scan_noise(scan);
    } catch (const Error& error) {
        if (error.subject() != "cloud") throw;
        throw Error("scan", std::string(error.what()).substr(error.subject().size() + 2));
    }
}

std::string tolerance_text(const MeshSectionFit& result, const SectionFitOptions& options) {
    const double tolerance = result.fits.tolerance_mm;
    switch (result.tolerance_source) {
    case SectionToleranceSource::Given: return format("tolerance %.4f mm: given", tolerance);
    case SectionToleranceSource::ScanNoise:
        return format("tolerance %.4f mm: 5 x the noise of the scan the mesh was made from, %.4f mm (measured on its points)",
                      tolerance, result.scan_noise_mm);
    case SectionToleranceSource::CutNoise: break;
    }
    return format("tolerance %.4f mm: from the cut of the mesh (5 x its noise, %.4f mm, at least %.4f mm), which says "
                  "nothing of the scan when the mesher flattened the faces; no scan given: set it yourself",
                  tolerance, result.fits.noise_mm, options.min_tolerance_mm);
}

}  // namespace

ScanOfMeshCheck check_scan_of_mesh(const PointCloud& scan, const Mesh& mesh, double scan_noise_mm) {
    // An evenly spread subset is plenty for a median and keeps the check to a fraction of a second.
    constexpr size_t kMostPoints = 4000;
    cv::Vec3f low(HUGE_VALF, HUGE_VALF, HUGE_VALF), high(-HUGE_VALF, -HUGE_VALF, -HUGE_VALF);
    for (const cv::Vec3f& v : mesh.vertices)
        for (int axis = 0; axis < 3; ++axis) {
            low[axis] = std::min(low[axis], v[axis]);
            high[axis] = std::max(high[axis], v[axis]);
        }
    const double diagonal = cv::norm(cv::Vec3d(high - low));
    ScanOfMeshCheck check;
    check.margin_mm = kScanOfMeshMarginFraction * diagonal;
    check.limit_mm = std::max(kScanOfMeshNoiseWidths * scan_noise_mm, kScanOfMeshDiagonalFraction * diagonal);
    // Only the points near the mesh's box are judged: a stitched scan keeps the table or turntable
    // round the part, which the mesh left out (and a scan in another frame has none near it).
    std::vector<size_t> near_box;
    size_t finite = 0;
    for (size_t i = 0; i < scan.points.size(); ++i) {
        const cv::Vec3f& p = scan.points[i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
        ++finite;
        bool inside = true;
        for (int axis = 0; axis < 3; ++axis)
            inside = inside && p[axis] >= low[axis] - check.margin_mm && p[axis] <= high[axis] + check.margin_mm;
        if (inside) near_box.push_back(i);
    }
    if (finite == 0) throw Error("scan", "has no finite points");
    check.outside_box = finite - near_box.size();
    if (near_box.size() < kScanOfMeshFewestPoints)
        throw Error("scan", format("is not the scan this mesh was made from: %zu of its %zu points lie within %.2f mm of the "
                                   "mesh's bounding box (%g of its %.1f mm diagonal), fewer than the %zu a check needs. "
                                   "A scan in another frame? Choose the scan the mesh was made from",
                                   near_box.size(), finite, check.margin_mm, kScanOfMeshMarginFraction, diagonal,
                                   kScanOfMeshFewestPoints));
    std::vector<cv::Vec3f> sample;
    const size_t stride = std::max<size_t>(1, near_box.size() / kMostPoints);
    for (size_t k = 0; k < near_box.size(); k += stride) sample.push_back(scan.points[near_box[k]]);
    const DeviationMap map = measure_deviation(sample, mesh);
    std::vector<double> distances;
    for (const float d : map.distances_mm)
        if (std::isfinite(d)) distances.push_back(std::abs(double(d)));
    check.checked = distances.size();
    check.share = double(std::count_if(distances.begin(), distances.end(), [&](double d) { return d <= check.limit_mm; })) /
                  double(std::max<size_t>(distances.size(), 1));
    if (check.share >= kScanOfMeshShare) return check;
    std::nth_element(distances.begin(), distances.begin() + long(distances.size() / 2), distances.end());
    throw Error("scan", format("is not the scan this mesh was made from: %.0f %% of its points (%zu checked, of the %zu within "
                               "%.2f mm of the mesh's bounding box; %zu outside it not judged) lie within %.4f mm of the "
                               "mesh (%.0f x its noise of %.4f mm, at least %g of the mesh's %.1f mm diagonal), where a "
                               "scan of it has %.0f %% or more; half lie more than %.4f mm off. Another part's scan, or one "
                               "in another frame? Choose the scan the mesh was made from",
                               100 * check.share, distances.size(), near_box.size(), check.margin_mm, check.outside_box,
                               check.limit_mm, kScanOfMeshNoiseWidths, scan_noise_mm, kScanOfMeshDiagonalFraction, diagonal,
                               100 * kScanOfMeshShare, distances[distances.size() / 2]));
}

std::string section_element_text(const SectionElement& e) {
    std::string text;
    if (e.kind == SectionElementKind::Line) {
        const cv::Vec2d along = e.end - e.start;
        text = format("line   length %9.4f mm, angle %9.4f deg (%s), from %s to %s", cv::norm(along),
                      std::atan2(along[1], along[0]) * 180 / kPi, sigma_text(e.angle_sigma_deg).c_str(),
                      point_text(e.start).c_str(), point_text(e.end).c_str());
    } else {
        text = format("%-6s radius %9.4f mm (%s), %7.2f deg around %s", to_string(e.kind).c_str(), e.radius_mm,
                      sigma_text(e.radius_sigma_mm).c_str(), swept_angle_deg(e), point_text(e.centre).c_str());
        if (e.kind == SectionElementKind::Arc)
            text += format(" %s from %s to %s", e.counter_clockwise ? "counter-clockwise" : "clockwise",
                           point_text(e.start).c_str(), point_text(e.end).c_str());
    }
    text += format(", %d points, rms %.4f mm, max %.4f mm", e.point_count, e.rms_mm, e.max_mm);
    if (e.chord_sag_mm > 0)
        text += format(" at the chords' ends (a faceted cut: its chords sag up to %.4f mm inside)", e.chord_sag_mm);
    if (e.tangent_to_next) text += ", tangent to the next";
    if (e.band_cuts > 0) return text + format(", %d band cuts", e.band_cuts);
    if (!e.band_note.empty()) return text + ", band: " + e.band_note;
    return text + ", one cut";
}

std::string left_out_text(const LeftOutPolyline& left) {
    return format("%s %d (%d points, %.2f mm across, around %s mm): ", left.closed ? "loop" : "chain", left.index + 1,
                  left.point_count, left.across_mm, point_text(left.centre).c_str()) +
           left.reason;
}

SectionPlane section_plane(const cv::Vec3d& origin, const cv::Vec3d& normal) {
    const double length = cv::norm(normal);
    if (!(length > 1e-9) || !std::isfinite(length)) throw Error("normal", "must be a non-zero direction, e.g. 0,0,1");
    const cv::Vec3d n = normal / length;
    const cv::Vec3d up = std::abs(n[2]) > 0.9 ? cv::Vec3d(0, 1, 0) : cv::Vec3d(0, 0, 1);
    cv::Vec3d u = up.cross(n);
    u /= cv::norm(u);
    return {origin, n, u, n.cross(u)};
}

SectionPlane section_plane_across(int axis, double at) {
    if (axis < 0 || axis > 2) throw Error("axis", "must be 0, 1 or 2 (x, y, z), is " + std::to_string(axis));
    // Normals towards the viewer of the right (x), front (y, looking along +y) and top (z) views.
    const cv::Vec3d normals[3] = {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}};
    cv::Vec3d origin(0, 0, 0);
    origin[axis] = at;
    return section_plane(origin, normals[axis]);
}

MeshSectionFit section_mesh(const Mesh& mesh, const cv::Vec3d& origin, const cv::Vec3d& u_axis, const cv::Vec3d& v_axis,
                            double band_mm, const SectionFitOptions& options, const ProgressCallback& progress,
                            const PointCloud* scan) {
    MeshSectionFit result;
    SectionFitOptions fit_options = options;
    if (scan != nullptr) {
        if (progress && !progress(0.0, "measuring the scan's noise")) throw Error("cancelled", "the section fit was cancelled");
        result.scan_noise_mm = fit_options.scan_noise_mm = scan_noise(*scan, options);
    }
    result.tolerance_source = options.tolerance_mm > 0       ? SectionToleranceSource::Given
                              : fit_options.scan_noise_mm > 0 ? SectionToleranceSource::ScanNoise
                                                              : SectionToleranceSource::CutNoise;
    if (scan == nullptr) result.scan_noise_mm = options.scan_noise_mm;
    result.section = cut_mesh_section(mesh, origin, u_axis, v_axis, band_mm, part_of(progress, 0, 0.5));
    ScanOfMeshCheck scan_check;
    if (scan != nullptr) scan_check = check_scan_of_mesh(*scan, mesh, result.scan_noise_mm);  // the cut has checked the mesh
    result.fits = fit_section_polylines(result.section.polylines, result.section.parallel_cuts, fit_options,
                                        part_of(progress, 0.5, 0.5));
    if (progress && !progress(1.0, "fitting lines and arcs")) throw Error("cancelled", "the section fit was cancelled");
    result.tolerance_from = tolerance_text(result, options);

    const MeshSection& section = result.section;
    const SectionFits& fits = result.fits;
    std::vector<std::string>& report = result.report;
    report.push_back("plane: through " + vector_text(origin) + " mm, normal " + vector_text(u_axis.cross(v_axis)) +
                     "; the drawing's x along " + vector_text(u_axis) + ", y along " + vector_text(v_axis));
    report.push_back(format("cut: %zu polylines; band +- %.3f mm: %zu parallel cuts' polylines", section.polylines.size(),
                            band_mm, section.parallel_cuts.size()));
    report.push_back(format("noise of the cut %.4f mm; ", fits.noise_mm) + result.tolerance_from);
    if (scan != nullptr)
        report.push_back(format("scan: %.0f %% of %zu points checked lie within %.4f mm of the mesh; %zu points more than "
                                "%.2f mm outside its bounding box (a table or turntable the mesh left out) not judged",
                                100 * scan_check.share, scan_check.checked, scan_check.limit_mm, scan_check.outside_box,
                                scan_check.margin_mm));
    for (size_t k = 0; k < fits.fits.size(); ++k) {
        const SectionFit& fit = fits.fits[k];
        const SectionPolyline& polyline = section.polylines[size_t(fits.fitted_index[k])];
        std::string line = format("%s %d (%zu points): %zu elements, tolerance %.4f mm", fit.closed ? "loop" : "chain",
                                  fits.fitted_index[k] + 1, polyline.points.size(), fit.elements.size(), fit.tolerance_mm);
        if (fit.tolerance_mm > fits.tolerance_mm)  // a measured hole in a mesh whose sides were flattened
            line += format(" (its own noise, %.4f mm, is above the section's tolerance)", fit.noise_mm);
        report.push_back(line);
        for (size_t e = 0; e < fit.elements.size(); ++e)
            report.push_back(format("  %2zu ", e + 1) + section_element_text(fit.elements[e]));
    }
    for (const LeftOutPolyline& left : fits.left_out) report.push_back("left out: " + left_out_text(left));
    return result;
}

}  // namespace picoscan
