// Isam2: incremental smoothing and mapping on the Bayes tree, after Kaess, Johannsson, Roberts,
// Ila, Leonard & Dellaert, "iSAM2: Incremental Smoothing and Mapping Using the Bayes Tree"
// (IJRR 2012), Algorithms 2-7.
//
// The solver keeps
//   θ  the linearisation point of every variable (Values; a variable's id is its slot there),
//   the nonlinear factors and their cached linearisations at θ (JacobianFactor per factor),
//   the Bayes tree of the linearised system, and
//   δ  its solution, so that the estimate is θ ⊕ δ.
// Update() adds factors and variables, relinearises variables whose δ has grown past a threshold
// or one of whose factors is no longer well approximated by its linearisation at θ ⊕ δ (fluid
// relinearisation, every `skip` updates; see Relinearization::error_threshold), removes from
// the tree the cliques those touch together with their ancestors (the "top"), re-eliminates the
// top with its original factors plus the cached factors of the orphaned subtrees, in a
// constrained COLAMD order that puts the newest variables last, re-attaches the orphans and
// back-substitutes from the top down until the change falls under the wildfire threshold. An
// odometry-only step so touches only the cliques near the newest pose: its cost does not grow.
//
// Errors: invalid input (unknown or duplicate keys, wrong types, non-finite values, bad factor
// indices) returns a status and changes nothing; a numerical failure (an indeterminate system,
// e.g. a new robot with no prior, a landmark with a single bearing) returns a status naming a
// variable and restores the solver to its state before the call: the estimate exactly, the tree
// re-eliminated in its old order (the same factorisation to rounding), but for caches of work.
//
// Thread safety: not thread-safe; one thread drives a solver (the server's estimator thread).
// Large steps use Isam2Params::threads internally; results do not depend on their number.
#pragma once

#include <array>
#include <atomic>
#include <limits>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

#include "core/base/worker_pool.h"
#include "core/factors/factor_graph.h"
#include "core/inference/back_substitution.h"
#include "core/inference/bayes_tree.h"
#include "core/inference/elimination.h"
#include "core/inference/jacobian_factor.h"
#include "core/inference/node_removal.h"
#include "core/inference/variable_index.h"
#include "core/isam/factor_costs.h"
#include "core/isam/isam2_params.h"
#include "core/isam/isam2_result.h"
#include "core/linear/ordering.h"

namespace slamd::core {

class Isam2 {
 public:
  // Refine's wildfire threshold relative to refine_threshold (see Refine).
  static constexpr double kRefineWildfire = 0.1;
  // Linearisation-error screen (FindStaleLinearizations): a factor predicted below kStaleScreen x
  // Relinearization::error_threshold is not evaluated (the prediction may be off by this factor
  // before a stale linearisation goes unnoticed); an error below kErrorFloor x it counts as that.
  static constexpr double kStaleScreen = 0.25;
  static constexpr double kErrorFloor = 0.01;
  // Trust region: a model decrease below this x (1 + cost) is round-off (Gauss-Newton taken).
  static constexpr double kNegligibleDecrease = 1e-12;

  // kInvalidArgument (naming the field) when params are invalid.
  static Result<std::unique_ptr<Isam2>> Create(const Isam2Params& params = {});

  // One incremental step (see the file comment). `new_values` holds an initial guess for every
  // variable that `new_factors` introduce, and nothing else.
  Isam2Result Update(const FactorGraph& new_factors, const Values& new_values,
                     const Isam2UpdateOptions& options = {});

  // Idle-time refinement ("settling"): relinearises the variables whose δ exceeds
  // Isam2Params::refine_threshold (at most refine_max_variables per round, the most changed
  // first) and re-solves, until none does (converged) or `budget_s` has passed: the estimate
  // approaches the batch optimum. Each round is a Gauss-Newton step through the tree, back-
  // substituted partially (threshold kRefineWildfire x refine_threshold: a full solve is
  // O(variables) a round). A round that raises chi2 is taken unless trust_region is on.
  struct RefineResult {
    Status status;
    int rounds = 0;
    int relinearized_variables = 0;
    bool converged = false;
    double seconds = 0.0;
  };
  // At most `max_rounds` rounds (a journal replay repeats a refinement by its round count).
  RefineResult Refine(double budget_s, int max_rounds = std::numeric_limits<int>::max());

  // Node removal (core/inference/node_removal.h): `keys` are marginalised out at θ (or at `at`,
  // values of them and their blanket: a journal replay of a live removal) into a summary on their
  // Markov blanket (dense, or its Chow-Liu tree), which replaces their factors. Only the cliques
  // of those factors and their ancestors are re-eliminated; the other variables are renumbered
  // (O(variables + factors), no arithmetic). Dense: the remaining marginals and linear system at
  // θ are exactly the full graph's: the estimate does not move. Factor indices stay.
  Isam2RemovalResult RemoveVariables(std::span<const Key> keys,
                                     const NodeRemovalParams& params = {},
                                     const Values* at = nullptr);

  // The rest of the back-substitution an Update with Isam2UpdateOptions::solve_first left; no-op
  // without one. Returns the number of cliques it solved.
  int FinishBackSubstitution();
  // An Update with solve_first left part of its back-substitution for FinishBackSubstitution.
  bool back_substitution_pending() const { return wildfire_.in_pass; }

  // θ ⊕ δ for every variable (O(n)), or for one (O(1); the key must exist, checked).
  Values CalculateEstimate() const;
  Variable CalculateEstimate(Key key) const;
  // Σ|R·e|² of all current factors at the estimate (O(factors)).
  double Chi2() const;

  const Values& linearization_point() const { return theta_; }
  // The current update δ of the variable in `slot` (linearization_point().SlotOf(key)): its
  // estimate is θ ⊕ δ. Valid until the next Update or Refine.
  const double* Delta(int slot) const {
    if (wildfire_.in_pass) CheckSolvedFirst(slot);
    return delta_.data() + offsets_[slot];
  }
  // The current factors (removed ones left out), in index order.
  FactorGraph Factors() const;
  // Every factor by its index (Isam2Result::new_factor_indices); null once removed. A removed
  // factor's index is given to a later factor with as many keys (after the update that removed
  // it stands), so that a lifelong stream of replaced factors does not grow these arrays.
  const std::vector<FactorPtr>& factor_slots() const { return factors_; }
  const BayesTree& tree() const { return tree_; }
  Isam2Memory MemoryUse() const;  // O(variables + factors + cliques)
  // For idle time: storage kept for reuse (BayesTree::TrimStorage, work arrays) given back.
  void TrimMemory();
  const Isam2Params& params() const { return params_; }
  int num_updates() const { return num_updates_; }

 private:
  explicit Isam2(const Isam2Params& params);
  // Update() with the relinearisation and wildfire thresholds given (Refine uses tiny ones).
  Isam2Result UpdateWith(const FactorGraph& new_factors, const Values& new_values,
                         const Isam2UpdateOptions& options,
                         const Isam2Params::Relinearization& relinearization,
                         double wildfire_threshold);

  // Step helpers (isam2_steps.cc, isam2_relinearization.cc); inputs by const&, outputs by pointer.
  // Every helper that changes state records how to undo it in undo_.
  Status CheckInput(const FactorGraph& new_factors, const Values& new_values,
                    const Isam2UpdateOptions& options) const;
  void AddVariables(const Values& new_values);
  Status AddFactors(const FactorGraph& new_factors, std::vector<int>* indices);
  void RemoveFactors(const std::vector<int>& indices, std::vector<int>* affected);
  // Lists in *relin the variables to relinearise now (at most max_variables, most changed
  // first); returns how many are due (over the threshold), before that cap. *screened: the
  // variables whose factors the linearisation-error check walked.
  int SelectRelinearization(const Isam2UpdateOptions& options, bool all,
                            const Isam2Params::Relinearization& thresholds, std::vector<int>* relin,
                            int* screened);
  // Linearisation-error check (Relinearization::error_threshold). The error of a factor's
  // linearisation at the estimate, d_f = |r_f(θ ⊕ δ) − (A_f·δ + b_f)| (whitened), is second
  // order in δ_f: d_f ≈ κ_f·s_f with s_f = StepSize(f). Each factor keeps κ_f from its last
  // evaluation, and each variable a budget on |δ_v|² within which none of its factors can be
  // predicted above kStaleScreen x threshold. SelectRelinearization lists the variables over
  // budget (over_budget_); this evaluates, at θ ⊕ δ, those of their factors that are predicted
  // above kStaleScreen x threshold or were never evaluated, raises ratio_ of the variables of
  // each factor with d_f > threshold to d_f / threshold, and renews the budgets. Leaves θ as it
  // was. Cost: O(factors of the variables over budget) (see the definition for why).
  void FindStaleLinearizations(double threshold);
  // |δ_nl|·|δ_f| for factor f: the scale of its linearisation error. δ_nl: the rotation
  // entries of a factor on poses only (a pose's translation enters such residuals linearly but
  // for products with its rotation), every entry of a factor on a point. Only during
  // FindStaleLinearizations (reads step_norms_ of the variables over budget).
  double StepSize(int f) const;
  // Evaluates probe_factors_ (see above).
  void ProbeLinearizations(double threshold);
  // Moves θ of `relin` to θ ⊕ δ and appends the variables of their factors to *affected. The
  // factors are linearised there by the threads (params_.threads) in the background while the
  // top is removed and ordered (steps 4-6, which read only the structure, FactorVars); the
  // calling thread joins in and waits in FinishRelinearization, before eliminating.
  void Relinearize(const std::vector<int>& relin, std::vector<int>* affected, int* num_factors);
  // Linearises the relinearised factors not yet taken, waits for the threads; the first error.
  // Idempotent: without a relinearisation in progress it returns Ok at once.
  Status FinishRelinearization();
  // Takes chunks of relin_factors_ until none is left (one thread's share of the work).
  void LinearizeChunks();
  Status ReEliminate(const std::vector<int>& affected, const std::vector<int>& last,
                     std::vector<int>* new_cliques, Isam2Result* result);
  // Eliminates elim_vars_ with every factor inside them and orphans_' cached factors, then
  // re-attaches the orphans. `last` (ids) are constrained to the end of the ordering.
  Status EliminateTop(const std::vector<int>& last, std::vector<int>* new_cliques,
                      Isam2Result* result);
  // Collects those factors (elim_jacobians_, elim_hessians_), with `incidence` their structure
  // in the local numbering (mark_); then eliminates order_ from them into the tree.
  void CollectTop(FactorIncidence* incidence);
  Status EliminateOrdered(std::vector<int>* new_cliques);
  void RebuildReleasedTop();  // Rollback of a released top: released_order_ eliminated again
  // Solves the tree from the new cliques down (all of it when `full`); with `first` (keys) only
  // the paths to them, leaving the rest for FinishBackSubstitution.
  int BackSubstitute(const std::vector<int>& new_cliques, bool full, double wildfire_threshold,
                     const std::vector<Key>& first);
  // Aborts unless the slot's δ is final while a back-substitution is pending (solve_first).
  void CheckSolvedFirst(int slot) const;
  // Aborts while a back-substitution is pending: `what` needs all of δ or changes the solver.
  void CheckNoPendingSolve(const char* what) const;
  Status LinearizeFactor(int index);
  // 9. Isam2Params::trust_region: replaces the Gauss-Newton δ by the dog-leg step (dogleg.h) that
  // lowers the (robust) cost below the cost at θ ⊕ start_ (else at θ), adapting radius_.
  Isam2Result::TrustRegion TrustRegionStep();
  // Σ Factor::Cost at θ ⊕ step (at θ when null): the trust region's cost (factor_costs.h).
  double CostAt(const Eigen::VectorXd* step);
  // θ ⊕ step (step in δ's layout).
  Values RetractedBy(const Eigen::VectorXd& step) const;
  // Restores the state before the current update (after a numerical failure).
  void Rollback();
  // The update stands: the detached top's cliques and the removed factors' slots go to reuse.
  void ReleaseRemoved();
  // Drops the variables `dead` (ids, in no factor and no clique) and renumbers the rest in
  // order: θ, δ, the per-variable arrays, the factors' and the tree's ids (isam2_removal.cc).
  void DropVariables(const std::vector<int>& dead);

  // What one update changed, so that a numerical failure can restore the state before it.
  struct Undo {
    int num_vars = 0;  // variables and factors beyond these counts are new
    int num_factors = 0;
    std::vector<std::pair<int, FactorPtr>> removed_factors;
    std::vector<int> reused_slots;  // slots of free_slots_ the new factors took, in order
    std::vector<int> relinearized;  // relinearised variables, in order, with their old θ
    std::vector<double> theta, delta;       // exactly encoded (variable.h) and old δ, concatenated
    std::vector<int> relinearized_factors;  // re-linearised at the restored θ on rollback
    bool top_removed = false;  // the tree's top was detached (removed_frontals_, orphans_)
    bool top_released = false;          // ... and released before eliminating (released_order_)
    void Clear(int vars, int factors);  // keeps the lists' storage; and once the update
    void GiveBackLargeStorage();        // stands, gives back large ones (isam2_steps.cc)
  };

  Isam2Params params_;
  Values theta_;                            // linearisation point; var id = slot
  std::vector<int> dims_;                   // tangent dimension per var id
  std::vector<VariableType> var_types_;     // per var id
  // Per variable type: its first rotation entry (the rotation entries are its last ones), or -1.
  std::array<int, kNumVariableTypes> rotation_begin_;
  std::vector<int> offsets_;                // δ offsets per var id (size n + 1)
  Eigen::VectorXd delta_;                   // solution of the linearised system (tail unused)
  double radius_;                           // trust-region radius (Isam2Params::trust_region)
  Eigen::VectorXd start_, gauss_newton_, gradient_, cauchy_, step_;  // TrustRegionStep's
  std::vector<double> dogleg_scratch_;
  FactorCosts costs_;                       // CostAt's
  std::vector<FactorPtr> factors_;          // by factor index; null once removed
  // Null slots free for a new factor, by its number of keys (the slot's share of
  // factor_var_ids_ is that long); each list used as a stack.
  std::vector<std::vector<int>> free_slots_;
  std::vector<JacobianFactor> linearized_;  // cached linearisation of each factor at θ
  // Linearisation-error screen (FindStaleLinearizations): per factor κ_f, or -1 before its
  // first evaluation; per variable the |δ_v|² budget per unit of kStaleScreen x threshold
  // (0: evaluate its factors as soon as δ_v moves).
  std::vector<float> curvature_;
  std::vector<double> budget_;
  // Per variable |δ_v|² when all its factors last passed the screen over budget (-1: not so);
  // while δ_v is exactly that, they are not walked again.
  std::vector<double> screened_norm2_;
  // Per factor its variable ids, compact for the screen (linearized_ is large): factor f's are
  // factor_var_ids_[factor_var_begin_[f] .. factor_var_begin_[f + 1]).
  std::vector<int> factor_var_begin_{0};
  std::vector<int> factor_var_ids_;
  std::span<const int> FactorVars(int f) const {
    return {factor_var_ids_.data() + factor_var_begin_[f],
            static_cast<std::size_t>(factor_var_begin_[f + 1] - factor_var_begin_[f])};
  }
  // k_f in the screen's budget 1 / (κ_f k_f): a bound on the factor's keys, at least 2 (the
  // budgets of unary and binary factors are the same, as they were tuned).
  int BudgetKeys(int f) const {
    return std::max(2, factor_var_begin_[f + 1] - factor_var_begin_[f]);
  }
  VariableIndex variable_index_;
  BayesTree tree_;
  Eliminator eliminator_;
  int num_updates_ = 0;
  bool relinearization_backlog_ = false;  // the last check left due variables (cap, deferral)

  std::vector<double> probe_error_;  // a probed factor's error and its linear model's misfit
  // Scratch reused across updates (no allocation per step once warm).
  std::vector<int> mark_;  // per var id: 0, or 1 + position in the current elimination set
  std::vector<int> removed_frontals_, orphans_, elim_vars_, elim_factors_, order_;
  std::vector<int> removing_;  // RemoveVariables: ids ReEliminate leaves out
  std::vector<int> released_order_;  // the released top's elimination order (Undo::top_released)
  std::vector<const JacobianFactor*> elim_jacobians_;
  std::vector<const HessianFactor*> elim_hessians_;
  std::vector<double> ratio_;           // per var id: how far over the relinearisation thresholds
  std::vector<char> probe_mark_;        // per factor: 0 between uses
  std::vector<char> over_budget_mark_;  // per var id: 0 between uses
  std::vector<std::pair<double, double>> step_norms_;  // per var id: |δ_v|², rotation part
  std::vector<int> over_budget_, screened_, probe_factors_, probe_vars_;
  std::vector<double> probe_weights_, probe_sizes_;
  std::vector<Variable> probe_saved_;
  WildfireWorkspace wildfire_;     // in_pass: Update with solve_first left a part for later
  std::vector<int> solved_first_;  // ... and these slots' δ is final
  Undo undo_;
  // Relinearisation in progress (Relinearize .. FinishRelinearization): the factors, the next
  // chunk to take, whether helpers are on it, and the first failure (guarded by relin_mutex_).
  std::vector<int> relin_factors_;
  std::atomic<int> relin_next_{0};
  bool relin_running_ = false;
  std::mutex relin_mutex_;
  Status relin_status_;
  WorkerPool relin_pool_;  // threads - 1 helpers; last, so that it stops before the rest goes
};

}  // namespace slamd::core
