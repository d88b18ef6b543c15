// Chow-Liu tree sparsification of a node-removal summary (Carlevaris-Bianco, Kaess & Eustice,
// "Generic Node Removal for Factor-Graph SLAM", T-RO 2014, §V): the dense Gaussian a removal
// leaves on its Markov blanket (node_removal.h) couples every blanket variable with every other,
// so in a long run each removal's summary absorbs the last one and grows without bound. The
// Chow-Liu tree is the tree-structured Gaussian closest to it in Kullback-Leibler divergence:
// the maximum spanning tree of the pairwise mutual information, as a unary factor on its root and
// one factor per edge, p(x_i | x_parent). Every variable's marginal (mean and covariance) and
// every edge's joint marginal are those of the dense summary; the couplings off the tree are
// dropped.
// A summary of relative measurements only has no information along the global frame (its
// information matrix is singular). The tree is then made in the frame of one blanket variable
// (the "root shift" of generic linear constraints), a pose whose tangent spans the null space
// V: with N = V V_r⁺ (N_r = I), the others become y_i = δ_i − N_i δ_r, whose information is
// regular, the tree keeps every y_i's marginal, and each of its factors also touches the root,
// so nothing is added along the gauge. Null directions the root does not take (a blanket pose
// the removed factors saw only through a landmark's range and bearing; a scale) get a prior of
// 1e-9 x the mean information.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/base/status.h"
#include "core/factors/factor.h"

namespace slamd::core {

// The tree of the dense summary |A·δ + b|² on `keys` at `x0` (as a LinearContainerFactor holds
// it): LinearContainerFactors at the same linearisation point, the tree's root first, each on
// one or two of the keys plus the shifted root if there is one (then k − 1 factors for k keys,
// else k); at least 3 keys. FailedPrecondition when the information is not positive definite,
// or a tree factor would hold more information than the summary gives its variable (round-off
// where the summary is nearly singular): keep the dense one then.
Result<std::vector<FactorPtr>> ChowLiuTree(const KeyVector& keys, const std::vector<Variable>& x0,
                                           const Eigen::MatrixXd& A, const Eigen::VectorXd& b);

}  // namespace slamd::core
