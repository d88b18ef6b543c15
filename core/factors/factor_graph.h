// FactorGraph: an ordered list of shared, immutable factors. Indices are stable (a factor's index
// is its position); removal is the solvers' business (they keep their own slots).
#pragma once

#include <vector>

#include "core/factors/factor.h"

namespace slamd::core {

class FactorGraph {
 public:
  void Add(FactorPtr factor) { factors_.push_back(std::move(factor)); }
  void Replace(std::size_t i, FactorPtr factor) { factors_.at(i) = std::move(factor); }
  template <typename F, typename... Args>
  void Emplace(Args&&... args) {
    factors_.push_back(std::make_shared<const F>(std::forward<Args>(args)...));
  }

  std::size_t size() const { return factors_.size(); }
  bool empty() const { return factors_.empty(); }
  const FactorPtr& operator[](std::size_t i) const { return factors_[i]; }
  const std::vector<FactorPtr>& factors() const { return factors_; }
  auto begin() const { return factors_.begin(); }
  auto end() const { return factors_.end(); }

  // Every key of every factor exists in `values` with the type the factor expects. The message
  // names the factor (index and type) and the key.
  Status CheckAgainst(const Values& values) const;

  // Σ |R·e|² over all factors: the sum of squared whitened residuals, ignoring robust kernels.
  // (No ½: GTSAM's NonlinearFactorGraph::error() is half of this.)
  double Chi2(const Values& values) const;
  // Σ ρ(|R·e|²): the objective the solvers minimise (equals Chi2 without robust kernels).
  double Cost(const Values& values) const;

 private:
  std::vector<FactorPtr> factors_;
};

}  // namespace slamd::core
