// The memory budget: the most one large allocation chain of a run may ask for.
#pragma once

#include <cstdint>
#include <string>

namespace picoscan::detail {

// PICOSCAN_MEMORY_MB from the environment when it holds a whole number of at least 64,
// otherwise half the machine's physical memory.
uint64_t memory_budget_bytes();

// Throws Error(subject, "... needs N MB for <what>, over the memory budget of M MB ...")
// when `bytes` exceeds the budget. Called before any allocation whose size comes from a file.
void check_memory_budget(double bytes, const std::string& subject, const std::string& what);

}  // namespace picoscan::detail
