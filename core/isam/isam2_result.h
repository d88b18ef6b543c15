// Per-call options of Isam2::Update and the result it returns (kept apart from the per-instance
// Isam2Params, as GTSAM splits ISAM2Params / ISAM2UpdateParams / ISAM2Result).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/base/key.h"
#include "core/base/status.h"
#include "core/factors/values.h"

namespace slamd::core {

struct Isam2UpdateOptions {
  // Factor indices (as returned in Isam2Result::new_factor_indices of earlier updates) to remove,
  // e.g. a loop closure found to be wrong. Removing leaves the result as if the factor had never
  // been added.
  std::vector<int> remove_factors = {};
  // Variables to re-eliminate even though no new factor touches them.
  std::vector<Key> extra_reeliminate = {};
  // Variables to order last (nearest the root) among those this update re-eliminates, in place
  // of the variables of the new factors. A solver given a whole graph in one update (slamd's
  // rebuild) would otherwise order it freely, and a newest pose could land deep in the tree, where
  // each following update, which touches it, re-eliminates the path to the root.
  std::vector<Key> order_last = {};
  // Variables that must not be relinearised in this update.
  std::vector<Key> no_relinearize = {};
  // Relinearise every variable whose update exceeds the threshold now, whatever the skip count.
  bool force_relinearize = false;
  // Relinearise every variable and re-eliminate everything (the batch step).
  bool force_full = false;
  // Back-substitute into every clique (ignore the wildfire threshold).
  bool force_full_solve = false;
  // When more variables than this are due for relinearisation, relinearise none of them and
  // report how many in Isam2Result::relinearization_deferred (they stay due: the check runs
  // again at the next update). For a caller that relinearises everything elsewhere: slamd
  // rebuilds the solver at the current estimate on another thread rather than stall its message
  // stream for the largest steps. Such steps relinearise most of the graph; left undone, the
  // linearisation point falls behind, so a caller must not defer without rebuilding.
  // 0 = never defer. Ignored by the batch step (force_full, batch_every).
  int defer_relinearization_above = 0;
  // Keys whose estimates the caller needs before the rest of the map (slamd: each robot's newest
  // pose, published before the rest is solved). When non-empty, the back-substitution solves the
  // cliques on the paths from the roots to these keys and Update returns; the rest of it waits
  // for Isam2::FinishBackSubstitution(), which gives the same δ as without this option. Until
  // then only these keys' estimates and δ may be read and nothing else of the solver may be
  // called (checked: it aborts). Ignored by a full solve (force_full_solve, the batch step).
  std::vector<Key> solve_first = {};
  // No relinearisation check in this update (what is due stays due). slamd's estimator while
  // its rebuild is in flight: the rebuild relinearises everything, and the check costs a scan of
  // every δ and evaluations of factors (4-6 ms per update on victoriaPark with a large backlog).
  // Ignored by the batch step.
  bool skip_relinearization = false;
};

struct Isam2Result {
  // Not ok on invalid input (nothing changed) or a numerical failure (message names the
  // variable; the solver is left as it was before the call).
  Status status;
  // Index of each new factor, in the order given (for later removal).
  std::vector<int> new_factor_indices;
  int new_variables = 0;
  int relinearized_variables = 0;
  int relinearized_factors = 0;
  // Variables due for relinearisation that were left as they are
  // (Isam2UpdateOptions::defer_relinearization_above).
  int relinearization_deferred = 0;
  // Variables over their δ budget whose factors the linearisation-error check walked
  // (Relinearization::error_threshold). One whose factors all passed is not walked again while
  // its δ stays exactly as it was.
  int screened_variables = 0;
  int reeliminated_variables = 0;
  int reeliminated_cliques = 0;
  // Cliques back-substituted (with solve_first: by Update; FinishBackSubstitution counts the rest).
  int solved_cliques = 0;
  bool batch_step = false;
  // Isam2Params::trust_region: the radius after this update, the dog-leg steps tried (each a chi2
  // evaluation) and whether δ is the Gauss-Newton step.
  struct TrustRegion {
    double radius = 0.0;
    int attempts = 0;
    bool gauss_newton = false;
  } trust_region;
  // Seconds per step of the update (numbered as in isam2.cc).
  struct Seconds {
    double add = 0.0;          // 1-2: checks, new variables and factors, linearisation
    // 3: fluid relinearisation: selecting, starting the threads, and waiting for them before 7
    // (what they do while the calling thread runs 4-6 is not counted here).
    double relinearize = 0.0;
    double remove_top = 0.0;   // 4-5: affected set and detaching the top
    double order = 0.0;        // 6: constrained COLAMD
    double eliminate = 0.0;    // 7: dense elimination and re-attaching orphans
    double solve = 0.0;        // 8: partial back-substitution (with solve_first: its first part)
    double trust_region = 0.0;  // 9: the dog leg (Isam2Params::trust_region)
    double total = 0.0;
  } seconds;

  // One line for a debug log.
  std::string Brief() const;
};

// What Isam2::RemoveVariables did.
struct Isam2RemovalResult {
  // Not ok on invalid input or a marginal that does not exist (nothing changed), or a numerical
  // failure of the re-elimination (the solver is left as it was).
  Status status;
  std::vector<int> removed_factors;  // their indices, now free (factor_slots() null)
  int removed_dimension = 0;         // Σ of their residual dimensions
  // Indices of the summary's factors on the blanket (NodeRemoval::summary); empty if none.
  std::vector<int> summary_factors;
  KeyVector blanket;               // the variables they are on
  Values marginalized_at;          // theta (or `at`) of the removed variables and blanket
  double constant_chi2 = 0.0;      // NodeRemoval::constant_chi2
  int reeliminated_variables = 0;  // the top of the tree the removed factors touched
  double seconds = 0.0;
};

// Where an Isam2's memory is (Isam2::MemoryUse), in bytes allocated (capacity): for memory
// reports. The factor objects themselves (measurements, noise models) are not counted, nor the
// allocator's own overhead: RSS minus Total() is their upper bound.
struct Isam2Memory {
  std::size_t linearization_point = 0;  // θ (Values: keys, variables, index)
  std::size_t variables = 0;       // δ and the per-variable arrays (dims, offsets, budgets, ...)
  std::size_t factor_lists = 0;    // per factor: pointer, variable ids, screen state
  std::size_t linearizations = 0;  // the cached linearisation of every factor
  std::size_t variable_index = 0;  // variable -> factors
  std::size_t tree = 0;            // the cliques in use: [R S d], cached factors, structure
  std::size_t tree_free = 0;       // cliques kept for reuse (free list)
  std::size_t scratch = 0;         // per-update work arrays kept between updates
  std::size_t Total() const {
    return linearization_point + variables + factor_lists + linearizations + variable_index + tree +
           tree_free + scratch;
  }
};

}  // namespace slamd::core
