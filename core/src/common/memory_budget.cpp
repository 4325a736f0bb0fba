#include "common/memory_budget.h"

#include "picoscan/error.h"

#include <cmath>
#include <cstdlib>

#include <unistd.h>

namespace picoscan::detail {

uint64_t memory_budget_bytes() {
    constexpr uint64_t kMegabyte = uint64_t(1) << 20;
    if (const char* setting = std::getenv("PICOSCAN_MEMORY_MB")) {
        char* end = nullptr;
        const unsigned long long megabytes = std::strtoull(setting, &end, 10);
        if (end != setting && *end == '\0' && megabytes >= 64 && megabytes <= (uint64_t(1) << 40))
            return megabytes * kMegabyte;
    }
    const long pages = ::sysconf(_SC_PHYS_PAGES), page_size = ::sysconf(_SC_PAGE_SIZE);
    if (pages <= 0 || page_size <= 0) return uint64_t(4096) * kMegabyte;
    return uint64_t(pages) * uint64_t(page_size) / 2;
}

void check_memory_budget(double bytes, const std::string& subject, const std::string& what) {
    const uint64_t budget = memory_budget_bytes();
    if (std::isfinite(bytes) && bytes >= 0 && bytes <= double(budget)) return;
    const auto megabytes = [](double value) {
        return std::isfinite(value) ? std::to_string(static_cast<long long>(std::ceil(value / 1048576.0))) : "inf";
    };
    throw Error(subject, "needs " + megabytes(bytes) + " MB for " + what + ", over the memory budget of " +
                             megabytes(double(budget)) + " MB (half the RAM, or PICOSCAN_MEMORY_MB)");
}

}  // namespace picoscan::detail
