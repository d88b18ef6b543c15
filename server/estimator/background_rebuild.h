// BackgroundRebuild: background relinearisation. An update due to relinearise many variables
// defers it (EstimatorParams::background_relinearization_above) and the estimator starts one of
// these: a new solver made from the live factors at the current estimate on one helper thread,
// slamd-rebuild, while the live solver keeps taking messages.
//
// The protocol. The new solver is made from the live factors at the current estimate (one batch
// update, as Restore does, then the new solver's first relinearisation check). The live solver
// keeps taking messages
// meanwhile, without relinearisation checks (the rebuild relinearises everything); each of its
// updates is logged for the rebuild (new factors, new variables with their initial guesses,
// removals). The helper then catches up on that log in rounds, each taking what was logged
// while the last one ran (and relinearising what moved), until nothing waits or it ran
// EstimatorParams::rebuild_catch_up_rounds: a rebuild of a large map takes seconds, and the
// updates logged meanwhile would otherwise be one long update on the estimator thread. It is
// ready (RebuildReady) only then, so FinishRebuild (the daemon calls it as soon as RebuildReady)
// gives the new solver just the updates logged since (usually none or one, unless the rounds ran
// out) in one update (new variables at the live estimate) and swaps it in. Deterministic: the
// same messages, refinements and swaps (with their catch-up rounds) in the same order give the
// same state, whatever the threads' timing: the journal records each swap and its rounds, and a
// replay runs the rounds it recorded.
//
// Threads: Start and the helper share only the log (under its mutex) and `done`; everything
// else belongs to the helper until Ready(), then to the estimator thread (Log, Finish).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <utility>
#include <vector>

#include "core/base/status.h"
#include "core/isam/isam2.h"

namespace slamd::server {

class BackgroundRebuild {
 public:
  struct Options {
    std::vector<core::Key> order_last;  // the newest poses (Isam2UpdateOptions::order_last)
    int max_rounds = 0;                 // catch-up rounds on the helper (0 while replaying)
    bool with_chi2 = false;             // compute the rebuilt map's chi2 on the helper
    std::int64_t start_sequence = 0;    // the live update sequence it starts from
  };
  // Copies the live solver's factors (shared, immutable) and estimate and starts the helper.
  static std::unique_ptr<BackgroundRebuild> Start(const core::Isam2& live, Options options);
  ~BackgroundRebuild();  // joins the helper

  // The helper is done: it built the solver and caught up (or failed).
  bool Ready() const { return done_.load(std::memory_order_acquire); }
  // The helper stops catching up after the round it is in (and computes no chi2): the swap is
  // wanted now, the rest of the log taken in the swap's update. The rounds it ran are what the
  // swap reports (and the journal records), so a replay does the same.
  void Hurry() { hurry_.store(true, std::memory_order_release); }

  // Logs a successful live update (its new factors with their live indices, new variables at
  // their initial guesses, removed live factor indices) for the rebuild to take.
  void Log(const core::FactorGraph& factors, const core::Values& values,
           const core::Isam2Result& update, std::span<const int> removed, std::int64_t sequence);

  // What the swap hands the estimator.
  struct Swap {
    std::unique_ptr<core::Isam2> solver;
    // Per live factor index: its index in `solver` (-1: not in it, or removed).
    std::vector<int> position;
    std::vector<int> rounds;  // logged updates taken per catch-up round
    // The rebuilt map's chi2 (-1: not computed) and the live update sequence it covers.
    double chi2 = -1.0;
    std::int64_t chi2_sequence = 0;
    core::Isam2Result update;  // the last catch-up, on the estimator thread
  };
  // Waits for the helper, runs `replay_rounds` (a replay's recorded rounds; ignored when they
  // name more updates than were logged), then gives the new solver the rest of the log in one
  // update with `options`, its new variables at `live`'s estimate. An error (prefixed
  // "background rebuild: ") when building or catching up failed.
  core::Result<Swap> Finish(std::span<const int> replay_rounds, core::Isam2UpdateOptions options,
                            const core::Isam2& live);

 private:
  BackgroundRebuild() = default;
  void Run(core::Isam2Params params, core::FactorGraph factors, core::Values estimate,
           Options options);
  // Gives the solver the log entries [caught_up_, end) in one update (none when they add and
  // remove nothing) and maps their factors in position_. New variables at their logged initial
  // guesses, or at `live`'s estimate when given (the estimator thread only).
  core::Isam2Result CatchUp(size_t end, core::Isam2UpdateOptions options, const core::Isam2* live);

  // What one live update gave the solver while the rebuild was in flight.
  struct LoggedUpdate {
    std::vector<std::pair<int, core::FactorPtr>> added;  // (live factor index, factor)
    core::Values values;                                 // new variables, initial guesses
    std::vector<int> removed;                            // live factor indices
    std::int64_t sequence = 0;                           // the live update sequence it made
  };

  std::thread thread_;
  std::atomic<bool> done_ = false;
  std::atomic<bool> hurry_ = false;
  std::unique_ptr<core::Isam2> solver_;
  core::Status status_;
  std::vector<int> position_;  // per live factor index
  std::mutex log_mutex_;
  std::vector<LoggedUpdate> log_;  // the live updates since the start, in order
  size_t caught_up_ = 0;           // log entries solver_ has taken
  std::vector<int> rounds_;        // entries taken per catch-up round
  double chi2_ = -1.0;
  std::int64_t chi2_sequence_ = 0;
};

}  // namespace slamd::server
