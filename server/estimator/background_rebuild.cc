#include "server/estimator/background_rebuild.h"

#include <algorithm>
#include <string>

#include "core/base/check.h"
#include "core/base/thread_name.h"

namespace slamd::server {

std::unique_ptr<BackgroundRebuild> BackgroundRebuild::Start(const core::Isam2& live,
                                                            Options options) {
  // The helper reads only what is copied here (the factors are immutable and shared).
  std::unique_ptr<BackgroundRebuild> r(new BackgroundRebuild());
  const std::vector<core::FactorPtr>& slots = live.factor_slots();
  core::FactorGraph factors;
  r->position_.assign(slots.size(), -1);
  for (size_t i = 0; i < slots.size(); ++i) {
    if (!slots[i]) continue;
    r->position_[i] = static_cast<int>(factors.size());
    factors.Add(slots[i]);
  }
  // One thread: the other core is the live solver's. (The rebuilt solver keeps it after the
  // swap; with background relinearisation the steps large enough for threads are the rebuilds.
  // A/B at 1 kHz: ingest-to-publish p99 victoriaPark 4.2-4.5 -> 3.3-4.1 ms, manhattan 2.5-2.7 ->
  // 1.6-2.3 ms.)
  core::Isam2Params params = live.params();
  params.threads = 1;
  BackgroundRebuild* self = r.get();
  r->thread_ =
      std::thread([self, params, factors = std::move(factors), estimate = live.CalculateEstimate(),
                   options = std::move(options)]() mutable {
        self->Run(params, std::move(factors), std::move(estimate), std::move(options));
      });
  return r;
}

BackgroundRebuild::~BackgroundRebuild() {
  if (thread_.joinable()) thread_.join();
}

void BackgroundRebuild::Run(core::Isam2Params params, core::FactorGraph factors,
                            core::Values estimate, Options options) {
  core::NameThisThread("slamd-rebuild");
  core::Result<std::unique_ptr<core::Isam2>> made = core::Isam2::Create(params);
  if (made.ok()) {
    solver_ = std::move(made).value();
    status_ = solver_->Update(factors, estimate, {.order_last = options.order_last}).status;
    // A relinearisation check now: its first pass in a new solver evaluates every factor
    // (Relinearization::error_threshold; nothing is known of their curvature yet), 4-5 ms on
    // victoriaPark, which would otherwise fall on the first checking update after the swap.
    if (status_.ok()) {
      status_ =
          solver_->Update({}, {}, {.order_last = options.order_last, .force_relinearize = true})
              .status;
    }
  } else {
    status_ = made.status();
  }
  // Freed now, not after `done` with the lambda: freeing a large map's copies (up to 30 ms in
  // the soak) would fall on the estimator thread, in FinishRebuild's join.
  factors = core::FactorGraph();
  estimate = core::Values();
  // Catch-up rounds: each takes what was logged while the last one ran, so the backlog
  // shrinks round by round; at most options.max_rounds, for input faster than them. The new
  // variables come at their initial guesses (the live estimate is the estimator thread's): each
  // round relinearises what moved past the thresholds. With `finish`, the check that finds nothing
  // waiting also marks the rebuild done, under the log's lock: every update the estimator
  // logged before it saw the rebuild not done is taken here, and the swap takes only what
  // came after (on manhattan.g2o at 1 kHz, leaving the last 2 and what came during the chi2
  // pass made swaps of up to 4 ms on the estimator thread).
  const auto catch_up = [&](bool finish) {
    for (;;) {
      size_t end = 0;
      {
        std::lock_guard lock(log_mutex_);
        end = log_.size();
        if (end == caught_up_ || !status_.ok() ||
            static_cast<int>(rounds_.size()) >= options.max_rounds ||
            hurry_.load(std::memory_order_acquire)) {
          if (finish) done_.store(true, std::memory_order_release);
          return;
        }
      }
      const int taken = static_cast<int>(end - caught_up_);
      status_ = CatchUp(end, {.force_relinearize = true}, nullptr).status;
      rounds_.push_back(taken);
    }
  };
  catch_up(false);
  // The status chi2 of the rebuilt map, here rather than on the estimator thread, where a
  // pass over every factor (50-350 ms at 250k variables) held up every message behind it.
  // It describes the updates taken so far; the swap hands it over.
  if (status_.ok() && options.with_chi2 && !hurry_.load(std::memory_order_acquire)) {
    chi2_ = solver_->Chi2();
    std::lock_guard lock(log_mutex_);
    chi2_sequence_ = caught_up_ == 0 ? options.start_sequence : log_[caught_up_ - 1].sequence;
  }
  catch_up(true);  // what came during the chi2 pass (2-4 ms on manhattan.g2o)
}

core::Isam2Result BackgroundRebuild::CatchUp(size_t end, core::Isam2UpdateOptions options,
                                             const core::Isam2* live) {
  core::FactorGraph added;
  std::vector<int> live_index;  // of each factor in `added`
  core::Values values;
  {
    std::lock_guard lock(log_mutex_);
    SLAMD_CHECK(end <= log_.size()) << "catch-up past the log";
    std::vector<std::pair<int, core::FactorPtr>> factors;
    for (size_t e = caught_up_; e < end; ++e) {
      const LoggedUpdate& u = log_[e];
      factors.insert(factors.end(), u.added.begin(), u.added.end());
      for (size_t v = 0; v < u.values.size(); ++v) {
        const core::Key key = u.values.KeyAt(static_cast<int>(v));
        const core::Status s = values.Insert(
            key, live ? live->CalculateEstimate(key) : u.values.VariableAt(static_cast<int>(v)));
        SLAMD_CHECK(s.ok()) << s.ToString();  // the live solver took it as new
      }
      for (int index : u.removed) {
        if (static_cast<size_t>(index) < position_.size() && position_[index] >= 0) {
          options.remove_factors.push_back(position_[index]);
          position_[index] = -1;
          continue;
        }
        // Added in this round: it never reaches the new solver. (The last factor logged at
        // that index: the live solver gives a removed factor's index to a later one.)
        const auto it = std::find_if(factors.rbegin(), factors.rend(),
                                     [&](const auto& f) { return f.first == index; });
        SLAMD_CHECK(it != factors.rend()) << "removed live factor " << index << " is unknown";
        it->second = nullptr;
      }
    }
    for (auto& [index, factor] : factors) {
      if (!factor) continue;
      live_index.push_back(index);
      added.Add(std::move(factor));
    }
  }
  caught_up_ = end;
  if (added.size() == 0 && values.empty() && options.remove_factors.empty()) return {};
  core::Isam2Result update = solver_->Update(added, values, options);
  if (!update.status.ok()) return update;
  for (size_t k = 0; k < live_index.size(); ++k) {
    const int i = live_index[k];
    if (static_cast<size_t>(i) >= position_.size()) position_.resize(i + 1, -1);
    position_[i] = update.new_factor_indices[k];
  }
  return update;
}

void BackgroundRebuild::Log(const core::FactorGraph& factors, const core::Values& values,
                            const core::Isam2Result& update, std::span<const int> removed,
                            std::int64_t sequence) {
  LoggedUpdate u;
  u.added.reserve(factors.size());
  for (size_t k = 0; k < factors.size(); ++k) {
    u.added.emplace_back(update.new_factor_indices[k], factors[k]);
  }
  u.values = values;
  u.removed.assign(removed.begin(), removed.end());
  u.sequence = sequence;
  std::lock_guard lock(log_mutex_);
  log_.push_back(std::move(u));
}

core::Result<BackgroundRebuild::Swap> BackgroundRebuild::Finish(std::span<const int> replay_rounds,
                                                                core::Isam2UpdateOptions options,
                                                                const core::Isam2& live) {
  if (thread_.joinable()) thread_.join();
  SLAMD_CHECK(replay_rounds.empty() || rounds_.empty())
      << "replayed catch-up rounds for a rebuild whose helper ran rounds (SetReplaying)";
  // Rounds recorded for another rebuild than this one cannot apply: recovery from a snapshot
  // taken while the journal's rebuild was in flight replays into a solver restored in a new
  // order, which may defer (and start its own rebuild) at other updates. Its swap then takes
  // everything in one update (a snapshot recovery is not bit for bit anyway).
  size_t named = 0;
  bool fits = true;
  for (int n : replay_rounds) {
    fits = fits && n > 0;
    named += static_cast<size_t>(std::max(n, 0));
  }
  if (!fits || caught_up_ + named > log_.size()) replay_rounds = {};
  const auto failed = [](const core::Status& s, const char* when) {
    return core::Status(s.code(), std::string("background rebuild: ") + when + s.message());
  };
  if (!status_.ok()) return failed(status_, "");
  for (int n : replay_rounds) {
    const core::Isam2Result round = CatchUp(caught_up_ + n, {.force_relinearize = true}, nullptr);
    if (!round.status.ok()) return failed(round.status, "catching up: ");
    rounds_.push_back(n);
  }
  // The rest in one update, its new variables at the live estimate, checked for relinearisation
  // as any update from messages.
  Swap swap;
  swap.update = CatchUp(log_.size(), options, &live);
  if (!swap.update.status.ok()) return failed(swap.update.status, "catching up: ");
  swap.solver = std::move(solver_);
  swap.position = std::move(position_);
  swap.rounds = std::move(rounds_);
  swap.chi2 = chi2_;
  swap.chi2_sequence = chi2_sequence_;
  return swap;
}

}  // namespace slamd::server
