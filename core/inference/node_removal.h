// Node removal: marginalising variables out of a factor graph at a linearisation point, leaving
// one dense Gaussian factor on their Markov blanket (Carlevaris-Bianco, Kaess & Eustice,
// "Generic Node Removal for Factor-Graph SLAM", T-RO 2014, the dense exact form).
//
// The factors touching the removed variables M are linearised at θ and stacked as
// |J_M δ_M + J_B δ_B + b|² (B: their other variables, the blanket). A QR factorisation of
// [J_M J_B b] gives [R_MM R_MB c_M; 0 R_BB c_B; 0 0 ρ]; minimising over δ_M leaves
// |R_BB δ_B + c_B|² + ρ², so the factor kept is the LinearContainerFactor (R_BB, c_B) at θ_B,
// re-linearised by the first-order rule elsewhere. At θ the remaining variables' marginal
// covariance and the Gauss-Newton step are exactly those of the full graph (Schur complement in
// square-root form, without squaring the Jacobian's condition), and the minimum of the
// linearised chi2 is the full graph's less the constant ρ², the misfit the removed factors leave
// at any value of the blanket.
#pragma once

#include <functional>
#include <span>
#include <vector>

#include "core/base/key.h"
#include "core/base/status.h"
#include "core/factors/factor.h"
#include "core/factors/values.h"
#include "core/inference/chow_liu.h"

namespace slamd::core {

struct NodeRemovalParams {
  // kDense: the exact summary, one container on the whole blanket. kChowLiu: its Chow-Liu tree
  // (chow_liu.h) when the blanket has 3 variables or more: every blanket variable's marginal
  // kept, the couplings off the tree dropped, so summaries stay sparse over a long run. It also
  // takes in the summaries (linear containers) already on the blanket, so that removing poses
  // where earlier removals left summaries replaces them rather than adding beside them: a
  // window over a robot driving a bounded area keeps a bounded number of factors. A
  // root-relative summary counts as on the blanket when its other variables are (its root, a
  // pose kept elsewhere, then joins the blanket): the trees of earlier visits to a place have
  // other roots, and left beside the new tree they would pile up.
  enum class Form { kDense, kChowLiu };
  Form form = Form::kDense;
  // kChowLiu on a summary of relative measurements: true for the blanket poses to make the
  // tree's root before others (chow_liu.h): variables the caller keeps, e.g. a window's
  // keyframes, since a root removed later brings its whole tree into that removal. Null: none.
  std::function<bool(Key)> prefer_root = nullptr;
  // kChowLiu on a summary of relative measurements: the frame of the tree's edges (chow_liu.h).
  // kParent keeps a long run's summaries from coupling the map through their roots, at the
  // cost of the dependence it drops.
  TreeEdgeFrame edge_frame = TreeEdgeFrame::kRoot;
  // kChowLiu: 2 conditions each tree variable on a second earlier one as well (chow_liu.h),
  // keeping more of the summary's couplings at a key more per factor.
  int tree_parents = 1;
};

struct NodeRemoval {
  // Indices in the input of the factors touching M (and, kChowLiu, of the summaries taken in).
  std::vector<int> removed_factors;
  KeyVector blanket;  // B, in order of first appearance in those factors, sorted by their keys
  FactorPtr marginal;                // the exact container on B; null when B is empty
  // What replaces the removed factors: {marginal} (kDense, a blanket of 1-2 variables, or a
  // tree ChowLiuTree refused) or its Chow-Liu tree; empty when B is empty.
  std::vector<FactorPtr> summary;
  double constant_chi2 = 0.0;        // ρ² (see the file comment)
};

// Marginalises `removed` out of `factors` (null entries skipped, as Isam2::factor_slots has
// them) at `theta`, which holds every variable of the factors touching them. Errors:
// InvalidArgument for an empty, repeated or unknown key in `removed` or tree_parents outside
// 1-2; FailedPrecondition naming the variable when its factors do not determine it (its block
// of R_MM is singular: nothing to marginalise, e.g. a landmark with one bearing), as a marginal
// would be undefined.
Result<NodeRemoval> MarginalizeOut(std::span<const FactorPtr> factors, const Values& theta,
                                   std::span<const Key> removed,
                                   const NodeRemovalParams& params = {});

}  // namespace slamd::core
