// Point preparation and Poisson surface reconstruction (Kazhdan et al. 2006, CGAL's
// Delaunay-refinement implementation), then a projection of the surface back onto the points.
#define CGAL_EIGEN3_ENABLED 1
#include "mesh/cgal_types.h"
#include "common/third_party_output.h"
#include "picoscan/error.h"

#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/compute_average_spacing.h>
#include <CGAL/grid_simplify_point_set.h>
#include <CGAL/pca_estimate_normals.h>
#include <CGAL/IO/facets_in_complex_2_to_triangle_mesh.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/repair_self_intersections.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Implicit_surface_3.h>
#include <CGAL/exceptions.h>
#include <CGAL/Poisson_reconstruction_function.h>
#include <CGAL/Delaunay_triangulation_cell_base_with_circumcenter_3.h>
#include <CGAL/Robust_circumcenter_traits_3.h>
#include <CGAL/Surface_mesh_cell_base_3.h>
#include <CGAL/Surface_mesh_vertex_base_3.h>
#include <CGAL/Surface_mesher/Standard_criteria.h>
#include <CGAL/make_surface_mesh.h>
#include <CGAL/property_map.h>

#include <opencv2/core.hpp>
#include <algorithm>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <map>
#include <type_traits>
#include <unordered_set>

namespace picoscan::detail {

namespace {
using PointMap = CGAL::First_of_pair_property_map<PointWithNormal>;
using NormalMap = CGAL::Second_of_pair_property_map<PointWithNormal>;

// The progress callback of CGAL's point processing (called once per point here, CGAL being
// built without TBB): reports every few thousand points. A cancel (the exception the report
// throws) is kept and stops CGAL's loop, and thrown again once CGAL has returned.
// CGAL 5.5 binds its reference to a temporary copy of a callback passed by value, gone before it
// is called (a crash once the callable does not fit in std::function's own buffer): the callback
// is passed as a std::cref of a std::function that outlives the call.
class PointLoopReport {
public:
    PointLoopReport(const StageReport& report, const char* stage, double from, double to)
        : report_(report), stage_(stage), from_(from), to_(to) {}
    std::function<bool(double)> callback() {
        return [this](double done) {
            if (++calls_ % 4096 != 0) return true;
            try {
                report_(from_ + (to_ - from_) * done, stage_);
            } catch (...) {
                cancel_ = std::current_exception();
                return false;
            }
            return true;
        };
    }
    void throw_if_cancelled() const {
        if (cancel_) std::rethrow_exception(cancel_);
    }

private:
    const StageReport& report_;
    const char* stage_;
    double from_, to_;
    size_t calls_ = 0;
    std::exception_ptr cancel_;
};

// Thinning has no callback of its own: each point read (by the one-per-cell partition, or by
// CGAL's grid simplification through this point map: once for the cell's hash, more for
// comparisons within a bucket) is counted, with a report every few thousand, so that thinning a
// large cloud can be cancelled (the report throws; the containers stay valid).
class ThinningReport {
public:
    explicit ThinningReport(const StageReport& report) : report_(report) {}
    void read() {
        if (++reads_ % 16384 == 0) report_(0.0, "thinning the points");
    }

private:
    const StageReport& report_;
    size_t reads_ = 0;
};
struct ThinningPointMap {
    using key_type = PointWithNormal;
    using value_type = Point3;
    using reference = const Point3&;
    using category = boost::lvalue_property_map_tag;
    ThinningReport* thinning;
    friend reference get(const ThinningPointMap& map, const key_type& point) {
        map.thinning->read();
        return point.first;
    }
};

// The cell of a spacing_mm grid a point falls in, computed as CGAL's grid_simplify_point_set
// computes it (floor of each coordinate over the spacing), so that cells compare alike.
struct GridCell {
    double x, y, z;
    bool operator==(const GridCell& other) const { return x == other.x && y == other.y && z == other.z; }
};
struct GridCellHash {
    size_t operator()(const GridCell& cell) const {
        const std::hash<double> hash;
        return hash(cell.x) ^ (hash(cell.y) * 0x9e3779b97f4a7c15ULL) ^ (hash(cell.z) * 0xc2b2ae3d27d4eb4fULL);
    }
};
}  // namespace

std::vector<PointWithNormal> prepare_points(const PointCloud& cloud, double spacing_mm, int max_points,
                                            double& average_spacing_mm, const StageReport& report) {
    if (cloud.points.size() > std::numeric_limits<uint32_t>::max())
        throw Error("point cloud", "has " + std::to_string(cloud.points.size()) + " points; at most 4294967295 can be meshed");
    const bool has_normals = cloud.normals.size() == cloud.points.size();
    auto finite = [](const cv::Vec3f& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); };
    enum class Kind { Unmeasured, WithoutNormal, Usable };
    auto kind_of = [&](size_t i) {
        if (!finite(cloud.points[i])) return Kind::Unmeasured;
        // The given normal says which side the sensor saw; without it a PCA normal's sign is a guess.
        if (has_normals && !(finite(cloud.normals[i]) && cv::norm(cloud.normals[i]) > 0)) return Kind::WithoutNormal;
        return Kind::Usable;
    };
    size_t usable_count = 0, without_normal = 0;
    for (size_t i = 0; i < cloud.points.size(); ++i) {
        const Kind kind = kind_of(i);
        usable_count += kind == Kind::Usable;
        without_normal += kind == Kind::WithoutNormal;
    }
    if (has_normals && without_normal * 10 > usable_count + without_normal)
        throw Error("point cloud", std::to_string(without_normal) + " of " + std::to_string(usable_count + without_normal) +
                                       " points have no valid normal (NaN or zero): their outside is unknown");
    // The usable points as indices into the cloud (4 bytes each, where a copy of a merged cloud
    // of millions of points as CGAL pairs takes 48): the cloud is thinned before it is copied.
    std::vector<uint32_t> usable;
    usable.reserve(usable_count);
    for (size_t i = 0; i < cloud.points.size(); ++i)
        if (kind_of(i) == Kind::Usable) usable.push_back(static_cast<uint32_t>(i));
    ThinningReport thinning(report);
    const ThinningPointMap thinning_map{&thinning};
    if (spacing_mm > 0) {
        // One point per cell: the same points, in the same order, as grid_simplify_point_set on a
        // copy of the usable points (the same std::partition with the same test, on indices).
        std::unordered_set<GridCell, GridCellHash> occupied;
        usable.erase(std::partition(usable.begin(), usable.end(),
                                    [&](uint32_t i) {
                                        thinning.read();
                                        const cv::Vec3f& p = cloud.points[i];
                                        return occupied
                                            .insert({std::floor(double(p[0]) / spacing_mm), std::floor(double(p[1]) / spacing_mm),
                                                     std::floor(double(p[2]) / spacing_mm)})
                                            .second;
                                    }),
                     usable.end());
    }
    std::vector<PointWithNormal> points;
    points.reserve(usable.size());
    for (uint32_t i : usable) {
        const cv::Vec3f& p = cloud.points[i];
        const cv::Vec3f n = has_normals ? cloud.normals[i] : cv::Vec3f(0, 0, 0);
        points.emplace_back(Point3(p[0], p[1], p[2]), Vector3(n[0], n[1], n[2]));
    }
    std::vector<uint32_t>().swap(usable);
    // The budget: a coarser grid until at most max_points remain (the count falls with the
    // square of the spacing on a surface).
    for (double coarser = spacing_mm; max_points > 0 && points.size() > size_t(max_points);) {
        const double shrink = std::sqrt(double(points.size()) / double(max_points)) * 1.05;
        coarser = coarser > 0 ? coarser * shrink : 0.1;
        points.erase(CGAL::grid_simplify_point_set(points, coarser, CGAL::parameters::point_map(thinning_map)), points.end());
    }
    if (spacing_mm <= 0) {
        // Coincident points have no spacing to mesh at (and crash the reconstruction).
        std::sort(points.begin(), points.end(), [](const PointWithNormal& a, const PointWithNormal& b) { return a.first < b.first; });
        points.erase(std::unique(points.begin(), points.end(),
                                 [](const PointWithNormal& a, const PointWithNormal& b) { return a.first == b.first; }),
                     points.end());
    }
    points.shrink_to_fit();  // the budget's thinning keeps the room of the points before it, through Poisson
    if (points.size() < 20) return points;
    report(0.0, "estimating normals");
    // Re-estimated normals are smoother than per-pixel ones; the sensor's side says which way.
    std::vector<Vector3> sensor_side;
    sensor_side.reserve(points.size());
    for (const PointWithNormal& p : points) sensor_side.push_back(p.second);
    PointLoopReport normals_report(report, "estimating normals", 0.0, 0.8);
    const std::function<bool(double)> normals_callback = normals_report.callback();
    CGAL::pca_estimate_normals<CGAL::Parallel_if_available_tag>(
        points, 18, CGAL::parameters::point_map(PointMap()).normal_map(NormalMap()).callback(std::cref(normals_callback)));
    normals_report.throw_if_cancelled();
    for (size_t i = 0; i < points.size(); ++i) {
        Vector3& n = points[i].second;
        const double length = std::sqrt(n.squared_length());
        if (length > 0) n = n / length;
        if (has_normals && n * sensor_side[i] < 0) n = -n;
    }
    PointLoopReport spacing_report(report, "measuring the spacing", 0.8, 1.0);
    const std::function<bool(double)> spacing_callback = spacing_report.callback();
    average_spacing_mm = CGAL::compute_average_spacing<CGAL::Parallel_if_available_tag>(
        points, 6, CGAL::parameters::point_map(PointMap()).callback(std::cref(spacing_callback)));
    spacing_report.throw_if_cancelled();
    return points;
}

namespace {

// Evaluations of the implicit function per face of the result, allowed before an attempt is
// given up (measured: about 165 on the demo part).
constexpr double kEvaluationsPerFace = 250;
// Rounds of the local repair of filled holes that cross the surface (one sufficed when measured).
constexpr int kCrossingRepairRounds = 3;
// Relative residual at which the Poisson equation counts as solved.
constexpr double kSolverTolerance = 1e-7;

// Called by CGAL before each point enters the triangulation: reports progress and stops the
// reconstruction (by the exception report throws) when the caller cancels.
struct ReportingVisitor {
    const StageReport* report;
    size_t total;
    const char* stage;
    double from, to;  // the fractions of the whole reported at the first and the last point
    mutable size_t inserted = 0;
    void before_insertion() const {
        if (++inserted % 4096 == 0) (*report)(from + (to - from) * std::min(1.0, double(inserted) / double(total)), stage);
    }
};

// CGAL's Delaunay refinement of the Poisson triangulation offers no hook, but it asks the
// geometric traits for the circumradius of every cell it tests. The traits below count those
// requests (and the input points inserted again between refinements) and report every 4096,
// so that the refinement shows progress and can be cancelled.
struct RefinementReport {
    const StageReport* report = nullptr;
    size_t points = 1;  // the input, to scale the progress (about 10 cell tests per point)
    size_t steps = 0;
    void step() {
        if (++steps % 4096 != 0) return;
        const double work = double(steps) / double(10 * points);
        (*report)(0.03 + 0.09 * work / (1 + work), "Poisson: refining the triangulation");
    }
};
thread_local RefinementReport* refinement_report = nullptr;

struct ReportingKernel : Kernel {
    struct Compute_squared_radius_3 : Kernel::Compute_squared_radius_3 {
        using Base = Kernel::Compute_squared_radius_3;
        using Base::operator();
        Kernel::FT operator()(const Point3& p, const Point3& q, const Point3& r, const Point3& s) const {
            if (refinement_report) refinement_report->step();
            return Base::operator()(p, q, r, s);
        }
    };
    Compute_squared_radius_3 compute_squared_radius_3_object() const { return {}; }
};

struct RefinementVisitor {
    void before_insertion() const {
        if (refinement_report) refinement_report->step();
    }
};

// Sets refinement_report for the lifetime of one reconstruction on this thread.
class RefinementReportScope {
public:
    explicit RefinementReportScope(RefinementReport& report) { refinement_report = &report; }
    ~RefinementReportScope() { refinement_report = nullptr; }
    RefinementReportScope(const RefinementReportScope&) = delete;
    RefinementReportScope& operator=(const RefinementReportScope&) = delete;
};

// CGAL's symmetric matrix, reporting as the rows of the Poisson system are assembled (each
// row ends with its diagonal coefficient), so that the assembly can be cancelled too.
class ReportingMatrix : public CGAL::Eigen_sparse_symmetric_matrix<double> {
public:
    explicit ReportingMatrix(int dimension)
        : CGAL::Eigen_sparse_symmetric_matrix<double>(dimension), rows_(std::max(dimension, 1)) {}
    void set_coef(std::size_t i, std::size_t j, double value, bool new_coef = false) {
        CGAL::Eigen_sparse_symmetric_matrix<double>::set_coef(i, j, value, new_coef);
        if (i == j && ++rows_done_ % 1024 == 0 && refinement_report)
            (*refinement_report->report)(0.12 + 0.03 * double(rows_done_) / double(rows_), "Poisson: assembling the system");
    }

private:
    int rows_;
    int rows_done_ = 0;
};

// The conjugate-gradient solve of CGAL's Poisson system, as Eigen's ConjugateGradient does it
// (Jacobi preconditioner, the lower triangle read as the symmetric matrix, 2n iterations at most),
// with a progress report every few iterations: the solve is most of a large reconstruction's
// time, and a report is where the caller can cancel (the exception it throws leaves the solver).
// It stops at a relative residual of kSolverTolerance, not Eigen's machine precision: the digits
// beyond move the zero level by far less than the point noise.
struct ReportingSolver {
    using Base = CGAL::Eigen_solver_traits<Eigen::ConjugateGradient<CGAL::Eigen_sparse_symmetric_matrix<double>::EigenType>>;
    using Matrix = ReportingMatrix;
    using Vector = Base::Vector;
    using NT = Base::NT;
    const StageReport* report = nullptr;

    bool linear_solver(const Matrix& a, const Vector& b, Vector& x, NT& d) const {
        d = 1;
        const auto& m = a.eigen_object();
        const Eigen::Index n = m.cols();
        Eigen::VectorXd inverse_diagonal = m.diagonal();
        for (Eigen::Index i = 0; i < n; ++i) inverse_diagonal[i] = inverse_diagonal[i] != 0 ? 1 / inverse_diagonal[i] : 1;
        Eigen::VectorXd solution = Eigen::VectorXd::Zero(n), residual = b.eigen_object();
        const double b_norm2 = residual.squaredNorm();
        const double threshold = std::max(kSolverTolerance * kSolverTolerance * b_norm2, std::numeric_limits<double>::min());
        if (b_norm2 == 0) {
            x.eigen_object() = solution;
            return true;
        }
        Eigen::VectorXd direction = inverse_diagonal.cwiseProduct(residual), product(n);
        double rz = residual.dot(direction);
        const double log_start = std::log(b_norm2), log_span = std::log(threshold) - log_start;
        for (Eigen::Index iteration = 0; iteration < 2 * n; ++iteration) {
            product.noalias() = m.selfadjointView<Eigen::Lower>() * direction;
            const double step = rz / direction.dot(product);
            solution += step * direction;
            residual -= step * product;
            const double r_norm2 = residual.squaredNorm();
            if (r_norm2 < threshold) {
                x.eigen_object() = solution;
                return true;
            }
            const Eigen::VectorXd preconditioned = inverse_diagonal.cwiseProduct(residual);
            const double rz_next = residual.dot(preconditioned);
            direction = preconditioned + (rz_next / rz) * direction;
            rz = rz_next;
            // The residual falls about geometrically: its logarithm tells how far the solve is.
            if (iteration % 16 == 15)
                (*report)(0.15 + 0.15 * std::clamp((std::log(r_norm2) - log_start) / log_span, 0.0, 1.0),
                          "Poisson: solving the implicit function");
        }
        return false;
    }
};

// Where the data is: the occupied cells of a fine grid (about two triangles wide) and of a
// coarse one (four times wider). A point near no data lies on the surface Poisson invents to
// close the shape, which needs no finer triangles than its smooth bulge.
class DataProximity {
public:
    DataProximity(const std::vector<PointWithNormal>& points, double fine_cell_mm)
        : fine_(fine_cell_mm), coarse_(4 * fine_cell_mm) {
        for (const PointWithNormal& p : points) {
            fine_cells_.insert(key(p.first, fine_, 0, 0, 0));
            coarse_cells_.insert(key(p.first, coarse_, 0, 0, 0));
        }
    }
    // 0 beside the data (an occupied fine cell or a neighbour of one), 1 within the coarse
    // neighbourhood, 2 farther.
    int level(const Point3& p) const {
        if (near(fine_cells_, p, fine_)) return 0;
        return near(coarse_cells_, p, coarse_) ? 1 : 2;
    }

private:
    static long long key(const Point3& p, double cell, int dx, int dy, int dz) {
        // 21 bits per axis around the origin: +-1 million cells. Clamped before the conversion, which
        // is undefined beyond long long's range (a cluster 1e-14 mm apart with --spacing-mm 0 and
        // a point 1 km away); cells that far share keys either way.
        const auto axis = [&](double v, int d) {
            return (static_cast<long long>(std::clamp(std::floor(v / cell), -1e15, 1e15)) + d + (1 << 20)) & 0x1FFFFF;
        };
        return (axis(p.x(), dx) << 42) | (axis(p.y(), dy) << 21) | axis(p.z(), dz);
    }
    static bool near(const std::unordered_set<long long>& cells, const Point3& p, double cell) {
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz)
                    if (cells.count(key(p, cell, dx, dy, dz))) return true;
        return false;
    }
    double fine_, coarse_;
    std::unordered_set<long long> fine_cells_, coarse_cells_;
};

// The surface mesher's criteria of Boissonnat & Oudot (minimum angle, Delaunay-ball radius,
// distance to the surface), with the radius and distance bounds graded by the distance to
// the data: as given beside the points, kCoarseScale times larger a little away, kFarScale
// times larger far away. A single open view closes into a bubble many times the data's area;
// at the data's resolution that bubble cost minutes.
template <class Tr>
class GradedCriteria {
public:
    using Criterion = CGAL::Surface_mesher::Refine_criterion<Tr>;
    using Quality = typename CGAL::Surface_mesher::Standard_criteria<Criterion>::Quality;
    using Facet = typename Tr::Facet;
    static constexpr double kCoarseScale = 2.5, kFarScale = 6.0;

    GradedCriteria(double angle_deg, double radius_mm, double distance_mm, const DataProximity& proximity)
        : angle_(angle_deg), size_(radius_mm, distance_mm, proximity) {
        criteria_.set_criteria({&angle_, &size_});
    }
    GradedCriteria(const GradedCriteria&) = delete;
    GradedCriteria& operator=(const GradedCriteria&) = delete;
    bool is_bad(const Facet& facet, Quality& quality) const { return criteria_.is_bad(facet, quality); }

private:
    class GradedSize : public Criterion {
    public:
        GradedSize(double radius, double distance, const DataProximity& proximity)
            : radius_(radius), distance_(distance), proximity_(proximity) {}
        bool is_bad(const Facet& facet, typename Criterion::Quality& quality) const override {
            const typename Tr::Geom_traits traits;
            const auto& p1 = facet.first->vertex((facet.second + 1) & 3)->point();
            const auto& p2 = facet.first->vertex((facet.second + 2) & 3)->point();
            const auto& p3 = facet.first->vertex((facet.second + 3) & 3)->point();
            const auto& on_surface = facet.first->get_facet_surface_center(facet.second);
            const int level = proximity_.level(on_surface);
            const double scale = level == 0 ? 1.0 : level == 1 ? kCoarseScale : kFarScale;
            const double radius = scale * radius_, distance = scale * distance_;
            const double ball = CGAL::to_double(traits.compute_squared_distance_3_object()(p1, on_surface));
            quality = radius * radius / ball;
            if (quality < 1) return true;
            const auto centre = traits.construct_circumcenter_3_object()(p1, p2, p3);
            const double gap = CGAL::to_double(traits.compute_squared_distance_3_object()(centre, on_surface));
            if (gap > 0) quality = std::min(quality, distance * distance / gap);
            return quality < 1;
        }

    private:
        double radius_, distance_;
        const DataProximity& proximity_;
    };
    CGAL::Surface_mesher::Aspect_ratio_criterion<Tr> angle_;
    GradedSize size_;
    CGAL::Surface_mesher::Standard_criteria<Criterion> criteria_;
};

// The surface mesher finds the surface where the implicit function changes sign along the
// edges of its Voronoi diagram: where a coarse cell's edge crosses the closing bubble twice (far
// from the data, where the triangles are large) it misses a facet, and leaves a hole there
// (27 to 41 border edges on a single view of the mechanical part), or a small separate sheet.
// The surface is closed, so its holes are closed again (triangulated, refined and faired: they
// lie on invented surface, marked filled later as any other) and separate pieces away from the
// data are dropped. A piece of the surface that holds data is never dropped.
// The mesher's own surface does not cross itself, but a filled hole can cross the bubble's
// other sheet where it passes close by (measured on a single view of the mechanical part: about
// 300 pairs of crossing faces, all in filled holes). Those crossings are repaired locally by
// CGAL's remove_self_intersections (the crossing faces removed, the region smoothed or its hole
// filled again), on the coordinates rounded to float as the Mesh keeps them, and checked again.
void close_invented_surface(SurfaceMesh& mesh, const DataProximity& proximity) {
    namespace PMP = CGAL::Polygon_mesh_processing;
    std::vector<SurfaceMesh::Halfedge_index> borders;
    PMP::extract_boundary_cycles(mesh, std::back_inserter(borders));
    for (SurfaceMesh::Halfedge_index border : borders) {
        std::vector<SurfaceMesh::Face_index> faces;
        std::vector<SurfaceMesh::Vertex_index> vertices;
        PMP::triangulate_refine_and_fair_hole(mesh, border, std::back_inserter(faces), std::back_inserter(vertices));
    }
    if (!borders.empty()) {
        const auto round_to_float = [&] {
            for (SurfaceMesh::Vertex_index v : mesh.vertices()) {
                const Point3& p = mesh.point(v);
                mesh.point(v) = Point3(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
            }
        };
        round_to_float();
        for (int round = 0; round < kCrossingRepairRounds && PMP::does_self_intersect(mesh); ++round) {
            PMP::experimental::remove_self_intersections(CGAL::faces(mesh), mesh, CGAL::parameters::preserve_genus(false));
            round_to_float();
        }
    }
    auto component = mesh.add_property_map<SurfaceMesh::Face_index, std::size_t>("f:component", 0).first;
    const std::size_t count = PMP::connected_components(mesh, component);
    if (count > 1) {
        std::vector<bool> holds_data(count, false);
        for (SurfaceMesh::Face_index f : mesh.faces())
            for (SurfaceMesh::Vertex_index v : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
                if (proximity.level(mesh.point(v)) == 0) holds_data[component[f]] = true;
        std::vector<std::size_t> invented;
        for (std::size_t c = 0; c < count; ++c)
            if (!holds_data[c]) invented.push_back(c);
        if (!invented.empty()) PMP::remove_connected_components(mesh, invented, component);
    }
    mesh.remove_property_map(component);
    mesh.collect_garbage();
    // With holes, the mesher's surface may come out inside out (seen once in three runs of the
    // same view: -189.5 cm^3); closed, it is turned to face out.
    if (CGAL::is_closed(mesh) && !PMP::is_outward_oriented(mesh)) PMP::reverse_face_orientations(mesh);
}

// A vertex or cell of a triangulation that carries its creation number. CGAL's containers then
// order handles by it instead of by memory address: the surface mesher keeps its bad vertices
// and facets in sets ordered by handle, so with addresses the same input gave different meshes
// depending on the heap's state (13 576 or 13 586 vertices, one process). The Poisson
// function's own triangulation needs it too (below).
template <class Base>
class TimeStamped : public Base {
public:
    template <class Tds>
    struct Rebind_TDS {
        using Other = TimeStamped<typename Base::template Rebind_TDS<Tds>::Other>;
    };
    using Has_timestamp = CGAL::Tag_true;
    using Base::Base;
    std::size_t time_stamp() const { return time_stamp_; }
    void set_time_stamp(std::size_t stamp) { time_stamp_ = stamp; }

private:
    std::size_t time_stamp_ = std::size_t(-1);  // unset: the container numbers it when it is created
};

using MesherTraits = CGAL::Robust_circumcenter_traits_3<Kernel>;
using MesherTriangulation = CGAL::Delaunay_triangulation_3<
    MesherTraits,
    CGAL::Triangulation_data_structure_3<
        TimeStamped<CGAL::Surface_mesh_vertex_base_3<MesherTraits>>,
        TimeStamped<CGAL::Delaunay_triangulation_cell_base_with_circumcenter_3<
            MesherTraits, CGAL::Surface_mesh_cell_base_3<MesherTraits>>>>>;

// The Poisson function's triangulation (CGAL 5.5 fixes its type from the traits alone), with
// time-stamped vertices and cells. Its Delaunay refinement keeps the bad cells in a
// CGAL::Double_map, a boost bimap ordered by quality and by handle; Double_map::insert
// (CGAL/Double_map.h, line 191 in 5.5.1) inserts with the handle's place as the hint, and boost
// places a cell among cells of equal quality at that hint. With handles ordered by address, which
// of two equally bad cells was split first followed the heap: the same points gave another set
// of Steiner points after an unrelated meshing in the process, and another surface (the holed
// block's unseen hole wall: 519 um or 1.2 um off the true wall).
using PoissonBaseTraits = CGAL::Robust_circumcenter_filtered_traits_3<ReportingKernel>;
using PoissonTraits = CGAL::Reconstruction_triangulation_default_geom_traits_3<PoissonBaseTraits>;
using StampedPoissonTds = CGAL::Triangulation_data_structure_3<
    TimeStamped<CGAL::Reconstruction_vertex_base_3<PoissonTraits>>,
    TimeStamped<CGAL::Delaunay_triangulation_cell_base_3<PoissonTraits,
                                                         CGAL::Triangulation_cell_base_with_info_3<int, PoissonTraits>>>>;
using StampedPoissonTriangulation = CGAL::Reconstruction_triangulation_3<PoissonBaseTraits, PoissonTraits, StampedPoissonTds>;

}  // namespace
}  // namespace picoscan::detail

// Poisson_reconstruction_function<ReportingKernel> names its triangulation as
// Reconstruction_triangulation_3<its traits> with the default data structure: that one type,
// which only this file uses, is made the time-stamped triangulation above.
template <>
class CGAL::Reconstruction_triangulation_3<picoscan::detail::PoissonBaseTraits>
    : public picoscan::detail::StampedPoissonTriangulation {};

namespace picoscan::detail {

Mesh poisson_mesh(const std::vector<PointWithNormal>& points, const PoissonSettings& settings, const StageReport& report) {
    // Kazhdan's implicit function on CGAL's Delaunay refinement, then the surface mesher of
    // Boissonnat & Oudot on its zero level, as CGAL's poisson_surface_reconstruction_delaunay,
    // with the progress reported and the surface's triangle size bounded by the face budget.
    using Function = CGAL::Poisson_reconstruction_function<ReportingKernel>;
    static_assert(std::is_base_of_v<StampedPoissonTriangulation, Function::Triangulation> &&
                      Function::Triangulation::Cell::Has_timestamp::value && Function::Triangulation::Vertex::Has_timestamp::value,
                  "the Poisson function's triangulation orders its handles by creation");
    using Triangulation = MesherTriangulation;
    using Complex = CGAL::Surface_mesh_complex_2_in_triangulation_3<Triangulation>;
    using Surface = CGAL::Implicit_surface_3<Kernel, std::function<Kernel::FT(Point3)>>;

    report(0.0, "Poisson: triangulating the points");
    Function function(points.begin(), points.end(), PointMap(), NormalMap(),
                      ReportingVisitor{&report, points.size(), "Poisson: triangulating the points", 0.0, 0.03});
    report(0.03, "Poisson: refining the triangulation");
    ThirdPartyOutput cgal;  // CGAL prints its solver's complaints on stderr
    ReportingSolver solver;
    solver.report = &report;
    RefinementReport refinement{&report, std::max<size_t>(points.size(), 1)};
    bool solved = false;
    {
        const RefinementReportScope scope(refinement);
        solved = function.compute_implicit_function(solver, RefinementVisitor{}, 0, 5);
    }
    if (!solved)
        throw Error("Poisson reconstruction", "the implicit function could not be solved (are the normals consistent?)" +
                                                  attached(cgal.text(), "CGAL"));
    // The surface mesher's triangles: about the point spacing, but larger when the data's
    // area (points x spacing^2, doubled for the side Poisson closes) would exceed the face
    // budget. Each attempt is capped by its number of evaluations of the function (a single
    // open view closes into a bubble larger than the data); past the cap the triangles double.
    const double data_area = 2.0 * double(points.size()) * settings.spacing_mm * settings.spacing_mm;
    const double faces = std::max(1000.0, double(settings.max_faces));
    double triangle_size = std::max(settings.triangle_size * settings.spacing_mm, std::sqrt(data_area / (0.5 * faces)));
    const Kernel::Sphere_3 bounds = function.bounding_sphere();
    const double sphere_radius = 5 * std::sqrt(bounds.squared_radius());
    const size_t evaluation_cap = static_cast<size_t>(kEvaluationsPerFace * faces);
    struct OverBudget {};
    const DataProximity proximity(points, 2 * triangle_size);
    // The mesher starts from points on rays in random directions (CGAL's default generator,
    // seeded from the clock): a fixed seed makes the mesh repeatable, and a start that hits one
    // of its own vertices (CGAL: "already inserted on surface") is tried again from other rays.
    unsigned seed = 1;
    constexpr unsigned kSeeds = 3;
    for (int attempt = 0;; ++attempt) {
        report(0.3, "Poisson: meshing the surface");
        size_t evaluations = 0;
        const std::function<Kernel::FT(Point3)> level = [&](const Point3& p) {
            if (++evaluations % 20000 == 0) {
                report(0.3 + 0.4 * double(evaluations) / double(evaluation_cap), "Poisson: meshing the surface");
                if (evaluations > evaluation_cap) throw OverBudget{};
            }
            return function(p);
        };
        const double distance = settings.distance * std::max(settings.spacing_mm, triangle_size / settings.triangle_size);
        const Surface surface(level, Kernel::Sphere_3(function.get_inner_point(), sphere_radius * sphere_radius),
                              distance / 1000.0 / sphere_radius);
        const GradedCriteria<Triangulation> criteria(20.0, triangle_size, distance, proximity);
        Triangulation triangulation;
        Complex complex(triangulation);
        CGAL::get_default_random() = CGAL::Random(seed);
        try {
            CGAL::make_surface_mesh(complex, surface, criteria, CGAL::Manifold_with_boundary_tag());
        } catch (const CGAL::Failure_exception& failure) {
            if (seed == kSeeds)
                throw Error("Poisson reconstruction", "the surface mesher failed from " + std::to_string(kSeeds) +
                                                          " random starts: " + failure.message());
            ++seed;
            --attempt;  // the same triangle size from other rays
            continue;
        } catch (const OverBudget&) {
            if (attempt == 3)
                throw Error("Poisson reconstruction", "the surface exceeds the face budget (mesh.max_faces) even with "
                                                      "triangles of " + std::to_string(triangle_size) + " mm");
            triangle_size *= 2;
            continue;
        }
        if (triangulation.number_of_vertices() == 0)
            throw Error("Poisson reconstruction", "the implicit function has no surface (are the normals consistent?)");
        // The mesher can insert its starting points and keep no facet (500 points on a 30 mm ball):
        // CGAL's export then reads the first of no facets (a crash).
        if (complex.number_of_facets() == 0) {
            if (seed == kSeeds)
                throw Error("Poisson reconstruction", "the surface mesher kept no facet from " + std::to_string(kSeeds) +
                                                          " random starts (too few points for the surface they sample?)");
            ++seed;
            --attempt;  // the same triangle size from other rays
            continue;
        }
        SurfaceMesh out;
        CGAL::facets_in_complex_2_to_triangle_mesh(complex, out);
        close_invented_surface(out, proximity);
        return to_mesh(out);
    }
}

double fraction_of_points_near(const Mesh& mesh, const std::vector<PointWithNormal>& points, double reach_mm) {
    using Traits = CGAL::Search_traits_3<Kernel>;
    using Search = CGAL::Orthogonal_k_neighbor_search<Traits>;
    if (mesh.vertices.empty() || points.empty()) return 0;
    std::vector<Point3> vertices;
    vertices.reserve(mesh.vertices.size());
    for (const cv::Vec3f& v : mesh.vertices) vertices.emplace_back(v[0], v[1], v[2]);
    const Search::Tree tree(vertices.begin(), vertices.end());
    size_t near = 0;
    for (const PointWithNormal& point : points) {
        Search search(tree, point.first, 1);
        if (search.begin() != search.end() && search.begin()->second <= reach_mm * reach_mm) ++near;
    }
    return double(near) / double(points.size());
}

void project_onto_points(Mesh& mesh, const std::vector<PointWithNormal>& points, double reach_mm) {
    using Traits = CGAL::Search_traits_3<Kernel>;
    using Search = CGAL::Orthogonal_k_neighbor_search<Traits>;
    std::vector<Point3> cloud;
    std::map<Point3, size_t> index_of;
    cloud.reserve(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
        cloud.push_back(points[i].first);
        index_of.emplace(points[i].first, i);
    }
    const Search::Tree tree(cloud.begin(), cloud.end());
    const int neighbours = 16;
    const double same_face = std::cos(20.0 * CV_PI / 180.0);
    for (cv::Vec3f& vertex : mesh.vertices) {
        const Point3 query(vertex[0], vertex[1], vertex[2]);
        Search search(tree, query, neighbours);
        // The plane of the face the nearest point lies on: only neighbours whose normals agree
        // with the nearest one's, so a vertex near a sharp edge goes to its face, not a bevel.
        std::vector<cv::Vec3d> near;
        Vector3 nearest_normal(0, 0, 0);
        for (const auto& found : search) {
            if (found.second > reach_mm * reach_mm) break;
            const Vector3& n = points[index_of.at(found.first)].second;
            if (near.empty()) nearest_normal = n;
            else if (n * nearest_normal < same_face) continue;
            near.emplace_back(found.first.x(), found.first.y(), found.first.z());
        }
        if (near.size() < 6) continue;  // unsupported by data (a closed-over gap): leave it
        cv::Vec3d centre(0, 0, 0);
        for (const cv::Vec3d& p : near) centre += p;
        centre *= 1.0 / static_cast<double>(near.size());
        cv::Matx33d scatter = cv::Matx33d::zeros();
        for (const cv::Vec3d& p : near) scatter += (p - centre) * (p - centre).t();
        cv::Matx31d eigenvalues;
        cv::Matx33d eigenvectors;
        cv::eigen(scatter, eigenvalues, eigenvectors);
        const cv::Vec3d normal(eigenvectors(2, 0), eigenvectors(2, 1), eigenvectors(2, 2));
        const cv::Vec3d v(vertex);
        vertex = cv::Vec3f(v - normal * normal.dot(v - centre));
    }
}

}  // namespace picoscan::detail
