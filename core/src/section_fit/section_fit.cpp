// Splits a section polyline into lines and arcs: each element is grown from where the last one
// ended for as long as its least-squares fit stays within the tolerance (line or arc, whichever
// covers more), the splits are then moved to where the two neighbours fit best, neighbours that
// fit as one are merged, and the ends are set to the joints of the fitted geometry.
#include "picoscan/section_fit.h"
#include "picoscan/error.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <set>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;
// A piece of a section shorter than this is no element of the part: a corner a mesh rounded or cut off.
constexpr double kSmallestElementMm = 1.0;

// A fitted line (point + unit direction) or circle (centre + radius), before it becomes an element.
struct Shape {
    bool circle = false;
    cv::Vec2d point, direction;  // line
    cv::Vec2d centre;
    double radius = 0;           // circle
    bool ok = false;

    double distance(const cv::Vec2d& p) const {
        if (circle) return std::abs(cv::norm(p - centre) - radius);
        const cv::Vec2d d = p - point;
        return std::abs(d[0] * direction[1] - d[1] * direction[0]);
    }
};

// The points of a polyline seen as a ring (closed) or a range (open): index i wraps when closed.
struct Points {
    const std::vector<cv::Vec2d>& p;
    bool closed;
    size_t size() const { return p.size(); }
    const cv::Vec2d& operator[](long i) const {
        const long n = long(p.size());
        return p[size_t(closed ? ((i % n) + n) % n : i)];
    }
};

Shape fit_line(const Points& pts, long first, long count) {
    Shape shape;
    if (count < 2) return shape;
    cv::Vec2d mean(0, 0);
    for (long i = first; i < first + count; ++i) mean += pts[i];
    mean /= double(count);
    double sxx = 0, sxy = 0, syy = 0;
    for (long i = first; i < first + count; ++i) {
        const cv::Vec2d d = pts[i] - mean;
        sxx += d[0] * d[0];
        sxy += d[0] * d[1];
        syy += d[1] * d[1];
    }
    const double angle = 0.5 * std::atan2(2 * sxy, sxx - syy);  // principal axis
    shape.point = mean;
    shape.direction = {std::cos(angle), std::sin(angle)};
    // Orient along the polyline.
    if ((pts[first + count - 1] - pts[first]).dot(shape.direction) < 0) shape.direction = -shape.direction;
    shape.ok = sxx + syy > 0;
    return shape;
}

// Algebraic (Kasa) start, then Gauss-Newton on the geometric distances.
Shape fit_circle(const Points& pts, long first, long count) {
    Shape shape;
    shape.circle = true;
    if (count < 3) return shape;
    cv::Vec2d mean(0, 0);
    for (long i = first; i < first + count; ++i) mean += pts[i];
    mean /= double(count);
    cv::Matx33d normal = cv::Matx33d::zeros();
    cv::Vec3d rhs(0, 0, 0);
    for (long i = first; i < first + count; ++i) {
        const cv::Vec2d d = pts[i] - mean;
        const cv::Vec3d row(d[0], d[1], 1);
        normal += row * row.t();
        rhs += row * -(d[0] * d[0] + d[1] * d[1]);
    }
    cv::Vec3d abc;
    if (!cv::solve(normal, rhs, abc, cv::DECOMP_CHOLESKY)) return shape;
    cv::Vec2d centre(-abc[0] / 2, -abc[1] / 2);
    double radius_sq = centre.dot(centre) - abc[2];
    if (!(radius_sq > 0)) return shape;
    double radius = std::sqrt(radius_sq);
    for (int iteration = 0; iteration < 10; ++iteration) {
        cv::Matx33d jtj = cv::Matx33d::zeros();
        cv::Vec3d jtr(0, 0, 0);
        for (long i = first; i < first + count; ++i) {
            const cv::Vec2d d = pts[i] - mean - centre;
            const double length = cv::norm(d);
            if (length == 0) continue;
            const cv::Vec3d j(-d[0] / length, -d[1] / length, -1);
            const double r = length - radius;
            jtj += j * j.t();
            jtr += j * r;
        }
        cv::Vec3d step;
        if (!cv::solve(jtj, -jtr, step, cv::DECOMP_CHOLESKY)) break;
        centre += cv::Vec2d(step[0], step[1]);
        radius += step[2];
        if (cv::norm(step) < 1e-10 * std::max(1.0, radius)) break;
    }
    shape.centre = centre + mean;
    shape.radius = radius;
    shape.ok = radius > 0 && std::isfinite(radius);
    return shape;
}

double max_distance(const Shape& shape, const Points& pts, long first, long count) {
    double worst = 0;
    for (long i = first; i < first + count; ++i) worst = std::max(worst, shape.distance(pts[i]));
    return worst;
}

double rms_of(const Shape& shape, const Points& pts, long first, long count) {
    double sum = 0;
    for (long i = first; i < first + count; ++i) sum += std::pow(shape.distance(pts[i]), 2);
    return std::sqrt(sum / double(std::max<long>(count, 1)));
}

// Signed angle swept going through the points around the centre (positive: counter-clockwise).
double swept_angle(const Points& pts, long first, long count, const cv::Vec2d& centre) {
    double sweep = 0;
    for (long i = first + 1; i < first + count; ++i) {
        const cv::Vec2d a = pts[i - 1] - centre, b = pts[i] - centre;
        sweep += std::atan2(a[0] * b[1] - a[1] * b[0], a.dot(b));
    }
    return sweep;
}

struct Span {
    long first = 0, count = 0;
    Shape shape;
};

class SectionFitter {
public:
    SectionFitter(const std::vector<cv::Vec2d>& polyline, bool closed, const SectionFitOptions& options, double tolerance)
        : pts_{polyline, closed}, options_(options), tolerance_(tolerance) {}

    bool fits(const Shape& shape, long first, long count) const {
        if (!shape.ok) return false;
        if (shape.circle) {
            if (shape.radius > options_.max_arc_radius_mm) return false;
            // An open run cannot go round more than once.
            if (std::abs(swept_angle(pts_, first, count, shape.centre)) > 2 * kPi + 0.1) return false;
        }
        return max_distance(shape, pts_, first, count) <= tolerance_;
    }

    Shape fit(bool circle, long first, long count) const {
        return circle ? fit_circle(pts_, first, count) : fit_line(pts_, first, count);
    }

    // The longest run from `first` (at most `limit` points) that one line (or circle) fits.
    Span grow(bool circle, long first, long limit) const {
        const long minimum = circle ? options_.min_arc_points : options_.min_line_points;
        Span best{first, 0, {}};
        if (limit < minimum) return best;
        const auto try_count = [&](long count) {
            Shape shape = fit(circle, first, count);
            if (!fits(shape, first, count)) return false;
            if (count > best.count) best = {first, count, shape};
            return true;
        };
        if (!try_count(minimum)) return best;
        // Doubling, then bisection between the last good and the first bad count.
        long good = minimum, bad = -1;
        for (long count = minimum * 2; bad < 0; count *= 2) {
            const long c = std::min(count, limit);
            if (try_count(c)) {
                good = c;
                if (c == limit) return best;
            } else {
                bad = c;
            }
        }
        while (bad - good > 1) {
            const long middle = (good + bad) / 2;
            if (try_count(middle))
                good = middle;
            else
                bad = middle;
        }
        return best;
    }

    // A real side too short for min_line_points after an arc (a slot's 2 mm side between two faceted
    // arcs: one chord of the mesh and its middle): the arc's last point, the point no element starts
    // at, and the next ones, on one line within the tolerance. It is a side, not a facet of the arc,
    // only when its inner points lie outside the arc's circle by more than the tolerance: a chord of
    // a circle lies inside it (by its sag), a line tangent to it outside. Count 0: none. A closed
    // polyline's side may take the point at start + total (the first element's first).
    Span short_side(const Span& arc, long position, long limit) const {
        constexpr long kFewestSidePoints = 3;  // a line through 2 points says nothing of its fit
        const Span none{position, 0, {}};
        if (!arc.shape.circle || arc.count - 1 < options_.min_arc_points) return none;
        const long most = std::min<long>(options_.min_line_points - 1, limit + (pts_.closed ? 2 : 1));
        for (long count = most; count >= kFewestSidePoints; --count) {
            const long first = position - 1;
            const Shape line = fit(false, first, count);
            if (!fits(line, first, count)) continue;
            bool outside = true;
            for (long i = first + 1; i + 1 < first + count; ++i)
                outside = outside && cv::norm(pts_[i] - arc.shape.centre) - arc.shape.radius > tolerance_;
            if (outside) return {first, count, line};
        }
        return none;
    }

    // Greedy cover of the points from `start`.
    std::vector<Span> cover(long start) const {
        std::vector<Span> spans;
        const long total = long(pts_.size());
        long position = start;
        while (position < start + total) {
            const long limit = start + total - position;
            const Span line = grow(false, position, limit);
            const Span arc = grow(true, position, limit);
            Span chosen = arc.count > line.count * 1.1 ? arc : line;
            if (chosen.count == 0 && spans.empty()) {
                // Stray points before the first element: they join it (its fit is made without them).
                if (limit <= std::min(options_.min_line_points, options_.min_arc_points))
                    throw Error("polyline", "no line of " + std::to_string(options_.min_line_points) +
                                                " points or more (min_line_points) or arc of " +
                                                std::to_string(options_.min_arc_points) +
                                                " (min_arc_points) fits its points within the tolerance of " +
                                                std::to_string(tolerance_) + " mm");
                ++position;
                continue;
            }
            if (spans.empty()) {
                chosen.count += chosen.first - start;
                chosen.first = start;
            }
            if (chosen.count == 0) {
                const Span side = short_side(spans.back(), position, limit);
                if (side.count > 0) {
                    spans.back().count -= 1;  // its last point is the side's first
                    spans.push_back(side);
                    // Closed, the side may end at the first element's first point: it is the side's.
                    const long past = side.first + side.count - (start + total);
                    if (past > 0) {
                        spans.front().first += past;
                        spans.front().count -= past;
                        break;
                    }
                    position = side.first + side.count;
                    continue;
                }
                const long fewest = std::min(options_.min_line_points, options_.min_arc_points);
                if (limit < fewest) {  // too few points left for an element of their own
                    spans.back().count += limit;
                    break;
                }
                // No element starts here (a stray point at a corner): it joins the previous element and
                // the next one starts after it. (Giving it all the points left made one "line" of a
                // whole outline.) Whether every element holds its points is checked at the end.
                spans.back().count += 1;
                position += 1;
                continue;
            }
            spans.push_back(chosen);
            // From the element's own end: the first one starts at `start`, with the stray points before
            // it (counting them twice skipped as many points of the next element: 2 of a 9-point fillet).
            position = chosen.first + chosen.count;
        }
        return spans;
    }

    // Moves every split between neighbours to where their two fits explain the points best.
    void refine(std::vector<Span>& spans) const {
        const size_t n = spans.size();
        const size_t joints = pts_.closed ? n : n - 1;
        if (n < 2) return;
        for (int round = 0; round < 3; ++round) {
            for (size_t j = 0; j < joints; ++j) {
                Span& a = spans[j];
                Span& b = spans[(j + 1) % n];
                const long begin = a.first, end = a.first + a.count + b.count;  // both, in a's numbering
                // A short side (short_side) keeps its points: moving the split would hand it the arc's.
                if (std::min(a.count, b.count) < options_.min_line_points) continue;
                // Neither may shrink below its own kind's fewest points: an arc kept to min_line_points
                // became a 4-point arc of 19 degrees off a faceted hole's circle.
                const long lowest = a.first + std::max<long>(fewest_points(a.shape), a.count / 2);
                const long highest = end - std::max<long>(fewest_points(b.shape), b.count / 2);
                if (lowest >= highest) continue;
                double best_cost = HUGE_VAL;
                long best_split = a.first + a.count;
                // cost(k) = sum of a's squared distances before k + b's from k on.
                std::vector<double> before(size_t(end - begin + 1), 0.0), after(size_t(end - begin + 1), 0.0);
                for (long i = begin; i < end; ++i) {
                    const double d = a.shape.distance(pts_[i]);
                    before[size_t(i - begin + 1)] = before[size_t(i - begin)] + d * d;
                }
                for (long i = end - 1; i >= begin; --i) {
                    const double d = b.shape.distance(pts_[i]);
                    after[size_t(i - begin)] = after[size_t(i - begin + 1)] + d * d;
                }
                for (long k = lowest; k <= highest; ++k) {
                    const double cost = before[size_t(k - begin)] + after[size_t(k - begin)];
                    if (cost < best_cost) {
                        best_cost = cost;
                        best_split = k;
                    }
                }
                const long total = a.count + b.count;
                a.count = best_split - a.first;
                b.first = best_split;
                b.count = total - a.count;
                if (pts_.closed) b.first = ((b.first % long(pts_.size())) + long(pts_.size())) % long(pts_.size());
                a.shape = fit(a.shape.circle, a.first, a.count);
                b.shape = fit(b.shape.circle, b.first, b.count);
            }
        }
    }

    // Joins neighbours of the same kind that one fit explains within the tolerance.
    void merge(std::vector<Span>& spans) const {
        bool merged = true;
        while (merged && spans.size() > 1) {
            merged = false;
            const size_t n = spans.size();
            const size_t joints = pts_.closed ? n : n - 1;
            for (size_t j = 0; j < joints && !merged; ++j) {
                const Span& a = spans[j];
                const Span& b = spans[(j + 1) % n];
                if (a.shape.circle != b.shape.circle) continue;
                const Shape joined = fit(a.shape.circle, a.first, a.count + b.count);
                if (!fits(joined, a.first, a.count + b.count)) continue;
                spans[j] = {a.first, a.count + b.count, joined};
                spans.erase(spans.begin() + long((j + 1) % n));
                if (j + 1 == n) spans.insert(spans.begin(), spans.back()), spans.pop_back();
                merged = true;
            }
        }
    }

    // Splits and arcs the points do not ask for. A cut of a scan mesh wavers along a side (views
    // merged with small offsets, noise shared along each facet) by more than its short-range
    // noise, so the tolerance taken from that noise splits a straight side into pieces, some
    // fitted as very flat arcs. A split stays only where joining its two neighbours into one line
    // (or circle, when one is an arc) raises their squared residuals more than kSplitGain times,
    // or the joined fit's RMS above the tolerance; an arc stays an arc on the same terms. A real
    // corner, chamfer or fillet raises them hundreds of times.
    void drop_unfounded_splits(std::vector<Span>& spans) const {
        constexpr double kSplitGain = 2.0;
        for (;;) {
            const size_t n = spans.size();
            double best_gain = kSplitGain;
            size_t best = n;
            Span replacement;
            const auto consider = [&](size_t j, const Span& joined, double separate) {
                const double sum = squared_sum(joined.shape, joined.first, joined.count);
                if (!fits_on_average(joined) || sum > best_gain * std::max(separate, floor_sum(joined.count))) return;
                best_gain = sum / std::max(separate, floor_sum(joined.count));
                best = j;
                replacement = joined;
            };
            for (size_t j = 0; j < n; ++j) {  // an arc that is as good as a line
                const Span& a = spans[j];
                if (a.shape.circle) consider(j, {a.first, a.count, fit(false, a.first, a.count)}, squared_sum(a.shape, a.first, a.count));
            }
            const size_t joints = n < 2 ? 0 : pts_.closed ? n : n - 1;
            for (size_t j = 0; j < joints; ++j) {
                const Span& a = spans[j];
                const Span& b = spans[(j + 1) % n];
                const double separate = squared_sum(a.shape, a.first, a.count) + squared_sum(b.shape, b.first, b.count);
                for (const bool circle : {false, true}) {
                    if (circle && !a.shape.circle && !b.shape.circle) continue;
                    consider(j, {a.first, a.count + b.count, fit(circle, a.first, a.count + b.count)}, separate);
                }
            }
            // A short piece of a side between two pieces of it (a bump where views overlap) is
            // judged with both: the three joined into one.
            const size_t middles = n < 4 ? (pts_.closed || n < 3 ? 0 : 1) : pts_.closed ? n : n - 2;
            for (size_t j = 0; j < middles; ++j) {
                const Span& a = spans[j];
                const Span& b = spans[(j + 1) % n];
                const Span& c = spans[(j + 2) % n];
                const double separate = squared_sum(a.shape, a.first, a.count) + squared_sum(b.shape, b.first, b.count) +
                                        squared_sum(c.shape, c.first, c.count);
                const long total = a.count + b.count + c.count;
                for (const bool circle : {false, true}) {
                    if (circle && !a.shape.circle && !b.shape.circle && !c.shape.circle) continue;
                    consider(j, {a.first, total, fit(circle, a.first, total)}, separate);
                }
            }
            if (best == n) return;
            // The replacement starts where spans[best] does and takes the next one or two.
            long left = replacement.count - spans[best].count;
            spans[best] = replacement;
            while (left > 0) {
                const size_t next = (best + 1) % spans.size();
                left -= spans[next].count;
                spans.erase(spans.begin() + long(next));
                if (next < best) --best;
            }
        }
    }

    // Elements spanning less than kSmallestElementMm, and arcs of a smaller radius between two
    // lines (or a line and an open end), are corners a mesh rounded or frayed (its surface
    // follows an edge only to within a few sample spacings), not fillets or facets: their points
    // go to the neighbours, half to each, for refine() to place the split.
    void drop_rounded_corners(std::vector<Span>& spans) const {
        for (size_t j = 0; j < spans.size() && spans.size() > 1;) {
            const size_t n = spans.size();
            const bool has_before = pts_.closed || j > 0, has_after = pts_.closed || j + 1 < n;
            const Span& arc = spans[j];
            const bool lines_around = (!has_before || !spans[(j + n - 1) % n].shape.circle) &&
                                      (!has_after || !spans[(j + 1) % n].shape.circle);
            const bool tiny = cv::norm(pts_[arc.first + arc.count - 1] - pts_[arc.first]) < kSmallestElementMm;
            const bool small_arc = arc.shape.circle && arc.shape.radius < kSmallestElementMm && lines_around;
            if (!tiny && !small_arc) {
                ++j;
                continue;
            }
            const long to_before = has_after ? (has_before ? arc.count / 2 : 0) : arc.count;
            std::vector<Span> given = spans;
            if (has_before) given[(j + n - 1) % n].count += to_before;
            if (has_after) {
                Span& next = given[(j + 1) % n];
                next.first -= arc.count - to_before;
                next.count += arc.count - to_before;
            }
            // At an open end, a neighbour that cannot take the points within the tolerance meets a
            // real short piece (a face's stub where a cut grazes a hole's rim): kept as its own
            // element. Between two elements the points are a rounded corner's, shared out.
            bool taken = has_before && has_after;
            std::vector<size_t> receivers;
            if (has_before) receivers.push_back((j + n - 1) % n);
            if (has_after && (receivers.empty() || receivers[0] != (j + 1) % n)) receivers.push_back((j + 1) % n);
            for (const size_t k : receivers) {
                given[k].shape = fit(given[k].shape.circle, given[k].first, given[k].count);
                taken = taken || fits_on_average(given[k]);
            }
            if (!taken) {
                ++j;
                continue;
            }
            spans = std::move(given);
            spans.erase(spans.begin() + long(j));
        }
    }

    const Points& points() const { return pts_; }

private:
    long fewest_points(const Shape& shape) const { return shape.circle ? options_.min_arc_points : options_.min_line_points; }
    double squared_sum(const Shape& shape, long first, long count) const {
        double sum = 0;
        for (long i = first; i < first + count; ++i) sum += std::pow(shape.distance(pts_[i]), 2);
        return sum;
    }
    // Noise-free points fit exactly: below a tenth of the tolerance, residuals count as that.
    double floor_sum(long count) const { return double(count) * std::pow(0.1 * tolerance_, 2); }
    bool fits_on_average(const Span& span) const {
        const Shape& shape = span.shape;
        if (!shape.ok) return false;
        if (shape.circle && (shape.radius > options_.max_arc_radius_mm ||
                             std::abs(swept_angle(pts_, span.first, span.count, shape.centre)) > 2 * kPi + 0.1))
            return false;
        return std::sqrt(squared_sum(shape, span.first, span.count) / double(span.count)) <= tolerance_;
    }

    Points pts_;
    const SectionFitOptions& options_;
    double tolerance_;
};

double median(std::vector<double> values) {
    if (values.empty()) return 0;
    std::nth_element(values.begin(), values.begin() + long(values.size() / 2), values.end());
    return values[values.size() / 2];
}

// Sums of points' coordinates and their products: the smallest eigenvalue of their scatter is the
// squared sum of their distances to the line that fits them best.
struct Moments {
    double n = 0, x = 0, y = 0, xx = 0, xy = 0, yy = 0;
    Moments operator-(const Moments& o) const { return {n - o.n, x - o.x, y - o.y, xx - o.xx, xy - o.xy, yy - o.yy}; }
    Moments plus(const cv::Vec2d& p) const { return {n + 1, x + p[0], y + p[1], xx + p[0] * p[0], xy + p[0] * p[1], yy + p[1] * p[1]}; }
    // The best line's direction, in radians in [-pi/2, pi/2].
    double line_angle() const {
        const double sxx = xx - x * x / n, sxy = xy - x * y / n, syy = yy - y * y / n;
        return 0.5 * std::atan2(2 * sxy, sxx - syy);
    }
    double line_squared_sum() const {
        if (n < 2) return 0;
        const double sxx = xx - x * x / n, sxy = xy - x * y / n, syy = yy - y * y / n;
        return std::max(0.0, 0.5 * (sxx + syy) - std::sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy));
    }
};

// A corner turns by more than a scan's waviness bends a side (a bump of 10 um over 1 mm: half a
// degree), and lines meeting at corners are only taken where they fit kCornerGain times as well as a
// line or circle: at a gain of 2, lines meeting at corners fitted the demo scan's bumps and its
// cuts at 6 heights read up to 22 % less noise (0.0062 mm at z = 1.5 mm, 0.0079 at a gain of 4).
constexpr double kSmallestCornerDeg = 5;
constexpr double kCornerGain = 4;
// The squared sums of a run's distances to lines meeting at corners (at its points, each line fitted
// to at least 3 points, the corner one of them), for the corners that fit best: one corner (two
// lines) and two corners (three lines). HUGE_VAL where the run is too short.
std::pair<double, double> corner_squared_sums(const Points& pts, long first, long count) {
    std::vector<Moments> prefix(size_t(count) + 1);  // prefix[k]: the run's first k points
    for (long k = 0; k < count; ++k) prefix[size_t(k) + 1] = prefix[size_t(k)].plus(pts[first + k]);
    const auto run = [&](long from, long to) { return prefix[size_t(to) + 1] - prefix[size_t(from)]; };
    const auto corner = [](const Moments& before, const Moments& after) {
        const double turn = std::abs(before.line_angle() - after.line_angle());
        return std::min(turn, kPi - turn) >= kSmallestCornerDeg * kPi / 180;
    };
    double one = HUGE_VAL, two = HUGE_VAL;
    for (long a = 2; a + 2 < count; ++a) {
        const Moments first = run(0, a), rest = run(a, count - 1);
        if (corner(first, rest)) one = std::min(one, first.line_squared_sum() + rest.line_squared_sum());
        for (long b = a + 2; b + 2 < count; ++b) {
            const Moments middle = run(a, b), last = run(b, count - 1);
            if (corner(first, middle) && corner(middle, last))
                two = std::min(two, first.line_squared_sum() + middle.line_squared_sum() + last.line_squared_sum());
        }
    }
    return {one, two};
}

// The noise of a polyline, point by point, from the short runs it lies in. A run spans at least
// window_mm and 7 points (a cut through a mesh has many points per facet, whose noise is shared by
// neighbours, so a run of a few points would see too little of it). It is read by a line, a circle
// where that fits at least twice as well (on a small hole or a fillet a line's residuals are the
// curve's sagitta, not noise: a 10 mm hole read as 0.17 mm), or lines meeting at one or two corners
// (turning by kSmallestCornerDeg or more) where those fit kCornerGain times as well (a run across a
// polygon's corners). A point's noise is the median of its runs', leaving out those above 2 x its
// lowest (runs across more corners than that). Over runs alone, a polygon whose sides are shorter
// than the runs read its corners as noise: a 12-gon of r 10 mm cut at its corners and the middles of
// its sides (24 points), every run of 9 points taking in 4 corners, read 0.23 mm, and one circle
// passed for it within 5 x that. The demo scan's cuts at 15 heights read 0.0058-0.0079 mm (0.0062-0.0084
// over runs alone).
// The points' noises are appended to `rms` (pooled over several polylines by the caller).
void window_noises(const Points& pts, double window_mm, std::vector<double>& rms) {
    constexpr long kFewestRunPoints = 7;
    const long n = long(pts.size());
    std::vector<std::vector<double>> runs_of(static_cast<size_t>(n));  // the noises of the runs each point lies in
    for (long i = 0; i < n;) {
        long count = 1;
        double length = 0;
        while ((count < kFewestRunPoints || length < window_mm) && count < n && (pts.closed || i + count < n)) {
            length += cv::norm(pts[i + count] - pts[i + count - 1]);
            ++count;
        }
        if (count < kFewestRunPoints || (!pts.closed && i + count > n)) break;
        double line_rms = HUGE_VAL, circle_rms = HUGE_VAL;
        for (const Shape& shape : {fit_line(pts, i, count), fit_circle(pts, i, count)}) {
            if (!shape.ok) continue;
            double sum = 0;
            for (long k = i; k < i + count; ++k) sum += std::pow(shape.distance(pts[k]), 2);
            (shape.circle ? circle_rms : line_rms) = std::sqrt(sum / double(count - (shape.circle ? 3 : 2)));
        }
        double best = circle_rms < 0.5 * line_rms ? circle_rms : line_rms;
        const auto [one_corner, two_corners] = corner_squared_sums(pts, i, count);
        for (const auto& [sum, parameters] : {std::pair{one_corner, 4L}, std::pair{two_corners, 6L}})
            if (count > parameters && std::sqrt(sum / double(count - parameters)) < best / kCornerGain)
                best = std::sqrt(sum / double(count - parameters));
        if (best < HUGE_VAL)
            for (long k = i; k < i + count; ++k) runs_of[size_t(k % n)].push_back(best);
        i += std::max<long>(1, count / 3);
    }
    for (std::vector<double>& values : runs_of) {
        if (values.empty()) continue;
        const double lowest = *std::min_element(values.begin(), values.end());
        values.erase(std::remove_if(values.begin(), values.end(), [&](double v) { return v > 2 * lowest; }), values.end());
        rms.push_back(median(values));
    }
}

double estimate_noise(const Points& pts, double window_mm) {
    std::vector<double> rms;
    window_noises(pts, window_mm, rms);
    return median(rms);
}

cv::Vec2d perpendicular_foot(const Shape& line, const cv::Vec2d& p) {
    return line.point + line.direction * (p - line.point).dot(line.direction);
}

// Whether two fitted neighbours can meet tangentially within the tolerance: a line and a circle
// whose distance differs from the radius by at most half of it, two circles touching (inside or
// outside) within half of it. The angle at an intersection is no test: a line cutting a circle
// 5 um inside its tangent point already meets it at 3 degrees.
bool can_be_tangent(const Shape& a, const Shape& b, double tolerance) {
    if (!a.circle && !b.circle) return false;
    if (a.circle != b.circle) {
        const Shape& line = a.circle ? b : a;
        const Shape& circle = a.circle ? a : b;
        return std::abs(line.distance(circle.centre) - circle.radius) <= 0.5 * tolerance;
    }
    const double d = cv::norm(a.centre - b.centre);
    return std::min(std::abs(d - (a.radius + b.radius)), std::abs(d - std::abs(a.radius - b.radius))) <= 0.5 * tolerance;
}

// The joint of two fitted elements near `near`: the tangent point of tangent neighbours, else the
// line-line intersection or the circle intersection nearest to `near`.
cv::Vec2d joint(const Shape& a, const Shape& b, const cv::Vec2d& near, bool tangent) {
    if (!a.circle && !b.circle) {
        const double cross = a.direction[0] * b.direction[1] - a.direction[1] * b.direction[0];
        if (std::abs(cross) < 1e-9) return perpendicular_foot(a, near);
        const cv::Vec2d d = b.point - a.point;
        const double t = (d[0] * b.direction[1] - d[1] * b.direction[0]) / cross;
        return a.point + t * a.direction;
    }
    if (a.circle != b.circle) {
        const Shape& line = a.circle ? b : a;
        const Shape& circle = a.circle ? a : b;
        const cv::Vec2d foot = perpendicular_foot(line, circle.centre);
        const double gap = cv::norm(foot - circle.centre);
        if (tangent || gap >= circle.radius) {
            // Halfway between the line's and the circle's point nearest to each other.
            const cv::Vec2d on_circle = circle.centre + circle.radius * (foot - circle.centre) / std::max(gap, 1e-12);
            return 0.5 * (foot + on_circle);
        }
        const double half = std::sqrt(circle.radius * circle.radius - gap * gap);
        const cv::Vec2d p1 = foot + half * line.direction, p2 = foot - half * line.direction;
        return cv::norm(p1 - near) < cv::norm(p2 - near) ? p1 : p2;
    }
    const cv::Vec2d d = b.centre - a.centre;
    const double distance = cv::norm(d);
    if (distance < 1e-12) return a.centre + a.radius * (near - a.centre) / std::max(cv::norm(near - a.centre), 1e-12);
    const cv::Vec2d u = d / distance;
    const double along = (distance * distance + a.radius * a.radius - b.radius * b.radius) / (2 * distance);
    const double h2 = a.radius * a.radius - along * along;
    if (tangent || h2 <= 0) {
        // On the line of the centres, on the side of the touching point.
        const double sign = (near - a.centre).dot(u) >= 0 ? 1.0 : -1.0;
        return a.centre + u * sign * a.radius;
    }
    const cv::Vec2d base = a.centre + along * u, normal(-u[1], u[0]);
    const cv::Vec2d p1 = base + std::sqrt(h2) * normal, p2 = base - std::sqrt(h2) * normal;
    return cv::norm(p1 - near) < cv::norm(p2 - near) ? p1 : p2;
}

// Unit direction of travel of an element at point p.
cv::Vec2d travel_direction(const SectionElement& e, const cv::Vec2d& p) {
    if (e.kind == SectionElementKind::Line) {
        const cv::Vec2d d = e.end - e.start;
        return d / std::max(cv::norm(d), 1e-12);
    }
    const cv::Vec2d r = p - e.centre;
    const cv::Vec2d t = e.counter_clockwise ? cv::Vec2d(-r[1], r[0]) : cv::Vec2d(r[1], -r[0]);
    return t / std::max(cv::norm(t), 1e-12);
}

double angle_between_deg(const cv::Vec2d& a, const cv::Vec2d& b) {
    return std::atan2(std::abs(a[0] * b[1] - a[1] * b[0]), a.dot(b)) * 180 / kPi;
}

void find_constraints(SectionFit& fit, const Points& pts, const SectionFitOptions& options) {
    const auto& elements = fit.elements;
    const double snap = options.snap_angle_deg;
    // Largest distance of an element's points to the line through their centroid along `direction`.
    const auto line_max = [&](const SectionElement& e, const cv::Vec2d& direction) {
        cv::Vec2d mean(0, 0);
        for (long i = e.first_point; i < e.first_point + e.point_count; ++i) mean += pts[i];
        mean /= double(e.point_count);
        Shape line;
        line.point = mean;
        line.direction = direction;
        return max_distance(line, pts, e.first_point, e.point_count);
    };
    const auto direction_of = [](const SectionElement& e) {
        const cv::Vec2d d = e.end - e.start;
        return d / std::max(cv::norm(d), 1e-12);
    };
    for (size_t i = 0; i < elements.size(); ++i) {
        if (elements[i].kind != SectionElementKind::Line) continue;
        const cv::Vec2d d = direction_of(elements[i]);
        for (const auto& [kind, axis] : {std::pair{SectionConstraintKind::Horizontal, cv::Vec2d(1, 0)},
                                         std::pair{SectionConstraintKind::Vertical, cv::Vec2d(0, 1)}}) {
            if (std::min(angle_between_deg(d, axis), angle_between_deg(d, -axis)) > snap) continue;
            const double worst = line_max(elements[i], axis);
            if (worst <= fit.tolerance_mm) fit.constraints.push_back({kind, int(i), -1, worst});
        }
    }
    for (size_t i = 0; i < elements.size(); ++i) {
        for (size_t j = i + 1; j < elements.size(); ++j) {
            const SectionElement &a = elements[i], &b = elements[j];
            if (a.kind == SectionElementKind::Line && b.kind == SectionElementKind::Line) {
                const cv::Vec2d da = direction_of(a), db = direction_of(b);
                const cv::Vec2d db_turned(-db[1], db[0]);
                for (const auto& [kind, other] : {std::pair{SectionConstraintKind::Parallel, db},
                                                  std::pair{SectionConstraintKind::Perpendicular, db_turned}}) {
                    const double angle = std::min(angle_between_deg(da, other), angle_between_deg(da, -other));
                    if (angle > snap) continue;
                    // The common direction, weighted by length; the second line is turned back by 90 degrees.
                    const cv::Vec2d aligned = da.dot(other) >= 0 ? other : -other;
                    const double la = cv::norm(a.end - a.start), lb = cv::norm(b.end - b.start);
                    cv::Vec2d common = la * da + lb * aligned;
                    common /= cv::norm(common);
                    const cv::Vec2d for_b = kind == SectionConstraintKind::Parallel ? common : cv::Vec2d(common[1], -common[0]);
                    const double worst = std::max(line_max(a, common), line_max(b, for_b));
                    if (worst <= fit.tolerance_mm) fit.constraints.push_back({kind, int(i), int(j), worst});
                }
            } else if (a.kind != SectionElementKind::Line && b.kind != SectionElementKind::Line) {
                const double mean = 0.5 * (a.radius_mm + b.radius_mm);
                if (std::abs(a.radius_mm - b.radius_mm) > fit.tolerance_mm) continue;
                double worst = 0;
                for (const SectionElement* e : {&a, &b}) {
                    Shape circle;
                    circle.circle = true;
                    circle.centre = e->centre;
                    circle.radius = mean;
                    worst = std::max(worst, max_distance(circle, pts, e->first_point, e->point_count));
                }
                if (worst <= fit.tolerance_mm) fit.constraints.push_back({SectionConstraintKind::EqualRadius, int(i), int(j), worst});
            }
        }
    }
}

}  // namespace

std::string to_string(SectionElementKind kind) {
    switch (kind) {
        case SectionElementKind::Line: return "line";
        case SectionElementKind::Arc: return "arc";
        case SectionElementKind::Circle: return "circle";
    }
    return "?";
}

std::string to_string(SectionConstraintKind kind) {
    switch (kind) {
        case SectionConstraintKind::Horizontal: return "horizontal";
        case SectionConstraintKind::Vertical: return "vertical";
        case SectionConstraintKind::Parallel: return "parallel";
        case SectionConstraintKind::Perpendicular: return "perpendicular";
        case SectionConstraintKind::EqualRadius: return "equal radius";
    }
    return "?";
}

namespace {

// Signed distance of p from `shape`: left of a line (along its direction) positive, outside a
// circle positive.
double signed_distance(const Shape& shape, const cv::Vec2d& p) {
    if (shape.circle) return cv::norm(p - shape.centre) - shape.radius;
    const cv::Vec2d d = p - shape.point;
    return shape.direction[0] * d[1] - shape.direction[1] * d[0];
}

// How much a least-squares polynomial of the offsets d (weighted by w) in the height z changes
// between the heights given, and the standard error of that change from the scatter about it.
// A straight trend (a drafted wall, a cone, a sphere off its equator), or a quadratic one (a
// sphere at its equator) from 5 heights on. sigma is 0 where the fit leaves no residual degree
// of freedom (2 heights).
struct Trend {
    double change = 0, sigma = 0;
};
Trend offset_trend(const std::vector<double>& z, const std::vector<double>& d, const std::vector<double>& w) {
    const int m = int(z.size()), terms = m >= 5 ? 3 : 2;
    cv::Mat normal = cv::Mat::zeros(terms, terms, CV_64F), rhs = cv::Mat::zeros(terms, 1, CV_64F);
    const auto basis = [&](double height) {
        cv::Mat row(terms, 1, CV_64F);
        for (int k = 0; k < terms; ++k) row.at<double>(k) = std::pow(height, k);
        return row;
    };
    for (int i = 0; i < m; ++i) {
        const cv::Mat row = basis(z[size_t(i)]);
        normal += w[size_t(i)] * row * row.t();
        rhs += w[size_t(i)] * d[size_t(i)] * row;
    }
    cv::Mat inverse;
    if (cv::invert(normal, inverse, cv::DECOMP_SVD) == 0) return {};
    const cv::Mat coefficients = inverse * rhs;
    double rss = 0, highest = -HUGE_VAL, lowest = HUGE_VAL;
    size_t at_high = 0, at_low = 0;
    for (size_t i = 0; i < size_t(m); ++i) {
        const double value = basis(z[i]).dot(coefficients);
        rss += w[i] * std::pow(d[i] - value, 2);
        if (value > highest) highest = value, at_high = i;
        if (value < lowest) lowest = value, at_low = i;
    }
    // change = g . coefficients, g the basis at its highest point minus at its lowest.
    const cv::Mat g = basis(z[at_high]) - basis(z[at_low]);
    Trend trend;
    trend.change = highest - lowest;
    if (m > terms) trend.sigma = std::sqrt(rss / double(m - terms) * g.dot(inverse * g));
    return trend;
}

// An element's Band: the points of the parallel cuts it is refitted with, how many cuts (heights)
// gave them, and why none are used when cuts followed it but trend with their height.
struct Band {
    std::vector<cv::Vec2d> points;
    int cuts = 0;
    std::string note;
};

// The points of the parallel cuts within the tolerance of `shape` and between the extremes of
// its own points pts[first, first + count) (along a line, or in angle around a circle's centre;
// a whole circle takes all within the tolerance), unless their mean offsets from `shape` trend
// with the cut's height (its own cut at height 0 included): averaging cuts of a drafted wall, a
// cone or a sphere would give a section that is at none of their heights.
Band band_of(const Shape& shape, const Points& pts, long first, long count, const std::vector<ParallelCut>& parallel_cuts,
             double tolerance, bool whole_circle, double trend_fraction) {
    Band band;
    if (parallel_cuts.empty()) return band;
    // Lines: the position along the direction. Arcs: the angle from the middle point, in (-pi, pi].
    const cv::Vec2d middle = shape.circle ? pts[first + count / 2] - shape.centre : cv::Vec2d();
    const auto position = [&](const cv::Vec2d& p) {
        if (!shape.circle) return (p - shape.point).dot(shape.direction);
        const cv::Vec2d r = p - shape.centre;
        return std::atan2(middle[0] * r[1] - middle[1] * r[0], middle.dot(r));
    };
    double low = HUGE_VAL, high = -HUGE_VAL;
    // The element's own cut (height 0): the sum of its points' offsets and their number.
    std::map<double, std::pair<double, double>> offsets;
    std::set<double> heights;  // of the cuts that follow it
    for (long i = first; i < first + count; ++i) {
        low = std::min(low, position(pts[i]));
        high = std::max(high, position(pts[i]));
        offsets[0].first += signed_distance(shape, pts[i]);
        offsets[0].second += 1;
    }
    // A cut is used only where it follows the element: of its points near it (within 10 x the
    // tolerance, in its range), 90 % within the tolerance. A cut of another profile (where the part
    // is not prismatic) may cross the element, and its few points on it would pull the fit away.
    std::vector<std::pair<double, std::vector<cv::Vec2d>>> following;  // each following cut's height and points
    std::set<double> all_heights{0.0};
    for (const ParallelCut& cut : parallel_cuts) {
        all_heights.insert(cut.offset_mm);
        std::vector<cv::Vec2d> within;
        size_t candidates = 0;
        for (const cv::Vec2d& p : cut.points) {
            if (!std::isfinite(p[0]) || !std::isfinite(p[1])) continue;
            const double distance = shape.distance(p), t = position(p);
            if (distance > 10 * tolerance || !(whole_circle || (t >= low && t <= high))) continue;
            ++candidates;
            if (distance <= tolerance) within.push_back(p);
        }
        if (within.empty() || double(within.size()) < 0.9 * double(candidates)) continue;
        following.emplace_back(cut.offset_mm, std::move(within));
        heights.insert(cut.offset_mm);
    }
    // The trend of the mean offsets of the cuts at `used` heights (the element's own cut, 0, always).
    const auto trend_of = [&](const std::set<double>& used) {
        std::map<double, std::pair<double, double>> sums{{0.0, offsets[0.0]}};
        for (const auto& [height, within] : following)
            if (used.count(height))
                for (const cv::Vec2d& p : within) {
                    sums[height].first += signed_distance(shape, p);
                    sums[height].second += 1;
                }
        std::vector<double> z, d, w;
        for (const auto& [height, sum] : sums) {
            z.push_back(height);
            d.push_back(sum.first / sum.second);
            w.push_back(sum.second);
        }
        return z.size() < 2 ? Trend{} : offset_trend(z, d, w);
    };
    const auto significant = [&](const Trend& trend) {
        return trend.change > 3 * trend.sigma && trend.change > trend_fraction * tolerance;
    };
    const auto keep = [&](const std::set<double>& used) {
        band.cuts = int(used.size());
        for (const auto& [height, within] : following)
            if (used.count(height)) band.points.insert(band.points.end(), within.begin(), within.end());
        return band;
    };
    Trend trend = trend_of(heights);
    if (!significant(trend)) return keep(heights);
    // A cut next to a height that does not follow the element, or at the band's end, may be where the
    // face ends (the block's top, 0.38 mm above such a cut on the demo scan), which a mesh rounds over a
    // sample spacing or two: that cut lay 0.015-0.017 mm inside the wall the other cuts followed within
    // 0.003 mm, and alone made a trend of 0.0100 mm (limit 0.0079-0.0086, 3 standard errors 0.0096-0.0102)
    // at z = 21 and 22.5 mm. A cut with fewer than half the points of the median one grazes the edge
    // itself (4 points of 230 at the top face's height). Such cuts are left out when the rest then show
    // no trend; where they still do (a sphere, a cone, a draft: every cut drifts), the element keeps to
    // its own cut.
    std::vector<size_t> sizes;
    for (const auto& [height, within] : following) sizes.push_back(within.size());
    std::nth_element(sizes.begin(), sizes.begin() + long(sizes.size() / 2), sizes.end());
    const size_t median_size = sizes.empty() ? 0 : sizes[sizes.size() / 2];
    std::set<double> full = heights;  // the following heights not grazing an edge
    for (const auto& [height, within] : following)
        if (2 * within.size() < median_size) full.erase(height);
    std::set<double> inner;
    for (const double height : full) {
        const auto at = all_heights.find(height);
        const bool below_ends = at == all_heights.begin() || (*std::prev(at) != 0.0 && !full.count(*std::prev(at)));
        const bool above_ends = std::next(at) == all_heights.end() || (*std::next(at) != 0.0 && !full.count(*std::next(at)));
        if (!below_ends && !above_ends) inner.insert(height);
    }
    // Only a few of many: the rest must still be most of them and enough for a quadratic trend (5
    // heights with its own). A sphere 0.5 mm off its equator is followed by 5 cuts, its 2 outer ones
    // next to cuts that no longer follow it; its 3 inner ones alone show no trend.
    if (inner.size() < heights.size() && inner.size() + 1 >= 5 && 3 * inner.size() >= 2 * heights.size() &&
        !significant(trend_of(inner)))
        return keep(inner);
    char text[320];
    std::snprintf(text, sizeof text,
                  "fitted to its own cut only: the %d parallel cuts that follow it (at %+.2f to %+.2f mm) lie off it by amounts "
                  "that change by %.4f mm with their height (standard error %.4f mm, tolerance %.4f mm): the part is not "
                  "prismatic here",
                  int(heights.size()), *heights.begin(), *heights.rbegin(), trend.change, trend.sigma, tolerance);
    return {{}, 0, text};
}

// `shape` fitted again to pts[first, first + count) and the points of its band.
Shape refit_with_band(const Shape& shape, const Points& pts, long first, long count, const Band& band) {
    if (band.points.empty()) return shape;
    std::vector<cv::Vec2d> all = band.points;
    for (long i = first; i < first + count; ++i) all.push_back(pts[i]);
    const Points joined{all, false};
    Shape refitted = shape.circle ? fit_circle(joined, 0, long(all.size())) : fit_line(joined, 0, long(all.size()));
    if (!refitted.ok) return shape;
    // fit_line orients along the joined points' first and last: keep the element's direction.
    if (!refitted.circle && refitted.direction.dot(shape.direction) < 0) refitted.direction = -refitted.direction;
    return refitted;
}

// The standard error of `shape`'s direction (a line, degrees) or radius (a circle, mm) fitted to
// pts[first, first + count) and the points of its band, by the block jackknife: the
// points cut into runs of about 1 mm along the element (at most 40 runs), the fit repeated
// without each run. A scan's deviations are shared over about 1 mm (its bumps, a facet), so
// single points are not independent samples; runs of that length nearly are. NaN for fewer than
// 3 runs.
double jackknife_sigma(const Shape& shape, const Points& pts, long first, long count, const Band& band) {
    std::vector<cv::Vec2d> points = band.points;
    for (long i = first; i < first + count; ++i) points.push_back(pts[i]);
    // Position along the element: along the line, or the arc length from the middle point.
    const cv::Vec2d middle = shape.circle ? pts[first + count / 2] - shape.centre : cv::Vec2d();
    std::vector<double> position;
    double low = HUGE_VAL, high = -HUGE_VAL;
    for (const cv::Vec2d& p : points) {
        const cv::Vec2d r = p - shape.centre;
        position.push_back(shape.circle ? shape.radius * std::atan2(middle[0] * r[1] - middle[1] * r[0], middle.dot(r))
                                        : (p - shape.point).dot(shape.direction));
        low = std::min(low, position.back());
        high = std::max(high, position.back());
    }
    const double run = std::max(1.0, (high - low) / 40);
    const int runs = int(std::floor((high - low) / run)) + 1;
    std::vector<double> values;
    for (int k = 0; k < runs; ++k) {
        std::vector<cv::Vec2d> others;
        for (size_t i = 0; i < points.size(); ++i)
            if (std::min(int((position[i] - low) / run), runs - 1) != k) others.push_back(points[i]);
        if (others.size() == points.size()) continue;  // an empty run
        const Points rest{others, false};
        const Shape fit = shape.circle ? fit_circle(rest, 0, long(others.size())) : fit_line(rest, 0, long(others.size()));
        if (!fit.ok) return std::nan("");
        // fit_line orients a fit along its first and last points: turned the element's way.
        const cv::Vec2d d = fit.direction.dot(shape.direction) < 0 ? -fit.direction : fit.direction;
        values.push_back(shape.circle ? fit.radius
                                      : std::asin(std::clamp(shape.direction[0] * d[1] - shape.direction[1] * d[0], -1.0, 1.0)) * 180 / kPi);
    }
    if (values.size() < 3) return std::nan("");
    double mean = 0, spread = 0;
    for (const double v : values) mean += v / double(values.size());
    for (const double v : values) spread += (v - mean) * (v - mean);
    return std::sqrt(spread * double(values.size() - 1) / double(values.size()));
}

// A fillet: an arc tangent to a line before it and a line after it, fitted as one curve by least
// squares. Each line is n . p = c (n = (cos t, sin t)); the centre lies r from both lines, on the
// side it started on, so the tangency holds exactly; each point is measured to the piece it lies
// against (before the first tangent point: the first line; after the second: the second line;
// between: the arc), so where the arc ends is found by the fit instead of by a split between
// points. Fitting the arc alone, its radius follows where its ends were cut: a point of a line
// counted as the arc's flattens it, an arc point counted as a line's bends it.
class FilletFit {
public:
    FilletFit(const Shape& before, const Shape& arc, const Shape& after, std::vector<cv::Vec2d> points)
        : points_(std::move(points)) {
        for (int k = 0; k < 2; ++k) {
            const Shape& line = k == 0 ? before : after;
            const cv::Vec2d n(-line.direction[1], line.direction[0]);
            angle_[k] = std::atan2(n[1], n[0]);
            offset_[k] = n.dot(line.point);
            side_[k] = n.dot(arc.centre) - offset_[k] >= 0 ? 1.0 : -1.0;
        }
        radius_ = arc.radius;
    }

    // Gauss-Newton on (angle, offset) of both lines and the radius. False when the lines are
    // (nearly) parallel or the fit does not settle.
    bool solve() {
        double parameters[5] = {angle_[0], offset_[0], angle_[1], offset_[1], radius_};
        for (int iteration = 0; iteration < 30; ++iteration) {
            std::vector<double> residual;
            if (!residuals(parameters, residual, assignment_, true)) return false;
            cv::Mat jacobian(int(residual.size()), 5, CV_64F);
            for (int k = 0; k < 5; ++k) {
                double moved[5];
                std::copy(parameters, parameters + 5, moved);
                const double step = 1e-7 * std::max(1.0, std::abs(parameters[k]));
                moved[k] += step;
                std::vector<double> shifted;
                if (!residuals(moved, shifted, assignment_, false)) return false;
                for (size_t i = 0; i < residual.size(); ++i) jacobian.at<double>(int(i), k) = (shifted[i] - residual[i]) / step;
            }
            cv::Mat delta;
            if (!cv::solve(jacobian, -cv::Mat(residual), delta, cv::DECOMP_SVD)) return false;
            double size = 0;
            for (int k = 0; k < 5; ++k) {
                parameters[k] += delta.at<double>(k);
                size = std::max(size, std::abs(delta.at<double>(k)));
            }
            if (size < 1e-11) break;
        }
        std::vector<double> residual;
        if (!residuals(parameters, residual, assignment_, true)) return false;
        angle_[0] = parameters[0], offset_[0] = parameters[1], angle_[1] = parameters[2], offset_[1] = parameters[3];
        radius_ = parameters[4];
        return radius_ > 0;
    }

    double max_residual() const {
        double parameters[5] = {angle_[0], offset_[0], angle_[1], offset_[1], radius_};
        std::vector<double> residual;
        std::vector<int> assignment;
        residuals(parameters, residual, assignment, true);
        double worst = 0;
        for (double r : residual) worst = std::max(worst, std::abs(r));
        return worst;
    }
    // Points on the arc's piece (between its tangent points).
    int arc_points() const { return int(std::count(assignment_.begin(), assignment_.end(), 1)); }

    // The fitted shapes, the lines oriented like `before` and `after`.
    void shapes(Shape& before, Shape& arc, Shape& after) const {
        const Geometry g = geometry(angle_[0], offset_[0], angle_[1], offset_[1], radius_);
        before.point = g.touch[0];
        before.direction = along(0, before.direction);
        after.point = g.touch[1];
        after.direction = along(1, after.direction);
        arc.centre = g.centre;
        arc.radius = radius_;
    }

private:
    struct Geometry {
        cv::Vec2d normal[2], centre, touch[2];
        bool ok = false;
    };
    Geometry geometry(double angle0, double offset0, double angle1, double offset1, double radius) const {
        Geometry g;
        g.normal[0] = {std::cos(angle0), std::sin(angle0)};
        g.normal[1] = {std::cos(angle1), std::sin(angle1)};
        const double det = g.normal[0][0] * g.normal[1][1] - g.normal[0][1] * g.normal[1][0];
        if (std::abs(det) < 1e-6) return g;
        const double b0 = offset0 + side_[0] * radius, b1 = offset1 + side_[1] * radius;
        g.centre = {(b0 * g.normal[1][1] - g.normal[0][1] * b1) / det, (g.normal[0][0] * b1 - b0 * g.normal[1][0]) / det};
        for (int k = 0; k < 2; ++k) g.touch[k] = g.centre - side_[k] * radius * g.normal[k];
        g.ok = true;
        return g;
    }
    cv::Vec2d along(int k, const cv::Vec2d& like) const {
        const cv::Vec2d d(-std::sin(angle_[k]), std::cos(angle_[k]));
        return d.dot(like) >= 0 ? d : -d;
    }
    // Signed distances of the points to their pieces (assignment: 0 the first line, 1 the arc, 2 the
    // second line), made anew when `assign`, else kept (for the Jacobian).
    bool residuals(const double* q, std::vector<double>& out, std::vector<int>& assignment, bool assign) const {
        const Geometry g = geometry(q[0], q[1], q[2], q[3], q[4]);
        if (!g.ok || !(q[4] > 0)) return false;
        // Travel directions: the first line runs into the arc, the second away from it.
        const cv::Vec2d into = g.touch[0] - g.touch[1], out_of = g.touch[1] - g.touch[0];
        const cv::Vec2d d0 = cv::Vec2d(-g.normal[0][1], g.normal[0][0]) * (cv::Vec2d(-g.normal[0][1], g.normal[0][0]).dot(into) >= 0 ? -1.0 : 1.0);
        const cv::Vec2d d1 = cv::Vec2d(-g.normal[1][1], g.normal[1][0]) * (cv::Vec2d(-g.normal[1][1], g.normal[1][0]).dot(out_of) >= 0 ? 1.0 : -1.0);
        out.resize(points_.size());
        if (assign) assignment.assign(points_.size(), 1);
        for (size_t i = 0; i < points_.size(); ++i) {
            const cv::Vec2d& p = points_[i];
            int piece = 1;
            if (!assign) {
                piece = assignment[i];
            } else {
                const bool first = (p - g.touch[0]).dot(d0) < 0, second = (p - g.touch[1]).dot(d1) > 0;
                if (first && second)
                    piece = std::abs(g.normal[0].dot(p) - q[1]) <= std::abs(g.normal[1].dot(p) - q[3]) ? 0 : 2;
                else
                    piece = first ? 0 : second ? 2 : 1;
                assignment[i] = piece;
            }
            out[i] = piece == 0 ? g.normal[0].dot(p) - q[1] : piece == 2 ? g.normal[1].dot(p) - q[3] : cv::norm(p - g.centre) - q[4];
        }
        return true;
    }

    std::vector<cv::Vec2d> points_;
    double angle_[2] = {0, 0}, offset_[2] = {0, 0}, side_[2] = {1, 1}, radius_ = 0;
    std::vector<int> assignment_;
};

void check_tolerance(const SectionFitOptions& options) {
    if (options.tolerance_mm < 0 || !std::isfinite(options.tolerance_mm))
        throw Error("tolerance_mm", "must be 0 (from the noise) or positive");
    if (options.scan_noise_mm < 0 || !std::isfinite(options.scan_noise_mm))
        throw Error("scan_noise_mm", "must be 0 (unknown) or positive");
    if (!(options.loop_noise_limit_mm >= 0) || !std::isfinite(options.loop_noise_limit_mm))
        throw Error("loop_noise_limit_mm", "must be 0 or positive");
    if (!(options.max_bridged_gap_mm >= 0) || !std::isfinite(options.max_bridged_gap_mm))
        throw Error("max_bridged_gap_mm", "must be 0 (no chain bridged) or positive");
    if (!(options.band_trend_fraction >= 0) || !std::isfinite(options.band_trend_fraction))
        throw Error("band_trend_fraction", "must be 0 or positive");
}

void check_cuts(const std::vector<ParallelCut>& parallel_cuts) {
    for (const ParallelCut& cut : parallel_cuts)
        if (!std::isfinite(cut.offset_mm)) throw Error("parallel_cuts", "a cut's offset_mm is not finite");
}

// The polyline without repeated points (closed: nor the first point repeated at the end).
std::vector<cv::Vec2d> distinct_points(const std::vector<cv::Vec2d>& input, bool closed) {
    std::vector<cv::Vec2d> polyline;
    for (const cv::Vec2d& p : input) {
        if (!std::isfinite(p[0]) || !std::isfinite(p[1])) throw Error("polyline", "has a non-finite point");
        if (polyline.empty() || cv::norm(p - polyline.back()) > 1e-9) polyline.push_back(p);
    }
    if (closed && polyline.size() > 1 && cv::norm(polyline.front() - polyline.back()) <= 1e-9) polyline.pop_back();
    return polyline;
}

double tolerance_for(double noise_mm, const SectionFitOptions& options) {
    return options.tolerance_mm > 0 ? options.tolerance_mm : std::max(options.min_tolerance_mm, 5 * noise_mm);
}

// Refuses an arc or circle whose radius its points do not tell within the tolerance: its
// standard error above the tolerance and above 1 % of the radius (a gently curved side may know
// its large radius only to a few mm and still follow its points). A sliver of a hole's wall
// (43 points of the demo scan's hole at z = 12 mm: 4.85 mm +- 1.77 mm) is no measured hole.
bool radius_unknown(const Shape& shape, double sigma, double tolerance) {
    return shape.circle && sigma > tolerance && sigma > 0.01 * shape.radius;
}

void check_radius_known(const Shape& shape, double sigma, double tolerance, long first, long number, long n) {
    if (!radius_unknown(shape, sigma, tolerance)) return;
    char text[256];
    std::snprintf(text, sizeof text,
                  "the arc fitted to points %ld to %ld (radius %.3f mm) has a radius standard error of %.3f mm, above the "
                  "tolerance of %.4f mm: too short a piece of a curve to tell its size",
                  ((first % n) + n) % n, ((first + number - 1) % n + n) % n, shape.radius, sigma, tolerance);
    throw Error("polyline", text);
}

// Fits a polyline of distinct points with the tolerance that `noise_mm` (the polyline's own or
// the whole section's) and the options give.
// `corner_cuts` are the parallel cuts' corners (corners_of), for arcs and circles: a faceted cut's
// points between them lie inside the curve. Lines take every point of the cuts.
SectionFit fit_points(const std::vector<cv::Vec2d>& polyline, bool closed, const SectionFitOptions& options,
                      const std::vector<ParallelCut>& parallel_cuts, const std::vector<ParallelCut>& corner_cuts,
                      double noise_mm) {
    if (polyline.size() < 4) throw Error("polyline", "needs at least 4 distinct points, has " + std::to_string(polyline.size()));
    SectionFit result;
    result.closed = closed;
    const Points pts{polyline, closed};
    result.noise_mm = noise_mm;
    result.tolerance_mm = tolerance_for(noise_mm, options);
    SectionFitter fitter(polyline, closed, options, result.tolerance_mm);
    const long n = long(polyline.size());

    // The whole closed polyline as one circle.
    const auto whole_circle = [&](Shape whole) {
        const Band band = band_of(whole, pts, 0, n, corner_cuts, result.tolerance_mm, true, options.band_trend_fraction);
        whole = refit_with_band(whole, pts, 0, n, band);
        SectionElement circle;
        circle.band_cuts = band.cuts;
        circle.band_note = band.note;
        circle.kind = SectionElementKind::Circle;
        circle.centre = whole.centre;
        circle.radius_mm = whole.radius;
        circle.start = circle.end = whole.centre + cv::Vec2d(whole.radius, 0);
        circle.counter_clockwise = swept_angle(pts, 0, n, whole.centre) > 0;
        circle.point_count = int(n);
        double sum = 0;
        for (long i = 0; i < n; ++i) {
            const double d = whole.distance(pts[i]);
            sum += d * d;
            circle.max_mm = std::max(circle.max_mm, d);
        }
        circle.rms_mm = std::sqrt(sum / double(n));
        circle.radius_sigma_mm = jackknife_sigma(whole, pts, 0, n, band);
        check_radius_known(whole, circle.radius_sigma_mm, result.tolerance_mm, 0, n, n);
        result.elements.push_back(circle);
        return result;
    };
    const Shape whole = fit_circle(pts, 0, n);
    if (closed && fitter.fits(whole, 0, n)) return whole_circle(whole);

    std::vector<Span> spans = fitter.cover(0);
    if (closed && spans.size() > 1) {  // start again at a real joint, at an element long enough to grow there
        size_t j = 1;  // not a short side (short_side): no element grows from its first point
        while (j < spans.size() && spans[j].count < options.min_line_points) ++j;
        if (j < spans.size()) spans = fitter.cover(spans[j].first);
    }
    fitter.refine(spans);
    fitter.merge(spans);
    fitter.refine(spans);
    // An arc whose points cannot tell its radius shows no curve: where a line holds the same points
    // within the tolerance (the terms every element is held to), it is that line, which may then
    // join its neighbours (a coarse mesh's chamfer, bowed 35 um and its corner rounded, grown as
    // one arc of radius 419 +- 88 mm). Not a fillet: its radius comes from its tangent lines too.
    const auto lines_for_arcs_of_unknown_radius = [&](std::vector<Span>& spans) {
        const size_t count = spans.size();
        for (size_t j = 0; j < count; ++j) {
            Span& span = spans[j];
            if (!span.shape.circle) continue;
            const bool tangent_before = (closed || j > 0) && count > 1 &&
                                        can_be_tangent(spans[(j + count - 1) % count].shape, span.shape, result.tolerance_mm);
            const bool tangent_after = (closed || j + 1 < count) && count > 1 &&
                                       can_be_tangent(span.shape, spans[(j + 1) % count].shape, result.tolerance_mm);
            if (tangent_before && tangent_after) continue;
            if (!radius_unknown(span.shape, jackknife_sigma(span.shape, pts, span.first, span.count, Band{}), result.tolerance_mm))
                continue;
            const Shape line = fitter.fit(false, span.first, span.count);
            if (line.ok && rms_of(line, pts, span.first, span.count) <= result.tolerance_mm) span.shape = line;
        }
    };
    for (size_t before = 0; before != spans.size();) {  // each pass can make more of the other's cases
        before = spans.size();
        fitter.drop_rounded_corners(spans);
        lines_for_arcs_of_unknown_radius(spans);
        fitter.drop_unfounded_splits(spans);
        fitter.refine(spans);
    }
    // A closed cut that ends as one arc all round is a circle: a hole's cut in a scan has bumps
    // beyond the tolerance (so the circle was not taken at once above), which the joining then
    // found unfounded. Held to the same terms as every element: its RMS within the tolerance.
    // Not a circle, it would be an arc from the first point round to the last with the closing gap
    // left out of the sketch: refused with what the circle misses by.
    if (closed && spans.size() == 1 && spans[0].shape.circle) {
        const double rms = rms_of(whole, pts, 0, n);
        if (rms <= result.tolerance_mm) return whole_circle(whole);
        long worst = 0;
        for (long i = 1; i < n; ++i)
            if (whole.distance(pts[i]) > whole.distance(pts[worst])) worst = i;
        char text[300];
        std::snprintf(text, sizeof text,
                      "the closed polyline runs round as one curve but is no circle within the tolerance of %.4f mm: "
                      "the circle of radius %.3f mm is %.4f mm RMS off its %ld points (%.4f mm at point %ld)",
                      result.tolerance_mm, whole.radius, rms, n, whole.distance(pts[worst]), worst);
        throw Error("polyline", text);
    }
    std::vector<double> sigmas;  // of each final fit (jackknife_sigma)
    std::vector<Band> bands(spans.size());  // each element's points of the parallel cuts
    // The final fits leave out a tenth of the points at each end that is a corner or an open end:
    // there a scan is least sure (a rounded corner, a grazing silhouette) and a split may still be
    // a point off. Tangent ends keep their points: a fillet needs all of its short arc.
    {
        const size_t count = spans.size();
        std::vector<bool> smooth_after(count, false);
        for (size_t j = 0; j + 1 < count || (closed && count > 1 && j < count); ++j)
            smooth_after[j] = can_be_tangent(spans[j].shape, spans[(j + 1) % count].shape, result.tolerance_mm);
        std::vector<Span> trimmed = spans;
        std::vector<std::pair<long, long>> fitted(count);  // first point and count of each final fit
        for (size_t j = 0; j < count; ++j) {
            const bool smooth_before = closed || j > 0 ? smooth_after[(j + count - 1) % count] : false;
            const long trim = spans[j].count / 10;
            const long head = smooth_before ? 0 : trim, tail = smooth_after[j] ? 0 : trim;
            const long minimum = spans[j].shape.circle ? options.min_arc_points : options.min_line_points;
            fitted[j] = {spans[j].first, spans[j].count};
            if (spans[j].count - head - tail < minimum || head + tail == 0) continue;
            const Shape shape = fitter.fit(spans[j].shape.circle, spans[j].first + head, spans[j].count - head - tail);
            if (!shape.ok) continue;
            trimmed[j].shape = shape;
            fitted[j] = {spans[j].first + head, spans[j].count - head - tail};
        }
        for (size_t j = 0; j < count; ++j) {
            bands[j] = band_of(trimmed[j].shape, pts, fitted[j].first, fitted[j].second,
                               trimmed[j].shape.circle ? corner_cuts : parallel_cuts, result.tolerance_mm,
                               false, options.band_trend_fraction);
            trimmed[j].shape = refit_with_band(trimmed[j].shape, pts, fitted[j].first, fitted[j].second, bands[j]);
        }
        // Fillets: an arc tangent to a line on each side is fitted again with both lines as one curve.
        for (size_t j = 0; j < count && count >= 3; ++j) {
            const size_t before = (j + count - 1) % count, after = (j + 1) % count;
            if (!closed && (j == 0 || j + 1 == count)) continue;
            if (!trimmed[j].shape.circle || trimmed[before].shape.circle || trimmed[after].shape.circle) continue;
            if (!smooth_after[before] || !smooth_after[j]) continue;
            std::vector<cv::Vec2d> points;
            for (const size_t k : {before, j, after}) {
                const auto [first, number] = fitted[k];
                for (long i = first; i < first + number; ++i) points.push_back(pts[i]);
                points.insert(points.end(), bands[k].points.begin(), bands[k].points.end());
            }
            FilletFit fillet(trimmed[before].shape, trimmed[j].shape, trimmed[after].shape, std::move(points));
            if (!fillet.solve() || fillet.arc_points() < options.min_arc_points) continue;
            Shape line_before = trimmed[before].shape, arc = trimmed[j].shape, line_after = trimmed[after].shape;
            fillet.shapes(line_before, arc, line_after);
            // Kept only when every element still holds its own points within the tolerance.
            bool holds = true;
            for (const auto& [k, shape] : {std::pair{before, &line_before}, std::pair{j, &arc}, std::pair{after, &line_after}})
                holds = holds && max_distance(*shape, pts, fitted[k].first, fitted[k].second) <= result.tolerance_mm;
            if (!holds) continue;
            trimmed[before].shape = line_before;
            trimmed[j].shape = arc;
            trimmed[after].shape = line_after;
        }
        for (size_t j = 0; j < count; ++j) {
            const auto [first, number] = fitted[j];
            sigmas.push_back(jackknife_sigma(trimmed[j].shape, pts, first, number, bands[j]));
            // A fillet (tangent on both sides) has its radius from the lines too, which its jackknife
            // over its own short arc does not see.
            const bool fillet = smooth_after[j] && (closed || j > 0) && smooth_after[(j + count - 1) % count];
            if (!fillet) check_radius_known(trimmed[j].shape, sigmas[j], result.tolerance_mm, first, number, n);
        }
        spans = trimmed;
    }
    for (size_t j = 0; j < spans.size(); ++j) {
        const Span& span = spans[j];
        SectionElement e;
        (span.shape.circle ? e.radius_sigma_mm : e.angle_sigma_deg) = sigmas[j];
        e.band_cuts = bands[j].cuts;
        e.band_note = bands[j].note;
        e.kind = span.shape.circle ? SectionElementKind::Arc : SectionElementKind::Line;
        e.first_point = int(((span.first % n) + n) % n);
        e.point_count = int(span.count);
        e.centre = span.shape.centre;
        e.radius_mm = span.shape.radius;
        if (span.shape.circle) e.counter_clockwise = swept_angle(pts, span.first, span.count, span.shape.centre) > 0;
        double sum = 0;
        for (long i = span.first; i < span.first + span.count; ++i) {
            const double d = span.shape.distance(pts[i]);
            sum += d * d;
            e.max_mm = std::max(e.max_mm, d);
        }
        e.rms_mm = std::sqrt(sum / double(span.count));
        // Ends: the points projected on the element; replaced by the joints below.
        const auto project = [&](const cv::Vec2d& p) {
            if (!span.shape.circle) return perpendicular_foot(span.shape, p);
            const cv::Vec2d r = p - span.shape.centre;
            return span.shape.centre + span.shape.radius * r / std::max(cv::norm(r), 1e-12);
        };
        e.start = project(pts[span.first]);
        e.end = project(pts[span.first + span.count - 1]);
        // The one acceptance test, on the figures the element reports: its RMS over all its points
        // (the ends the final fit left out included) within the tolerance. An element far off its
        // own points (a fillet of too few points for an arc, covered by lines across it; an arc round
        // a faceted hole that one chord's middle point pulls off) is refused, never handed on as
        // fitted. (A check on the trimmed points alone passed a 351-degree arc 1.9 x the tolerance
        // RMS off its points.)
        if (e.rms_mm > result.tolerance_mm) {
            long worst = span.first;
            for (long i = span.first; i < span.first + span.count; ++i)
                if (span.shape.distance(pts[i]) > span.shape.distance(pts[worst])) worst = i;
            char text[300];
            std::snprintf(text, sizeof text,
                          "a %s from (%.3f, %.3f) to (%.3f, %.3f) mm is %.4f mm RMS off its %ld points (%.4f mm at point "
                          "%ld), above the tolerance of %.4f mm (a tolerance set above it fits it)",
                          span.shape.circle ? "arc" : "line", e.start[0], e.start[1], e.end[0], e.end[1], e.rms_mm,
                          span.count, e.max_mm, ((worst % n) + n) % n, result.tolerance_mm);
            throw Error("polyline", text);
        }
        result.elements.push_back(e);
    }
    const size_t count = spans.size();
    const size_t joints = closed ? count : count - 1;
    for (size_t j = 0; j < joints && count > 1; ++j) {
        const size_t k = (j + 1) % count;
        const Shape &a = spans[j].shape, &b = spans[k].shape;
        const cv::Vec2d near = 0.5 * (pts[spans[j].first + spans[j].count - 1] + pts[spans[k].first]);
        bool tangent = can_be_tangent(a, b, result.tolerance_mm);
        const cv::Vec2d point = joint(a, b, near, tangent);
        // A joint far from the points (nearly parallel neighbours) is not trusted: keep the ends. A
        // tangent joint may lie up to sqrt(2 r t) from them: so far an arc of radius r stays within the
        // tolerance t of its tangent line (0.32 mm for 10 mm), and either may have taken the points there.
        double reach = 10 * result.tolerance_mm + 2 * cv::norm(pts[spans[k].first] - near);
        if (tangent) reach += std::sqrt(2 * std::min(a.circle ? a.radius : HUGE_VAL, b.circle ? b.radius : HUGE_VAL) * result.tolerance_mm);
        if (cv::norm(point - near) > reach) continue;
        result.elements[j].end = point;
        result.elements[k].start = point;
        // Tangent, not a cusp: the two run on in about the same direction there.
        tangent = tangent && angle_between_deg(travel_direction(result.elements[j], point),
                                               travel_direction(result.elements[k], point)) < options.tangent_angle_deg;
        result.elements[j].tangent_to_next = tangent;
    }
    find_constraints(result, pts, options);
    return result;
}

// The corners of a faceted cut. A plane cuts a mesh's curved face (a fillet, a hole) along the
// chords of its facets: the chords' ends (where the cut crosses an edge along the curve) lie on the
// true curve, the points between them (where it crosses a facet's diagonal) on the straight chord, up
// to c^2 / (8 r) inside the curve for a chord of length c on radius r. A circle fitted to every point
// lies between the two, off the true radius by up to half that sag (56 um for 3 mm chords on a 10 mm
// hole), and none holds them all once the sag passes about twice the tolerance. Where the chords'
// ends lie on one curve (facet_runs), only they are fitted.
//
// Points of a polyline where it turns: not within the rounding of a mesh's float vertices (a few
// 1e-7 of their coordinates: 1e-5 mm at 25 mm) of the line through their neighbours, allowed 1e-6
// of the coordinates. A scan mesh's cut turns at every point by its noise (its facets are not
// coplanar), so there every point turns and no chord has inner points.
std::vector<long> turning_points(const std::vector<cv::Vec2d>& polyline, bool closed) {
    constexpr double kStraightRelative = 1e-6;
    const long n = long(polyline.size());
    const Points pts{polyline, closed};
    std::vector<long> turning;
    for (long i = 0; i < n; ++i) {
        if (!closed && (i == 0 || i == n - 1)) {
            turning.push_back(i);
            continue;
        }
        const cv::Vec2d a = pts[i - 1], b = pts[i + 1], d = b - a;
        const double length = cv::norm(d);
        const cv::Vec2d p = pts[i] - a;
        const double along = length > 0 ? p.dot(d) / length : 0;
        const double straight = kStraightRelative * std::max({1.0, cv::norm(a), cv::norm(b)});
        if (length == 0 || along <= 0 || along >= length || std::abs(p[0] * d[1] - p[1] * d[0]) / length > straight)
            turning.push_back(i);
    }
    return turning;
}

// A run of chords along one curve: the polyline indices of its first and last chord ends (`last`
// past the end of a closed polyline wraps; first + n: the whole loop).
struct FacetRun {
    long first = 0, last = 0;
};

// Chords whose ends turn alike, by the geometry alone: at least 4 chords in a row, each end between
// two of them turning the same way by at most kLargestFacetTurnDeg, the turn per length of chord
// (the curvature) within 25 % of the next end's, and neighbouring chords within 2 x of each other's
// length. A real polygon turns more at each corner (a hexagon 60 deg, an octagon 45, a 0.5 mm
// chamfer 45); a real straight piece between two arcs (tangent to them) turns into them by half a
// chord's turn, which breaks the run. Whether the ends lie on one circle within the tolerance is
// on_one_circle's to say.
constexpr double kLargestFacetTurnDeg = 20;
std::vector<FacetRun> facet_runs(const std::vector<cv::Vec2d>& polyline, bool closed) {
    const long n = long(polyline.size());
    std::vector<long> w = turning_points(polyline, closed);
    const long count = long(w.size());
    std::vector<FacetRun> runs;
    if (count < 4) return runs;
    if (closed) w.push_back(w[0] + n);  // chord k runs from w[k] to w[k + 1]
    const long chords = long(w.size()) - 1;
    const Points pts{polyline, closed};
    const auto chord_vector = [&](long k) {
        const long j = (k % chords + chords) % chords;
        return cv::Vec2d(pts[w[size_t(j + 1)]] - pts[w[size_t(j)]]);
    };
    // Vertex k joins chord k - 1 to chord k (k = 1 .. chords - 1 open; all closed).
    const auto curvature = [&](long k, bool& facet) {
        const cv::Vec2d a = chord_vector(k - 1), b = chord_vector(k);
        const double la = cv::norm(a), lb = cv::norm(b);
        const double turn = std::atan2(a[0] * b[1] - a[1] * b[0], a.dot(b));
        facet = turn != 0 && std::abs(turn) <= kLargestFacetTurnDeg * kPi / 180 && std::max(la, lb) <= 2 * std::min(la, lb);
        return turn / (0.5 * (la + lb));
    };
    const long first_vertex = closed ? 0 : 1, vertices = closed ? chords : chords - 1;
    std::vector<bool> facet(static_cast<size_t>(vertices)), alike_next(static_cast<size_t>(vertices), false);
    std::vector<double> kappa(static_cast<size_t>(vertices));
    for (long v = 0; v < vertices; ++v) {
        bool is_facet = false;
        kappa[size_t(v)] = curvature(first_vertex + v, is_facet);
        facet[size_t(v)] = is_facet;
    }
    for (long v = 0; v < vertices; ++v) {
        const long next = closed ? (v + 1) % vertices : v + 1;
        if (next >= vertices) continue;
        const double a = kappa[size_t(v)], b = kappa[size_t(next)];
        alike_next[size_t(v)] = facet[size_t(v)] && facet[size_t(next)] && a * b > 0 &&
                                std::abs(a - b) <= 0.25 * std::max(std::abs(a), std::abs(b));
    }
    // Runs of vertices each alike the next; closed: started after a break, or the whole loop.
    long begin = 0;
    if (closed) {
        while (begin < vertices && alike_next[size_t((begin + vertices - 1) % vertices)]) ++begin;
        if (begin == vertices) return {{w[0], w[0] + n}};
    }
    for (long v = begin; v < begin + vertices;) {
        long last = v;  // the run's vertices are v .. last
        while (last < begin + vertices - 1 && alike_next[size_t(last % vertices)]) ++last;
        // 4 chords or more: chords (first_vertex + v - 1) .. (first_vertex + last). Their 5 ends or more
        // test a circle (3 unknowns) twice; any 4 ends of a symmetric run lie on one (a short straight
        // side between two arcs with a chord of each).
        if (last - v + 1 >= 3) {
            const long first_chord = first_vertex + v - 1, last_chord = first_vertex + last;
            const long from = w[size_t((first_chord % chords + chords) % chords)];
            long to = w[size_t(((last_chord % chords + chords) % chords) + 1)];
            if (to <= from) to += n;
            runs.push_back({from, to});
        }
        v = last + 1;
    }
    return runs;
}

// Whether a run's chord ends lie on one circle within the tolerance, and its chords sag enough for
// it to matter (more than a tenth of the tolerance: a straight side's noise makes runs of a huge
// radius).
bool on_one_circle(const std::vector<cv::Vec2d>& polyline, bool closed, const FacetRun& run, double tolerance,
                   const SectionFitOptions& options) {
    const Points pts{polyline, closed};
    const std::vector<long> turning = turning_points(polyline, closed);
    std::vector<cv::Vec2d> ends;
    for (long i = run.first; i <= run.last && long(ends.size()) < long(polyline.size()); ++i)
        if (std::binary_search(turning.begin(), turning.end(), i % long(polyline.size()))) ends.push_back(pts[i]);
    const Points end_points{ends, false};
    const Shape circle = fit_circle(end_points, 0, long(ends.size()));
    if (!circle.ok || circle.radius > options.max_arc_radius_mm) return false;
    double longest = 0;
    for (size_t k = 1; k < ends.size(); ++k) longest = std::max(longest, cv::norm(ends[k] - ends[k - 1]));
    return longest * longest / (8 * circle.radius) > 0.1 * tolerance && max_distance(circle, end_points, 0, long(ends.size())) <= tolerance;
}

// The polyline without the points strictly inside the chords of `runs`; `kept` gives the index of
// each point kept.
struct Corners {
    std::vector<cv::Vec2d> points;
    std::vector<long> kept;
};
Corners corners_of(const std::vector<cv::Vec2d>& polyline, bool closed, const std::vector<FacetRun>& runs) {
    const long n = long(polyline.size());
    const std::vector<long> turning = turning_points(polyline, closed);
    std::vector<bool> keep(size_t(n), true);
    for (const FacetRun& run : runs)
        for (long i = run.first + 1; i < run.last; ++i)
            if (!std::binary_search(turning.begin(), turning.end(), i % n)) keep[size_t(i % n)] = false;
    Corners corners;
    for (long i = 0; i < n; ++i)
        if (keep[size_t(i)]) {
            corners.points.push_back(polyline[size_t(i)]);
            corners.kept.push_back(i);
        }
    return corners;
}

// The points a polyline's noise is measured on: without the inner points of chords that turn alike
// (facet_runs), whose sag is no noise (it read 0.038 mm on a slot of 2 mm chords on 10 mm arcs).
std::vector<cv::Vec2d> without_chord_middles(const std::vector<cv::Vec2d>& polyline, bool closed) {
    return corners_of(polyline, closed, facet_runs(polyline, closed)).points;
}

// The faceted runs of a polyline whose ends lie on one circle within the tolerance.
std::vector<FacetRun> curved_facet_runs(const std::vector<cv::Vec2d>& polyline, bool closed, double tolerance,
                                        const SectionFitOptions& options) {
    std::vector<FacetRun> runs;
    for (const FacetRun& run : facet_runs(polyline, closed))
        if (on_one_circle(polyline, closed, run, tolerance, options)) runs.push_back(run);
    return runs;
}

// A fit of `corners` given back in the polyline's own numbering: each element starts at its first point
// fitted and runs to the next one's first; point_count stays the points fitted. An arc's or circle's
// chord_sag_mm is the largest sag c^2 / (8 r) of the chords whose inner points were not fitted: they
// lie up to that far inside it.
SectionFit in_polyline_numbering(SectionFit fit, const std::vector<cv::Vec2d>& polyline, bool closed, const Corners& corners) {
    const long n = long(polyline.size()), m = long(corners.points.size());
    const auto original = [&](long i) { return corners.kept[size_t(((i % m) + m) % m)]; };
    for (size_t j = 0; j < fit.elements.size(); ++j) {
        SectionElement& e = fit.elements[j];
        const long first = original(e.first_point);
        const bool runs_to_end = !closed && e.first_point + e.point_count >= m;
        const long end = runs_to_end ? n : original(e.first_point + e.point_count);
        const long span = e.point_count >= m ? n : ((end - first) % n + n) % n;  // polyline points up to the next element
        e.first_point = int(first);
        if (e.kind == SectionElementKind::Line) continue;
        for (long k = 0; k + 1 < span; ++k) {  // chords within the element
            const long a = first + k;
            if (!closed && a + 1 >= n) break;
            if (std::binary_search(corners.kept.begin(), corners.kept.end(), (a + 1) % n)) continue;
            long b = a + 1;  // a is the chord's start, b its end (the next kept point)
            while (!std::binary_search(corners.kept.begin(), corners.kept.end(), b % n)) ++b;
            const double c = cv::norm(polyline[size_t(b % n)] - polyline[size_t(a % n)]);
            e.chord_sag_mm = std::max(e.chord_sag_mm, c * c / (8 * e.radius_mm));
            k = b - first - 1;
        }
    }
    return fit;
}

// Straight runs between two turning points shorter than kSmallestElementMm (no element of the part is
// that short: a corner a mesh cut off, a 0.5 mm chamfer), as runs whose inner points carry nothing
// the run's ends do not.
std::vector<FacetRun> short_straight_runs(const std::vector<cv::Vec2d>& polyline, bool closed) {
    const long n = long(polyline.size());
    std::vector<long> w = turning_points(polyline, closed);
    if (w.empty()) return {};
    if (closed) w.push_back(w[0] + n);
    std::vector<FacetRun> runs;
    const Points pts{polyline, closed};
    for (size_t k = 0; k + 1 < w.size(); ++k)
        if (w[k + 1] - w[k] > 1 && cv::norm(pts[w[k + 1]] - pts[w[k]]) < kSmallestElementMm) runs.push_back({w[k], w[k + 1]});
    return runs;
}

// Fits a polyline. Where it has chords whose ends lie on one curve (curved_facet_runs), to those ends
// first (and the parallel cuts' likewise, for arcs); then, or else, with all its points; and when
// those cannot be split into elements within the tolerance, without the inner points of straight runs
// shorter than kSmallestElementMm (short_straight_runs). An element fitted without some points is
// given back in the polyline's numbering (in_polyline_numbering).
SectionFit fit_section_with(const std::vector<cv::Vec2d>& polyline, bool closed, const SectionFitOptions& options,
                            const std::vector<ParallelCut>& parallel_cuts, double noise_mm) {
    const double tolerance = tolerance_for(noise_mm, options);
    const auto fit_without = [&](const std::vector<FacetRun>& runs,
                                 const std::function<std::vector<FacetRun>(const std::vector<cv::Vec2d>&)>& cut_runs) {
        const Corners corners = corners_of(polyline, closed, runs);
        std::vector<ParallelCut> corner_cuts;
        for (const ParallelCut& cut : parallel_cuts)
            corner_cuts.push_back({cut.offset_mm, corners_of(cut.points, false, cut_runs(cut.points)).points});
        return in_polyline_numbering(fit_points(corners.points, closed, options, parallel_cuts, corner_cuts, noise_mm), polyline,
                                     closed, corners);
    };
    const auto refused = [](const Error& error) { return error.subject() == "polyline"; };
    const std::vector<FacetRun> curved = curved_facet_runs(polyline, closed, tolerance, options);
    if (!curved.empty()) {
        try {
            SectionFit fit = fit_without(curved, [&](const std::vector<cv::Vec2d>& cut) { return curved_facet_runs(cut, false, tolerance, options); });
            // Chord ends are a mesh's vertices, on the part within its noise: an element passing a
            // point 3 x the tolerance away has swallowed a real piece too short for an element of its
            // own (a 2 mm side of 3 points between two arcs, 0.05 mm off the arc that took it).
            if (std::all_of(fit.elements.begin(), fit.elements.end(),
                            [&](const SectionElement& e) { return e.max_mm <= 3 * fit.tolerance_mm; }))
                return fit;
        } catch (const Error& error) {
            if (!refused(error)) throw;
        }
    }
    const std::vector<FacetRun> short_runs = short_straight_runs(polyline, closed);
    try {
        return fit_points(polyline, closed, options, parallel_cuts, parallel_cuts, noise_mm);
    } catch (const Error& error) {
        if (short_runs.empty() || !refused(error)) throw;
    }
    return fit_without(short_runs, [&](const std::vector<cv::Vec2d>& cut) { return short_straight_runs(cut, false); });
}

}  // namespace

SectionFit fit_section(const std::vector<cv::Vec2d>& polyline, bool closed, const SectionFitOptions& options) {
    return fit_extruded_section(polyline, closed, {}, options);
}

SectionFit fit_extruded_section(const std::vector<cv::Vec2d>& input, bool closed,
                                const std::vector<ParallelCut>& parallel_cuts, const SectionFitOptions& options) {
    check_tolerance(options);
    check_cuts(parallel_cuts);
    const std::vector<cv::Vec2d> polyline = distinct_points(input, closed);
    return fit_section_with(polyline, closed, options, parallel_cuts,
                            estimate_noise({without_chord_middles(polyline, closed), closed}, options.noise_window_mm));
}

SectionFits fit_section_polylines(const std::vector<SectionPolyline>& input,
                                  const std::vector<ParallelCut>& parallel_cuts, const SectionFitOptions& options,
                                  const ProgressCallback& progress) {
    check_tolerance(options);
    check_cuts(parallel_cuts);
    if (input.empty()) throw Error("polylines", "none given");
    std::vector<std::vector<cv::Vec2d>> polylines;
    for (const SectionPolyline& polyline : input) polylines.push_back(distinct_points(polyline.points, polyline.closed));
    const auto big_enough = [&](size_t k) { return long(polylines[k].size()) >= std::max(4, options.min_polyline_points); };

    const auto bridged = [&](const std::vector<cv::Vec2d>& points) {
        if (points.size() < 2) return false;
        double length = 0;
        for (size_t i = 1; i < points.size(); ++i) length += cv::norm(points[i] - points[i - 1]);
        const double gap = cv::norm(points.front() - points.back());
        return gap <= options.max_bridged_gap_mm && gap <= 0.1 * length;
    };
    SectionFits result;
    std::vector<double> windows;
    for (size_t k = 0; k < polylines.size(); ++k)
        if (big_enough(k))
            window_noises({without_chord_middles(polylines[k], input[k].closed), input[k].closed}, options.noise_window_mm, windows);
    result.noise_mm = median(windows);
    result.tolerance_mm = tolerance_for(options.scan_noise_mm > 0 ? options.scan_noise_mm : result.noise_mm, options);

    const auto number = [](double value) {
        char text[32];
        std::snprintf(text, sizeof text, "%.4f", value);
        return std::string(text);
    };
    for (size_t k = 0; k < polylines.size(); ++k) {
        if (progress && !progress(double(k) / double(polylines.size()), "fitting lines and arcs"))
            throw Error("cancelled", "the section fit was cancelled");
        const std::vector<cv::Vec2d>& points = polylines[k];
        const bool closed = input[k].closed || bridged(points);
        std::string reason;
        if (!big_enough(k)) {
            reason = "fewer points than the " + std::to_string(std::max(4, options.min_polyline_points)) +
                     " a feature of the part needs (min_polyline_points)";
        } else if (const double own = estimate_noise({without_chord_middles(points, closed), closed}, options.noise_window_mm);
                   own > result.tolerance_mm && (options.tolerance_mm > 0 || own > options.loop_noise_limit_mm)) {
            reason = "its points scatter by " + number(own) + " mm about short line or arc fits, more than the section's "
                     "tolerance of " + number(result.tolerance_mm) + " mm" +
                     (options.tolerance_mm > 0 || result.tolerance_mm >= options.loop_noise_limit_mm
                          ? ""
                          : " and the " + number(options.loop_noise_limit_mm) + " mm a scan's cut holds (loop_noise_limit_mm)") +
                     " (a tolerance set above it fits it)";
        } else {
            try {
                // Noisier than the section (a measured hole in a mesh whose sides were flattened):
                // fitted with its own noise's tolerance. Else with the section's, the scan's noise's
                // when given (fitted with the cut's, a Poisson mesh's outline got the 0.005 mm floor
                // while the report gave the scan's 0.08 mm).
                const double noise = own > result.tolerance_mm ? own
                                     : options.scan_noise_mm > 0 ? options.scan_noise_mm
                                                                 : result.noise_mm;
                result.fits.push_back(fit_section_with(points, closed, options, parallel_cuts, noise));
                result.fitted_index.push_back(int(k));
                continue;
            } catch (const Error& e) {
                reason = std::string(e.what()).substr(e.subject().empty() ? 0 : e.subject().size() + 2);
            }
        }
        LeftOutPolyline left;
        left.index = int(k);
        left.point_count = int(points.size());
        left.closed = closed;
        cv::Vec2d low(HUGE_VAL, HUGE_VAL), high(-HUGE_VAL, -HUGE_VAL);
        for (const cv::Vec2d& p : points) {
            left.centre += p / double(points.size());
            for (int axis = 0; axis < 2; ++axis) {
                low[axis] = std::min(low[axis], p[axis]);
                high[axis] = std::max(high[axis], p[axis]);
            }
        }
        left.across_mm = points.empty() ? 0 : std::max(high[0] - low[0], high[1] - low[1]);
        left.reason = reason;
        result.left_out.push_back(left);
    }
    // Leaving out the section's biggest polyline would hand over a sketch without its outline.
    const size_t biggest = size_t(std::max_element(polylines.begin(), polylines.end(), [](const auto& a, const auto& b) {
                                      return a.size() < b.size();
                                  }) - polylines.begin());
    for (const LeftOutPolyline& left : result.left_out)
        if (size_t(left.index) == biggest)
            throw Error("polyline", "the section's biggest polyline (" + std::to_string(left.point_count) +
                                        " points) cannot be fitted: " + left.reason);
    return result;
}

}  // namespace picoscan
