// Back-substitution on a Bayes tree: solving the conditionals R δ_F + S δ_S = d top-down
// (Kaess et al., iSAM2, IJRR 2012, §IV-C, Alg. 7 for the partial "wildfire" variant).
//
// The solution is one stacked vector δ over all variable ids: variable v occupies
// δ[var_offsets[v], var_offsets[v] + dim(v)) (StackedOffsets builds the offsets from the dims in
// id order, so appending variables never moves existing ones). Every clique reads its separator
// from δ (solved earlier, in an ancestor) and writes its frontals.
//
// Thread safety: pure functions of their arguments; a workspace must not be shared.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/inference/bayes_tree.h"

namespace slamd::core {

// offsets[v] = Σ_{u < v} var_dims[u]; offsets.size() == var_dims.size() + 1 (the last entry is
// the total dimension).
std::vector<int> StackedOffsets(std::span<const int> var_dims);

// δ_F = R⁻¹ (d − S δ_S) for one clique: reads δ_S from *delta, overwrites δ_F in it. Returns
// the largest absolute change of a frontal entry. If frontal_changes is non-empty (size
// num_frontals()), it receives the largest absolute change of each frontal variable.
// `scratch` is resized as needed; reuse it across calls to avoid allocation.
double SolveClique(const Clique& clique, std::span<const int> var_offsets, Eigen::VectorXd* delta,
                   std::vector<double>* scratch, std::span<double> frontal_changes = {});

// Solves every clique, parents before children. delta->size() must be at least the offset
// past the largest variable id in the tree (checked).
void BackSubstitute(const BayesTree& tree, std::span<const int> var_offsets,
                    Eigen::VectorXd* delta);

// Scratch for WildfireBackSubstitute; keep one per solver to avoid allocation per call.
// Between WildfireBegin and WildfireFinish it also holds the pass's state.
struct WildfireWorkspace {
  std::vector<double> scratch;
  std::vector<double> frontal_changes;
  std::vector<char> changed;  // per variable id: moved more than the threshold in this pass
  std::vector<char> forced;   // per clique id
  std::vector<char> visited;  // per clique id: 0, or kSolved / kSkipped by WildfireBegin
  std::vector<int> stack;
  std::vector<int> changed_vars;
  std::vector<int> forced_ids, visited_ids, path;
  double threshold = 0.0;
  bool in_pass = false;  // WildfireBegin ran and WildfireFinish has not
};

// Partial back-substitution ("wildfire"): walks down from the roots; a clique is re-solved if it
// is in `forced` (iSAM2: the re-eliminated top, which must be closed under ancestors) or one of
// its separator variables changed by more than `threshold` (max absolute entry) in this pass.
// A variable counts as changed when one of its entries moves by more than `threshold`; the walk
// does not descend below a clique that was not re-solved. threshold = 0 re-solves everything
// reachable that moved at all. Returns the number of cliques solved.
// Cost: O(cliques visited), independent of the tree size once the workspace is warm.
int WildfireBackSubstitute(const BayesTree& tree, std::span<const int> forced, double threshold,
                           std::span<const int> var_offsets, Eigen::VectorXd* delta,
                           WildfireWorkspace* workspace);

// The same pass in two parts, for a caller that needs some variables before the rest (slamd
// publishes each robot's newest pose before the rest of its map is solved). WildfireBegin
// solves, by the same rule, the cliques on the paths from the roots to `first` (clique ids),
// top down; WildfireFinish solves the rest. Each clique reads only what its ancestors solved, so
// the two parts solve the same cliques to the same values as WildfireBackSubstitute. Between
// them only the frontals of the paths' solved cliques hold their new values, and the tree and δ
// must not change. Each returns the number of cliques it solved.
int WildfireBegin(const BayesTree& tree, std::span<const int> forced, double threshold,
                  std::span<const int> first, std::span<const int> var_offsets,
                  Eigen::VectorXd* delta, WildfireWorkspace* workspace);
int WildfireFinish(const BayesTree& tree, std::span<const int> var_offsets, Eigen::VectorXd* delta,
                   WildfireWorkspace* workspace);

}  // namespace slamd::core
