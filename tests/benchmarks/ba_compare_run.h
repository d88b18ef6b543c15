// One solve of ba_ceres_compare, run in a child process of its own so that its peak memory is
// its own: the solve's report (Run), sent back to the parent through a pipe, and the child's
// peak resident set size.
#pragma once

#include <array>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace slamd::benchmarks {

// One solve, as its child process reports it.
struct Run {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

  bool ok = false;
  std::string linear_solver;  // the one used, as the solver names it
  std::string message;        // why it failed, else why it stopped
  double initial_cost = kNaN;
  double final_cost = kNaN;
  double total_s = kNaN;
  double solve_s = kNaN;                     // Ceres: Solve() alone; slamd: total_s
  std::vector<std::array<double, 2>> trace;  // (seconds since the start, cost) per iteration
  double start_rss_mb = kNaN;                // the child's RSS (MiB) before it solved
  double peak_rss_mb = kNaN;                 // the child's peak RSS (MiB)
};

// A failed Run saying why.
Run FailedRun(std::string message);

// Runs `solve` in a forked child and returns its report with start_rss_mb and peak_rss_mb filled
// in; a failed Run when the child could not be started, died, or sent no report. The peak is
// wait4's ru_maxrss of that child alone (RUSAGE_CHILDREN would keep the largest child so far);
// it counts the pages the child shares with the parent, start_rss_mb is what it had of them
// before solving. Whatever `solve` changes stays in the child (copy-on-write), so successive
// calls start from the same data. Call it only while the process has one thread: fork copies
// the calling thread alone.
Run RunInChild(const std::function<Run()>& solve);

}  // namespace slamd::benchmarks
