// Separator summaries: what a factor graph knows about a set S of its variables, as one dense
// Gaussian factor on S (a LinearContainerFactor), less what some of its own factors on S said.
//
// This is the message of distributed smoothing over map shards (DDF-SAM: Cunningham, Paluri &
// Dellaert, IROS 2010; DDF-SAM 2.0, ICRA 2013). Two ways to use it:
//  * to each neighbour, the marginal on what they share less that neighbour's own message
//    (DDF-SAM 2.0): exact when the shards form a tree, but around a cycle of shards information
//    comes back and is counted again (the covariances shrink at every exchange);
//  * to every shard, the marginal of the shard's own factors alone on its boundary (every
//    variable it shares with anyone), with all the messages it received taken out: each shard's
//    factors then enter every other shard's graph exactly once, on any topology (slamd's map
//    shards). The messages it received reach beyond its boundary (variables two other shards
//    share); `kept_keys` then keeps the summary on the boundary, where nothing else is left.
//
// Math. At the estimate x̂ (the minimiser of the linearised problem) the graph's marginal on S is
// |L δ|² + const, LᵀL = Σ_S⁻¹ (Σ_S the joint marginal covariance, tangent at x̂). A factor f_k on a
// subset of S, linearised at x̂, is |H_k δ + r_k|²; since it touches only S, the marginal without
// it is the marginal with its term taken away:
//   Λ = Σ_S⁻¹ − Σ_k H_kᵀ H_k,   g = −Σ_k H_kᵀ r_k,   cost δᵀ Λ δ + 2 gᵀ δ.
// Λ = V diag(λ) Vᵀ (symmetric eigen-decomposition; directions with λ <= rank_tolerance · λ_max
// dropped, as S may hold variables the rest of the graph says nothing about) gives the container
// A = diag(√λ) Vᵀ, b = diag(1/√λ) Vᵀ g at x̂: |A δ + b|² equals that cost up to a constant.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/base/key.h"
#include "core/base/status.h"
#include "core/factors/factor.h"
#include "core/isam/isam2.h"
#include "core/marginals/marginals.h"

namespace slamd::core {

struct SeparatorSummaryParams {
  // Eigenvalues of Λ at most this times the largest are taken as zero; in (0, 1).
  double rank_tolerance = 1e-9;
  // The summary is on the first kept_keys keys (-1: all of them). The others only carry excluded
  // factors: what is left on them once those are taken out must be nothing (at most 1e-6 of the
  // largest entry of Λ), else FailedPrecondition.
  int kept_keys = -1;
};

// The summary on `keys` from their joint marginal covariance `joint_cov` (tangent at `at`, blocks
// in key order) with the factors `excluded` taken out; each excluded factor's keys must be among
// `keys`. nullptr when nothing is left (Λ is zero). InvalidArgument for sizes that do not match,
// a non-finite or non-symmetric covariance, an excluded factor on another variable, or
// rank_tolerance outside (0, 1) or kept_keys outside [1, keys]; FailedPrecondition when Σ_S is
// not positive definite or information is left on a key not kept.
Result<FactorPtr> SeparatorSummary(const KeyVector& keys, const std::vector<Variable>& at,
                                   const Eigen::MatrixXd& joint_cov,
                                   std::span<const FactorPtr> excluded,
                                   const SeparatorSummaryParams& params = {});

// The same for the variables of an Isam2 solver, at its estimate θ ⊕ δ, with the joint marginal
// from `marginals` (of that solver). NotFound for a key the solver does not have.
Result<FactorPtr> SeparatorSummary(const Isam2& solver, Isam2Marginals& marginals,
                                   const KeyVector& keys, std::span<const FactorPtr> excluded,
                                   const SeparatorSummaryParams& params = {});

}  // namespace slamd::core
