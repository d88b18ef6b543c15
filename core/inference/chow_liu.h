// Chow-Liu tree sparsification of a node-removal summary (Carlevaris-Bianco, Kaess & Eustice,
// "Generic Node Removal for Factor-Graph SLAM", T-RO 2014, §V): the dense Gaussian a removal
// leaves on its Markov blanket (node_removal.h) couples every blanket variable with every other,
// so in a long run each removal's summary absorbs the last one and grows without bound. The
// Chow-Liu tree is the tree-structured Gaussian closest to it in Kullback-Leibler divergence:
// the maximum spanning tree of the pairwise mutual information, as a unary factor on its root and
// one factor per edge, p(x_i | x_parent). Every variable's marginal (mean and covariance) and
// every edge's joint marginal are those of the dense summary; the couplings off the tree are
// dropped.
// The summary of relative measurements has no information along the global frame (its
// information matrix is singular): the covariance is taken of the information plus
// kRegularization x its mean diagonal on the diagonal, which the root's unary factor carries
// (information ~1e-9 of the summary's in those directions).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/base/status.h"
#include "core/factors/factor.h"

namespace slamd::core {

// The tree of the dense summary |A·δ + b|² on `keys` at `x0` (as a LinearContainerFactor holds
// it): LinearContainerFactors on one or two of the keys at the same linearisation point, root
// first; at least 3 keys. FailedPrecondition when the regularised information is not positive
// definite (non-finite entries), or a tree factor would hold more information than the summary
// gives its variable (round-off where the summary is nearly singular): keep the dense one then.
Result<std::vector<FactorPtr>> ChowLiuTree(const KeyVector& keys, const std::vector<Variable>& x0,
                                           const Eigen::MatrixXd& A, const Eigen::VectorXd& b);

}  // namespace slamd::core
