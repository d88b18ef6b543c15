// The process's memory use, as the kernel counts it (Linux /proc): what status_t reports and
// what the lifelong benchmarks watch.
#pragma once

#include <cstdint>

namespace slamd::core {

// Resident set size now [bytes] (/proc/self/statm); 0 if it cannot be read.
std::int64_t ResidentBytes();

}  // namespace slamd::core
