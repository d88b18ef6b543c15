// Fill-reducing elimination orderings at the VARIABLE (block) level, computed with SuiteSparse
// COLAMD / CCOLAMD on the factor-by-variable incidence matrix A (rows = factors, columns =
// variables). COLAMD orders the columns of A to keep the Cholesky factor of AᵀA sparse, and AᵀA
// has exactly the block pattern of the Gauss-Newton Hessian H = Σ JᵀJ, so a variable order from
// COLAMD is a fill-reducing order for H. Ordering whole variables (not scalars) keeps every d x d
// block contiguous, which is what BlockSparseSystem and the Bayes tree need, and is ~d² cheaper.
//
// Conventions: variables are dense indices 0..num_vars-1. An order is a vector `order` of size
// num_vars with order[k] = the variable eliminated k-th; its inverse (InversePermutation) gives
// each variable's position. Variables touched by no factor appear in the output too (COLAMD
// places them last within their group).
//
// Complexity: roughly linear in the number of incidence entries for SLAM-like graphs.
// Thread safety: the functions are pure; they may be called concurrently.
#pragma once

#include <vector>

#include "core/base/status.h"

namespace slamd::core {

// Compressed-row incidence: factor f touches variables vars[offsets[f] .. offsets[f+1]).
// offsets has num_factors + 1 entries, offsets[0] == 0, non-decreasing.
struct FactorIncidence {
  std::vector<int> offsets = {0};  // size num_factors + 1
  std::vector<int> vars;           // variable indices in [0, num_vars)

  int NumFactors() const { return static_cast<int>(offsets.size()) - 1; }
  // Appends a factor touching `factor_vars` (convenience for building and for tests).
  void AddFactor(const std::vector<int>& factor_vars) {
    vars.insert(vars.end(), factor_vars.begin(), factor_vars.end());
    offsets.push_back(static_cast<int>(vars.size()));
  }
};

// Checks the CSR structure and that every variable index is in [0, num_vars). Duplicate
// variables within one factor are allowed here (the orderings ignore them).
Status ValidateIncidence(int num_vars, const FactorIncidence& incidence);

// COLAMD ordering of all num_vars variables. Fails with kInvalidArgument on a malformed
// incidence; an error inside COLAMD (e.g. out of memory) is reported as kFailedPrecondition with
// COLAMD's status code in the message.
Result<std::vector<int>> ColamdOrdering(int num_vars, const FactorIncidence& incidence);

// CCOLAMD ordering with constraint groups: group[v] is variable v's group (any int values; only
// their relative order matters). Every variable of a lower group is eliminated before every
// variable of a higher group; within a group the order is fill-reducing. iSAM2 uses this to force
// the variables touched by new factors to the end (the root of the Bayes tree).
// group.size() must equal num_vars.
Result<std::vector<int>> ConstrainedColamdOrdering(int num_vars, const FactorIncidence& incidence,
                                                   const std::vector<int>& group);

// The variables marked in `independent` first (sorted by where their neighbours are
// eliminated), then the others by CCOLAMD with their groups (as ConstrainedColamdOrdering) on the
// system that eliminating the first leaves: each marked variable's factors merge into one row
// over its unmarked neighbours. No factor may touch two marked variables (an independent set, as
// the points of bundle adjustment are), so eliminating them first fills in only among each one's
// neighbours: the Schur complement. The cost is that of reading the incidence plus CCOLAMD on
// the rest, where CCOLAMD on the whole graph costs ~30 ms on Ladybug-49's 7,800 variables.
//
// That order is as good as CCOLAMD's only where the system left is dense anyway: on a long
// camera trajectory (few cameras share a point) CCOLAMD eliminates some cameras before their
// points and fills in far less (a simulated city: 2.6x the flops with the points first). So
// `min_density`: the least fraction of pairs of unmarked variables that a row of the system left
// ties together (Ladybug-49: 0.83-0.85; the city: 0.15-0.36); a sparser system, or one of more
// than kMaxDensityVars unmarked variables, is refused.
//
// kFailedPrecondition when a factor touches two marked variables or the system left is too
// sparse (the caller orders by CCOLAMD instead); sizes as ConstrainedColamdOrdering.
inline constexpr int kMaxDensityVars = 1024;
Result<std::vector<int>> IndependentFirstOrdering(int num_vars, const FactorIncidence& incidence,
                                                  const std::vector<char>& independent,
                                                  const std::vector<int>& group,
                                                  double min_density = 0.0);

// inverse[perm[k]] = k. `perm` must be a permutation of 0..n-1 (checked by SLAMD_DCHECK only).
std::vector<int> InversePermutation(const std::vector<int>& perm);

// True iff `perm` is a permutation of 0..n-1 with n = perm.size().
bool IsPermutation(const std::vector<int>& perm);

}  // namespace slamd::core
