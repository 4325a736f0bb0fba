// How many elements or constraints of a kind a section fit holds (shared by this folder's tests).
#pragma once

#include "picoscan/section_fit.h"

inline int count(const picoscan::SectionFit& fit, picoscan::SectionElementKind kind) {
    int n = 0;
    for (const auto& e : fit.elements) n += e.kind == kind;
    return n;
}

inline int count(const picoscan::SectionFit& fit, picoscan::SectionConstraintKind kind) {
    int n = 0;
    for (const auto& c : fit.constraints) n += c.kind == kind;
    return n;
}
