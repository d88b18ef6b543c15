// The q-quantile of a sample, for the benchmarks' step and latency figures: the value at rank
// round(q·(n − 1)) of the sorted values (q in [0, 1]; q = 1 is the maximum), 0 for no values.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace slamd::core {

inline double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const double last = static_cast<double>(v.size() - 1);
  const auto k = static_cast<std::size_t>(std::min(last, q * last + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace slamd::core
