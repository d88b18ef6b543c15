// WorkerPool: helper threads kept by a solver for its parallel steps (relinearising factors,
// eliminating independent subtrees). A thread started for each large update cost ~35 µs, plus
// the page faults of its stack once the C library had released it, and started late: 2-3% of
// the steps it was meant to shorten. A kept helper waits on a condition variable instead.
//
// Run(n, task) starts task(0), ..., task(n - 1) on the helpers and returns at once, so that the
// caller can do its own share; Wait() returns when every task has finished. Tasks beyond the
// helpers (or all of them, if the system refuses to start a thread) run inside Wait() on the
// calling thread. Helpers start on first use, so a pool that is never needed costs nothing.
// One owner: Run and Wait must not be called concurrently, and every Run needs its Wait.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace slamd::core {

class WorkerPool {
 public:
  explicit WorkerPool(int helpers);  // helpers >= 0
  ~WorkerPool();                     // stops and joins the helpers (after any pending Wait)
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int helpers() const { return helpers_; }
  void Run(int n, std::function<void(int)> task);
  void Wait();

 private:
  void Loop(int index);

  const int helpers_;
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::function<void(int)> task_;  // set by Run, read by the helpers until Wait returns
  std::uint64_t round_ = 0;        // bumped by each Run
  int on_helpers_ = 0;             // tasks [0, on_helpers_) of this round go to the helpers
  int total_ = 0;                  // tasks of this round
  int pending_ = 0;                // helper tasks not yet finished
  bool stop_ = false;
};

}  // namespace slamd::core
