// LatencyWindow: the last `size` latency samples (publish.latency_window) and their percentiles,
// for status_t's update and ingest-to-publish latencies.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace slamd::server {

class LatencyWindow {
 public:
  explicit LatencyWindow(std::size_t size) : size_(size) {}

  // Keeps `value` in place of the oldest once the window is full.
  void Record(double value) {
    if (samples_.size() < size_) {
      samples_.push_back(value);
    } else {
      samples_[next_++ % size_] = value;
    }
  }

  // The q-quantiles of the samples for ascending qs in [0, 1] (1: the largest); zeros when there
  // are none. From one copy: each nth_element works on the part above the previous one (windows
  // can be large).
  template <std::size_t N>
  std::array<std::int64_t, N> Percentiles(const std::array<double, N>& qs) const {
    std::array<std::int64_t, N> out{};
    if (samples_.empty()) return out;
    std::vector<double> v = samples_;
    auto from = v.begin();
    for (std::size_t i = 0; i < N; ++i) {
      const std::size_t k =
          std::min(v.size() - 1, static_cast<std::size_t>(qs[i] * static_cast<double>(v.size())));
      const auto kth = v.begin() + static_cast<std::ptrdiff_t>(k);
      std::nth_element(from, kth, v.end());
      out[i] = static_cast<std::int64_t>(*kth);
      from = kth;
    }
    return out;
  }

 private:
  std::size_t size_;
  std::vector<double> samples_;
  std::size_t next_ = 0;
};

}  // namespace slamd::server
