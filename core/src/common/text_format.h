// printf-style formatting into a std::string, for messages and reports.
#pragma once

#include <string>

namespace picoscan {

// The text printf would print; cut at 4095 characters.
std::string format(const char* pattern, ...) __attribute__((format(printf, 1, 2)));

}  // namespace picoscan
