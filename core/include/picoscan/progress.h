// Progress reporting for long core calls.
#pragma once

#include <functional>
#include <string>

namespace picoscan {

// Called with the fraction done (0..1) and the current stage name.
// Returning false asks the call to stop; it then throws Error("cancelled", ...).
using ProgressCallback = std::function<bool(double fraction, const std::string& stage)>;

}  // namespace picoscan
