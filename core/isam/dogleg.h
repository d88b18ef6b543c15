// Powell's dog leg on the linear model a Bayes tree holds, for Isam2's trust-region step
// (Isam2Params::trust_region; the dog leg in iSAM2 as in Rosen, Kaess & Leonard, "RISE: An
// Incremental Trust-Region Method for Robust Online Sparse Least-Squares Estimation", T-RO 2014).
//
// The tree's conditionals R_c δ_F + S_c δ_S = d_c stack into one upper-triangular system
// R δ = d, and the linearised chi2 around the linearisation point is, up to a constant,
//     m(δ) = |R δ − d|²                      (chi2 units: no ½),
// minimised by the Gauss-Newton step R⁻¹d (back-substitution). The dog leg starts at a point p
// (Isam2: 0, the linearisation point, or the estimate before the update): around it
// m(p + h) = |R h − d_p|² + const with d_p = d − R p, the Gauss-Newton step is h = R⁻¹d − p,
// the steepest-descent direction g = Rᵀd_p, and the model's minimum along it (the Cauchy point)
// is (|g|² / |R g|²) g. The dog-leg step follows the path 0 → Cauchy point → Gauss-Newton step
// and stops at the trust-region radius; a step is judged by the ratio of the actual decrease of
// the nonlinear chi2 to the decrease m(p) − m(p + h) = 2 d_pᵀRh − |Rh|² the model predicts. The
// functions below take p as `at` (null: p = 0).
//
// Each function visits every live clique once: O(size of the tree).
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/inference/bayes_tree.h"

namespace slamd::core {

// A tree's cliques top down (BayesTree::TopDownOrder), taken once for all the sums of a step.
// The sums run in this order, fixed by the tree's shape, not by which slots the cliques took
// (that depends on the free list's history), so their rounding does not depend on it either.
struct TopDownCliques {
  explicit TopDownCliques(const BayesTree& t) : tree(t), order(t.TopDownOrder()) {}
  const BayesTree& tree;
  const std::vector<int> order;
};

// g = Rᵀd_p over the stacked δ layout (var_offsets as in back_substitution.h).
void TreeGradient(const TopDownCliques& cliques, std::span<const int> var_offsets,
                  const Eigen::VectorXd* at, Eigen::VectorXd* g, std::vector<double>* scratch);

// For a vector v in the stacked layout: |R v|² and d_pᵀ R v.
struct TreeModelTerms {
  double quadratic = 0.0;
  double linear = 0.0;
  // The decrease of m from 0 to v.
  double Decrease() const { return 2.0 * linear - quadratic; }
};

// The terms of two vectors a and b and their cross term, from one pass over the tree: those
// of any α a + β b (every point of the dog-leg path combines the Gauss-Newton step and the
// gradient) then need no further pass.
struct TreeModelPair {
  double aa = 0.0, ab = 0.0, bb = 0.0;  // (Ra)ᵀRa, (Ra)ᵀRb, (Rb)ᵀRb
  double da = 0.0, db = 0.0;            // d_pᵀRa, d_pᵀRb
  TreeModelTerms Of(double alpha, double beta) const {
    return {.quadratic = alpha * alpha * aa + 2.0 * alpha * beta * ab + beta * beta * bb,
            .linear = alpha * da + beta * db};
  }
};
TreeModelPair ModelTermsOfPair(const TopDownCliques& cliques, std::span<const int> var_offsets,
                               const Eigen::VectorXd* at, const Eigen::VectorXd& a,
                               const Eigen::VectorXd& b, std::vector<double>* scratch);

// The point of the dog-leg path 0 → cauchy → gauss_newton at distance `radius` from 0 (or
// gauss_newton itself when it lies within the radius), and its weights: *step =
// on_gauss_newton x gauss_newton + on_cauchy x cauchy. *step may not alias the inputs.
struct DoglegWeights {
  double on_gauss_newton = 0.0;
  double on_cauchy = 0.0;
};
DoglegWeights DoglegPoint(const Eigen::VectorXd& gauss_newton, const Eigen::VectorXd& cauchy,
                          double radius, Eigen::VectorXd* step);

}  // namespace slamd::core
