// Multifrontal elimination of a linearised factor graph into a Bayes tree with supernodal
// cliques, on dense Eigen blocks (Kaess et al., iSAM2, IJRR 2012, Alg. 2; the multifrontal
// method of Duff & Reid / Liu).
//
// One call eliminates the variables listed in `ordering`, in that order, and adds the resulting
// cliques to a BayesTree. The same call serves
//   * full elimination: all variables, all factors, an empty tree;
//   * iSAM2's partial re-elimination of the top: after BayesTree::RemoveTop(), the removed
//     frontals (plus new variables) in a constrained order, the factors all of whose variables
//     are among them, and the cached factors of the orphaned subtrees as extra HessianFactors.
//     EliminationResult::hessian_cliques[i] is the new clique that absorbed hessians[i]; attach
//     orphan i under it (BayesTree::Attach(orphan, hessian_cliques[i])) to complete the tree.
//
// Steps (numbered in elimination.cc):
//   1. validate and number the variables by position; assign each factor to its first-
//      eliminated variable;
//   2. symbolic phase: separators and fundamental supernodes (symbolic_elimination.h);
//   3. numeric phase, cliques bottom-up: assemble the dense augmented Hessian over frontals +
//      separator (+ rhs) from the clique's factors and its children's cached factors, partial
//      Cholesky on the frontal block (partial_cholesky.h) giving [R S d] and the cached factor.
//
// Supernodes: a variable joins its only child clique when that adds no fill (fundamental
// supernodes). A chain in natural order therefore gives n − 1 cliques ({x_i | x_{i+1}}, root
// {x_{n-2}, x_{n-1}}); dense blocks such as loop closures give large cliques. A Hessian factor
// counts as a child for this rule (it summarises an orphaned subtree), so re-eliminating a top
// with the orphans' cached factors reproduces the full elimination's cliques exactly.
//
// Conventions: the factors minimise Σ|A δ + b|², so the conditionals satisfy R δ_F + S δ_S = d
// and back-substitution gives the solution of AᵀA δ = −Aᵀb.
//
// Failure modes (the tree is left exactly as before the call):
//   * kInvalidArgument: a variable listed twice or out of range or already frontal in the tree,
//     dims that disagree with var_dims, a factor touching a variable not in `ordering`, a null
//     factor, or invalid params.
//   * kNumericalFailure: a frontal pivot not positive relative to the information that flowed
//     into that scalar (an indeterminate system, e.g. no prior/gauge, or a non-finite input; see
//     EliminationParams); the message names the variable id and
//     EliminationResult::failed_variable holds it, so the caller can name the Key.
//
// Complexity: O(work of the cliques created) — nothing proportional to the total number of
// variables once the Eliminator's workspace has grown to it, so small top re-eliminations are
// cheap. Thread safety: one Eliminator per thread (it owns scratch buffers); a call may use
// several threads of its own (Eliminator's `threads`).
#pragma once

#include <span>
#include <vector>

#include "core/base/status.h"
#include "core/base/worker_pool.h"
#include "core/inference/bayes_tree.h"
#include "core/inference/hessian_factor.h"
#include "core/inference/jacobian_factor.h"
#include "core/inference/subtree_split.h"
#include "core/inference/symbolic_elimination.h"

namespace slamd::core {

namespace internal {
// A factor's column block as the assembly loops see it.
struct ScatterBlock {
  int target;  // offset in the clique matrix
  int dim;
  int source;  // Jacobian: first column; Hessian: offset in info
};
}  // namespace internal

struct EliminationParams {
  // A frontal scalar's pivot must exceed relative_pivot_tolerance times its reference: the
  // information that flowed into it (squared Jacobian column norms of its factors, plus the
  // references carried by cached/extra Hessian factors, plus the propagated round-off bound of
  // earlier pivots; see partial_cholesky.h). The pivot of an unconstrained direction is
  // round-off: measured <= 3e-15 of the reference (M3500 without a prior, natural / reversed /
  // COLAMD orders; random singular chains <= 2e-17). Determined systems sit far above (M3500
  // with a prior of sigma 1: >= 1e-7; sigma 1e3: ~1e-14, i.e. that weak a gauge is rejected).
  // Default 1e-13; range [0, 1). 0 accepts every positive pivot.
  double relative_pivot_tolerance = 1e-13;
  // Merge fundamental supernodes (default true). false gives one clique per variable (the
  // elimination tree), useful to compare against and for debugging.
  bool merge_supernodes = true;
  // Relaxed supernodes (with merge_supernodes): a variable also joins its single child's clique
  // when its own factors bring at most `relaxed_new_variables` variables that clique's
  // separator lacks, while the clique has fewer than `relaxed_max_frontals` frontals
  // (symbolic_elimination.h). Pose graphs with many loop closures add one such variable per
  // pose, so their cliques stay at one pose each otherwise; the merged cliques carry a few
  // explicit zeros but need less assembly and copying per variable, and there are fewer of
  // them to solve. `slamctl bench F --solver isam2`, 5 interleaved runs each: parking-garage
  // (3D) total 0.495 -> 0.434 s, p99 step 4.42 -> 3.42 ms; victoriaPark total 1.039 -> 0.911 s;
  // 2D pose graphs about even. The cap keeps the cliques that every update re-eliminates (at
  // the root) small. 0 = fundamental supernodes only.
  int relaxed_new_variables = 1;
  int relaxed_max_frontals = 4;  // >= 1

  Status Validate() const;
};

// What to eliminate. The spans must stay valid during the call; nothing is kept afterwards.
struct EliminationProblem {
  // Dimension of every variable id (entries for ids not eliminated are not read).
  std::span<const int> var_dims = {};
  // Factors on the eliminated variables; each touches only variables in `ordering`.
  std::span<const JacobianFactor* const> factors = {};
  // Extra information-form factors (iSAM2: cached factors of orphans), same rule.
  std::span<const HessianFactor* const> hessians = {};
  // The variables to eliminate, first-eliminated first.
  std::span<const int> ordering = {};
};

struct EliminationResult {
  // Cliques created, children before parents (a topological order). Concatenating their
  // frontals gives the effective elimination order: equivalent to `ordering` (same fill), with
  // each clique's frontals contiguous and in their `ordering` order.
  std::vector<int> cliques;
  // hessian_cliques[i]: the created clique whose assembly absorbed hessians[i] (its first-
  // eliminated variable is frontal there).
  std::vector<int> hessian_cliques;
  // On kNumericalFailure: the variable whose pivot failed; otherwise -1.
  int failed_variable = -1;
  // Threads that eliminated the cliques (1, or the Eliminator's `threads` for a large call).
  int threads_used = 1;
};

class Eliminator {
 public:
  // `threads` (>= 1; checked) eliminate the cliques of a large call in parallel: a clique needs
  // only its children's cached factors, so disjoint subtrees are independent; each thread takes
  // whole subtrees, then the calling thread the cliques above them. Each clique is computed
  // exactly as by one thread (same assembly order), so the tree is bitwise the same for any
  // thread count. Calls whose estimated work is below kParallelMinWork run on the
  // calling thread alone (starting a thread costs more than they take).
  explicit Eliminator(EliminationParams params = {}, int threads = 1);

  // Estimated work (≈ multiply-adds of assembly and partial Cholesky) from which a call uses
  // `threads`: about half a millisecond on one core.
  static constexpr double kParallelMinWork = 1.5e6;

  // Eliminates problem.ordering into *tree (see the file comment). *result is overwritten.
  Status Eliminate(const EliminationProblem& problem, BayesTree* tree, EliminationResult* result);

  const EliminationParams& params() const { return params_; }
  int threads() const { return threads_; }

 private:
  // One thread's scratch for eliminating cliques.
  struct Workspace {
    std::vector<int> offset;  // per variable id: scalar offset inside the clique being assembled
    std::vector<int> frontal_ids, frontal_dims, sep_ids, sep_dims;
    std::vector<double> ref;     // pivot references of the clique's scalars
    std::vector<double> matrix;  // the clique's dense augmented matrix
    std::vector<internal::ScatterBlock> scatter_blocks;
    int failed_variable = -1;  // set by a failing EliminateClique
  };

  Status Prepare(const EliminationProblem& problem, const BayesTree& tree);
  // Lists clique sym's frontals (elimination order) and separator, with their dims, in *ws and
  // sets the pre-created clique tree_id_[sym] to that structure (its storage sized).
  void ShapeClique(const EliminationProblem& problem, int sym, BayesTree* tree,
                   Workspace* ws) const;
  // Fills the pre-created clique tree_id_[sym] (no links: LinkCliques does them), shaping it
  // first unless `shaped`. Touches only that clique, *ws and hessian_cliques entries of its own
  // Hessian factors.
  Status EliminateClique(const EliminationProblem& problem, int sym, BayesTree* tree, Workspace* ws,
                         std::vector<int>* hessian_cliques, bool shaped = false) const;
  Status EliminateSerial(const EliminationProblem& problem, BayesTree* tree,
                         EliminationResult* result);
  // Returns false when some clique failed (nothing is reported: the caller re-runs serially,
  // so that the failure named is the first in creation order, as with one thread).
  bool EliminateParallel(const EliminationProblem& problem, BayesTree* tree,
                         EliminationResult* result);
  // Fills clique_nf_ and clique_ns_: each clique's frontal and separator dimension.
  void CliqueDims(const EliminationProblem& problem);
  // Fills work_ and subtree_work_ of the forest (after CliqueDims); returns the total.
  double EstimateWork();
  // Fills owner_: the thread that eliminates each clique, or -1 for the top (see the .cc).
  void AssignSubtrees();
  void ResetPositions(std::span<const int> ordering);

  EliminationParams params_;
  int threads_;
  // Per variable id (sized to the largest var_dims seen; entries reset after each call).
  std::vector<int> pos_;  // position in the current ordering, or -1
  // Per position / per scalar of the current call.
  std::vector<int> jac_ptr_, jac_list_, hes_ptr_, hes_list_;  // factors assigned per position
  std::vector<int> first_;                                    // per factor: first position
  std::vector<int> cursor_, structure_cursor_;                // CSR fill cursors
  std::vector<int> structure_ptr_, structure_pos_;            // their variables' positions
  std::vector<int> tree_id_;                                  // symbolic clique -> tree id
  std::vector<int> clique_nf_, clique_ns_;                    // per clique: dims
  std::vector<double> work_, subtree_work_;                   // per clique: estimated work
  std::vector<int> owner_;                                    // per clique: thread or -1
  std::vector<int> roots_;                                    // cliques without a parent
  SubtreeSplit split_;
  std::vector<Workspace> workspaces_;                         // one per thread
  WorkerPool pool_;                                           // threads_ - 1 helpers
  internal::SymbolicForest forest_;
  internal::SymbolicWorkspace symbolic_workspace_;
};

// One-shot convenience: Eliminator(params).Eliminate(problem, tree, result), one thread.
Status Eliminate(const EliminationProblem& problem, BayesTree* tree, EliminationResult* result,
                 const EliminationParams& params = {});

}  // namespace slamd::core
