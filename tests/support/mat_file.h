// A minimal reader for MATLAB v5 .mat files (compressed or not), for comparing with
// reference outputs of other scanners in tests. Reads numeric arrays only.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace picoscan::test_support {

struct MatArray {
    std::vector<int> dimensions;  // MATLAB order (rows, columns, ...)
    std::vector<double> values;   // column-major, converted to double
    // Element at MATLAB subscripts (row, column, page), zero based.
    double at(int row, int column, int page = 0) const {
        return values[size_t(row) + size_t(dimensions[0]) * (size_t(column) + size_t(dimensions[1]) * size_t(page))];
    }
};

// Every numeric array in the file by name; throws std::runtime_error on malformed input.
std::map<std::string, MatArray> read_mat_file(const std::string& path);

}  // namespace picoscan::test_support
