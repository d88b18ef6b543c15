// Optimising from a start chosen by the data: a pose graph's own guess (file vertices, odometry
// composed in file order) can hold Levenberg-Marquardt in a local minimum far from the optimum
// (the Intel lab's file guess ends at chi2 126,155 where a spanning-tree start reaches 215.83;
// Victoria Park's odometry ends at 610,073 where an incremental start reaches 6,184).
//
// What it does, for planar graphs (3-D graphs: the given guess only):
//   1. optimise from the given guess and from a spanning tree (initialization.h; cheap: one
//      pass over the edges), and keep the lower final cost;
//   2. if that still leaves more than `poor_chi2_per_dim` of chi2 per residual dimension (a
//      consistent optimum has about 1), also optimise from the incremental guess, which costs a
//      few Gauss-Newton passes of the growing graph, and keep the lowest.
// The result is the solver's from the chosen start; `tried` lists each start with the cost it
// reached, for reports.
#pragma once

#include <utility>
#include <vector>

#include "core/batch/batch_solver.h"
#include "core/batch/initialization.h"

namespace slamd::core {

struct AutoInitialization {
  InitialGuess chosen = InitialGuess::kAsGiven;
  BatchResult result;
  std::vector<std::pair<InitialGuess, double>> tried = {};  // start, final cost
};

// `graph` with its gauge (a prior), `initial` the given guess, `poses` the pose keys in order
// (poses[0] is the root of the other guesses), `chunk` the incremental guess's step. Fails only
// when no start could be made or solved; a start that fails is skipped.
Result<AutoInitialization> OptimizeWithAutoInitialization(
    const FactorGraph& graph, const Values& initial, const std::vector<Key>& poses,
    const BatchParams& params, int chunk = 100, double poor_chi2_per_dim = 5.0);

}  // namespace slamd::core
