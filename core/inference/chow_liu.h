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
// information matrix is singular). The tree is then made in the frame of one blanket pose (the
// "root shift" of generic linear constraints), the one the null space V spans best, preferring
// those the caller keeps: the others become y_i = δ_i − N_i δ_r, N the rigid motion of all of
// them with the root's δ_r, whose information is regular; the tree keeps every y_i's marginal,
// and its factors are LinearContainerFactors in the root-relative form (each variable taken in
// the root's frame, y to first order), so that a rigid correction of the whole region, as a
// loop closure makes, leaves them as they were. A summary that does see that motion (AN ≠ 0), or
// has no pose to shift to, is shifted linearly along V (N = V V_r⁺) instead. Null directions
// the root does not take (a blanket pose the removed factors saw only through one landmark's
// range and bearing; a scale) get a prior of 1e-9 x the mean information.
// In the root's frame every factor of such a tree holds the root: over a long run of removals
// whose trees have different roots, those roots tie ever more of the map together (fill-in of
// the Bayes tree, its memory and update time growing while the graph does not). With
// TreeEdgeFrame::kParent an edge p(y_i | y_p) = |W (y_i − K y_p − c)|² goes on fewer keys where
// that drops a term below 0.05 of |W N_i^p| (N^p: the rigid motion of the child with its parent,
// the coupling a summary of relative measurements mostly has): in the parent pose's frame,
// |W (z_i − c)|² with z_i the child there (y_i − N_i^p y_p to first order: drops W (N_i^p − K)
// y_p), where the conditional carries the child along with its parent; or the child alone in
// the root's frame, |W (y_i − c)|² (drops W K y_p), where the parent says next to nothing of it.
// Other edges keep the root. (A shifted tree is rooted at the pose closest to the root, the
// smallest covariance in its frame, so that its edges run out from the root as the summary's
// links do: a chain's are then all exact.) In the lifelong soak's trees about 80 % of the edges
// go in a parent's frame and 8 % alone.
// With parents = 2 each variable after the tree's first two is also conditioned on a second
// earlier one (in tree order), the one with the largest conditional mutual information given its
// tree parent: a Bayes net of at most two parents a variable, p(y_i | y_p, y_q), whose
// divergence from the dense summary is the tree's less the sum of those informations (the net's
// divergence is Σ_i H(y_i | parents) − H(y)). The marginals are then no longer all exact, but
// the couplings kept are. kParent puts such a factor in the tree parent's frame (the child and
// the second parent taken there) on the same rule.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/base/status.h"
#include "core/factors/factor.h"

namespace slamd::core {

// The tree of the dense summary |A·δ + b|² on `keys` at `x0` (as a LinearContainerFactor holds
// it): LinearContainerFactors at the same linearisation point, the tree's root first, each on
// one or two of the keys plus the shifted root if there is one (then k − 1 factors for k keys,
// else k; kParent: most edges on fewer, see above); at least 3 keys.
// `preferred` (empty, or a flag per key): poses to shift to before the others. `parents`: 1 (the
// tree) or 2 (factors on up to three of the keys, and the root).
// FailedPrecondition when the information is not positive definite, or a tree factor would hold
// more information than the summary gives its variable (round-off where the summary is nearly
// singular): keep the dense one then.
enum class TreeEdgeFrame { kRoot, kParent };
Result<std::vector<FactorPtr>> ChowLiuTree(const KeyVector& keys, const std::vector<Variable>& x0,
                                           const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                           std::span<const char> preferred = {},
                                           TreeEdgeFrame edge_frame = TreeEdgeFrame::kRoot,
                                           int parents = 1);

}  // namespace slamd::core
