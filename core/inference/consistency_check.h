// Structural consistency check of a Bayes tree: the oracle the elimination and iSAM2 tests run
// after every step (GTSAM testGaussianISAM2 `isam_check` in spirit).
//
// Checks, returning kFailedPrecondition naming the first violation:
//   * links: every live clique's parent is live and lists it exactly once among its children,
//     every child points back; roots() is exactly the live parentless cliques, without
//     duplicates; every live clique is reachable from a root (no cycles);
//   * variables: every variable is frontal in exactly one live clique, and CliqueOf() names it;
//     no variable is both frontal and separator in one clique, nor listed twice;
//   * running intersection: a root's separator is empty; a child's separator is contained in
//     its parent's frontals ∪ separator and meets its parent's frontals (so separators are
//     contained in the ancestors' frontals);
//   * sizes: [R S d] and the cached factor have the sizes the frontal and separator dims give;
//     a variable has the same dim wherever it appears; R is upper-triangular with a positive
//     diagonal and [R S d] is finite.
// Cost: O(Σ clique sizes + matrix entries); allocates (meant for tests and debug checks).
#pragma once

#include "core/base/status.h"
#include "core/inference/bayes_tree.h"

namespace slamd::core {

Status CheckConsistency(const BayesTree& tree);

}  // namespace slamd::core
