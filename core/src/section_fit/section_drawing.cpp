// Fitted sections written as drawings (SVG for viewers and laser cutters, DXF R12 for CAD tools).
#include "picoscan/section_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace picoscan {

namespace {

constexpr double kPi = 3.14159265358979323846;

double angle_of(const cv::Vec2d& point, const cv::Vec2d& centre) {
    return std::atan2(point[1] - centre[1], point[0] - centre[0]);
}

// Radians swept from start to end in the arc's direction, in (0, 2 pi].
double arc_sweep(const SectionElement& arc) {
    const double from = angle_of(arc.start, arc.centre), to = angle_of(arc.end, arc.centre);
    double sweep = arc.counter_clockwise ? to - from : from - to;
    while (sweep <= 0) sweep += 2 * kPi;
    while (sweep > 2 * kPi) sweep -= 2 * kPi;
    return sweep;
}

std::string number(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.6f", std::abs(value) < 5e-7 ? 0.0 : value);
    return text;
}

struct Box {
    double x0 = HUGE_VAL, y0 = HUGE_VAL, x1 = -HUGE_VAL, y1 = -HUGE_VAL;
    void add(const cv::Vec2d& p) {
        x0 = std::min(x0, p[0]), y0 = std::min(y0, p[1]);
        x1 = std::max(x1, p[0]), y1 = std::max(y1, p[1]);
    }
};

// The element's bounding box: its ends, and the points of its circle at 0, 90, 180 and 270
// degrees that it passes.
void add_element(Box& box, const SectionElement& e) {
    box.add(e.start);
    box.add(e.end);
    if (e.kind == SectionElementKind::Line) return;
    const double from = e.counter_clockwise ? angle_of(e.start, e.centre) : angle_of(e.end, e.centre);
    const double sweep = e.kind == SectionElementKind::Circle ? 2 * kPi : arc_sweep(e);
    for (int quarter = 0; quarter < 4; ++quarter) {
        double past = quarter * kPi / 2 - from;  // counter-clockwise from `from`
        while (past < 0) past += 2 * kPi;
        if (past <= sweep)
            box.add(e.centre + e.radius_mm * cv::Vec2d(std::cos(quarter * kPi / 2), std::sin(quarter * kPi / 2)));
    }
}

}  // namespace

double swept_angle_deg(const SectionElement& element) {
    switch (element.kind) {
    case SectionElementKind::Line: return 0;
    case SectionElementKind::Circle: return 360;
    case SectionElementKind::Arc: break;
    }
    return arc_sweep(element) * 180 / kPi;
}

std::string section_svg(const SectionFits& fits) {
    Box box;
    for (const SectionFit& fit : fits.fits)
        for (const SectionElement& e : fit.elements) add_element(box, e);
    if (box.x0 > box.x1) box = Box{0, 0, 0, 0};
    const double margin = 2;  // mm around the profile
    const double width = box.x1 - box.x0 + 2 * margin, height = box.y1 - box.y0 + 2 * margin;
    // SVG's y runs down: a point (x, y) of the section is drawn at (x, -y).
    const auto at = [](const cv::Vec2d& p) { return number(p[0]) + " " + number(-p[1]); };
    std::string svg = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
                      number(width) + "mm\" height=\"" + number(height) + "mm\" viewBox=\"" + number(box.x0 - margin) +
                      " " + number(-box.y1 - margin) + " " + number(width) + " " + number(height) + "\">\n";
    svg += "<desc>Fitted section (PicoScan), millimetres; section tolerance " + number(fits.tolerance_mm) +
           " mm</desc>\n<g fill=\"none\" stroke=\"black\" stroke-width=\"0.1\">\n";
    for (size_t k = 0; k < fits.fits.size(); ++k) {
        svg += "<g id=\"polyline" + std::to_string(fits.fitted_index[k] + 1) + "\">\n";
        for (const SectionElement& e : fits.fits[k].elements) {
            if (e.kind == SectionElementKind::Circle) {
                svg += "<circle cx=\"" + number(e.centre[0]) + "\" cy=\"" + number(-e.centre[1]) + "\" r=\"" +
                       number(e.radius_mm) + "\"/>\n";
            } else if (e.kind == SectionElementKind::Line) {
                svg += "<path class=\"line\" d=\"M " + at(e.start) + " L " + at(e.end) + "\"/>\n";
            } else {
                // Negating y turns the section's counter-clockwise into SVG's negative sweep.
                const bool large = arc_sweep(e) > kPi;
                svg += "<path class=\"arc\" d=\"M " + at(e.start) + " A " + number(e.radius_mm) + " " +
                       number(e.radius_mm) + " 0 " + (large ? "1 " : "0 ") + (e.counter_clockwise ? "0 " : "1 ") +
                       at(e.end) + "\"/>\n";
            }
        }
        svg += "</g>\n";
    }
    return svg + "</g>\n</svg>\n";
}

std::string section_dxf(const SectionFits& fits) {
    std::string dxf = "0\nSECTION\n2\nHEADER\n9\n$ACADVER\n1\nAC1009\n0\nENDSEC\n0\nSECTION\n2\nENTITIES\n";
    const auto group = [&](int code, const std::string& value) { dxf += std::to_string(code) + "\n" + value + "\n"; };
    const auto point = [&](int code, const cv::Vec2d& p) {
        group(code, number(p[0]));
        group(code + 10, number(p[1]));
        group(code + 20, number(0));
    };
    for (const SectionFit& fit : fits.fits)
        for (const SectionElement& e : fit.elements) {
            const char* entity = e.kind == SectionElementKind::Line ? "LINE" : e.kind == SectionElementKind::Arc ? "ARC" : "CIRCLE";
            group(0, entity);
            group(8, "0");
            if (e.kind == SectionElementKind::Line) {
                point(10, e.start);
                point(11, e.end);
                continue;
            }
            point(10, e.centre);
            group(40, number(e.radius_mm));
            if (e.kind == SectionElementKind::Circle) continue;
            // DXF arcs run counter-clockwise from their start angle (50) to their end angle (51).
            const cv::Vec2d& from = e.counter_clockwise ? e.start : e.end;
            const cv::Vec2d& to = e.counter_clockwise ? e.end : e.start;
            group(50, number(angle_of(from, e.centre) * 180 / kPi));
            group(51, number(angle_of(to, e.centre) * 180 / kPi));
        }
    return dxf + "0\nENDSEC\n0\nEOF\n";
}

}  // namespace picoscan
