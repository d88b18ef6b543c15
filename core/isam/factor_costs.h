// FactorCosts: Σ ρ(|R·e_f|²) over Isam2's factors at a point, for the trust region
// (Isam2Params::trust_region), which needs it at least twice per update over the whole graph: at
// the update's start and at each dog-leg trial. The start is the estimate the last update ended
// at, so most factors' costs there are those of the last evaluation: a factor's cost is reused
// when the factor and the values of its variables are bitwise those it was last evaluated with
// (on Ladybug-49 camera by camera, ~31,000 factors, only the new image's and the relinearised
// variables' factors are evaluated at the start). The others are evaluated in chunks, on a
// pool's helpers too. The sum is taken in slot order, so it is bitwise the serial loop's, with
// any number of threads.
#pragma once

#include <atomic>
#include <span>
#include <vector>

#include "core/base/worker_pool.h"
#include "core/factors/factor.h"
#include "core/factors/values.h"

namespace slamd::core {

class FactorCosts {
 public:
  // Σ Factor::Cost(at) over the non-null `factors` (by slot), `vars(f)` the slots in `at` of
  // factor f's variables. Remembers each cost and what it was evaluated with for the next call.
  template <typename VarsOf>
  double Sum(const Values& at, std::span<const FactorPtr> factors, VarsOf&& vars,
             WorkerPool* pool) {
    Snapshot(at);
    todo_.clear();
    cost_.resize(factors.size(), 0.0);
    factor_.resize(factors.size(), nullptr);
    for (int f = 0; f < static_cast<int>(factors.size()); ++f) {
      const Factor* factor = factors[f].get();
      if (factor == nullptr) continue;
      bool same = factor_[f] == factor;
      for (int v : vars(f)) same = same && !changed_[v];
      if (!same) todo_.push_back(f);
      factor_[f] = factor;
    }
    Evaluate(at, factors, pool);
    double sum = 0.0;
    for (int f = 0; f < static_cast<int>(factors.size()); ++f) {
      if (factors[f]) sum += cost_[f];
    }
    return sum;
  }
  // The factor in slot f changed (removed, or the slot reused): its cost is evaluated again.
  void Forget(int f) {
    if (f < static_cast<int>(factor_.size())) factor_[f] = nullptr;
  }
  // Everything is evaluated again (the variables' slots were renumbered).
  void Clear();
  std::size_t MemoryUse() const;

 private:
  // Marks in changed_ the variables of `at` that differ from the last call's (key or bits), and
  // keeps `at`'s for the next.
  void Snapshot(const Values& at);
  void Evaluate(const Values& at, std::span<const FactorPtr> factors, WorkerPool* pool);
  void EvaluateChunks(const Values& at, std::span<const FactorPtr> factors);

  // The last call's variables: keys and exact encodings (variable.h), by slot.
  std::vector<Key> keys_, next_keys_;
  std::vector<double> encoded_, next_encoded_;
  std::vector<int> begin_, next_begin_;  // slot v's encoding: [begin_[v], begin_[v + 1])
  std::vector<char> changed_;            // per slot of the current call
  // Per factor slot: the factor its cost was evaluated for (null: none) and the cost.
  std::vector<const Factor*> factor_;
  std::vector<double> cost_;
  std::vector<int> todo_;  // the slots to evaluate in this call
  std::atomic<int> next_{0};
};

}  // namespace slamd::core
