// The core's one parallel mechanism: split a range of rows across all cores.
#pragma once

#include <opencv2/core.hpp>
#include <algorithm>

namespace picoscan::detail {

// Runs body(begin, end) over [0, count) in a few contiguous chunks per core.
template <class Body>
void parallel_rows(int count, Body&& body) {
    const int stripes = std::max(1, std::min(count, cv::getNumThreads() * 4));
    cv::parallel_for_(
        cv::Range(0, count), [&](const cv::Range& range) { body(range.start, range.end); }, stripes);
}

}  // namespace picoscan::detail
