// Stopwatch: wall-clock timing for the per-phase figures solvers put in their results.
#pragma once

#include <chrono>

namespace slamd::core {

class Stopwatch {
 public:
  Stopwatch() : start_(Clock::now()) {}
  void Restart() { start_ = Clock::now(); }
  // Seconds since construction or the last Restart().
  double Seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  // Returns the seconds so far and restarts: convenient for consecutive phases.
  double Lap() {
    const auto now = Clock::now();
    const double s = std::chrono::duration<double>(now - start_).count();
    start_ = now;
    return s;
  }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point start_;
};

}  // namespace slamd::core
