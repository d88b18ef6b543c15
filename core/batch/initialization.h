// Initial guesses for the batch solver when the one at hand (file vertices, or odometry composed
// in file order) is poor enough to trap Levenberg-Marquardt in a local minimum.
//
// Planar graphs (Pose2 with BetweenFactor<Pose2>, RelativePointFactor<Pose2, Point2> and
// BearingRangeFactor; other factors are ignored here and only matter to the solver afterwards):
//
//   SpanningTree: composes the between-factor measurements outward from `root` along a spanning
//     tree grown through the most certain edges first (Prim's algorithm on the trace of each
//     edge's covariance), so a pose's guess goes through as few weak links as possible.
//   Lago: the linear approximation of Carlone, Aragues, Castellanos & Bona, "A fast and accurate
//     approximation for planar pose graph optimization" (IJRR 2014). (1) Orientations from the
//     tree, (2) every measured relative angle unwrapped by the multiple of 2π that makes it agree
//     with the tree, (3) a linear least-squares fit of all orientations to all unwrapped relative
//     angles, weighted by their information, (4) with the orientations fixed, a linear
//     least-squares fit of all positions (and relative-point landmarks) to the translation
//     measurements. No iteration, one sparse Cholesky per stage.
//
//   Incremental: for graphs whose pose-pose edges leave orientations weakly determined (e.g. a
//     landmark graph with odometry only, like Victoria Park), neither of the above helps: the
//     orientations come from odometry alone. This one imitates an incremental smoother: poses are
//     added in the given order, `chunk` at a time, each new pose predicted from an already-placed
//     neighbour through its between factor and each new landmark from its first observation, and
//     the growing graph is re-optimised (Gauss-Newton, a few iterations) after every chunk, so the
//     estimate never strays far from the optimum of the data seen so far.
//
// All keep `root` where `initial` has it (the gauge) and start from `initial` for variables they
// cannot reach (which is an error: the message names one). Landmarks observed only by bearing
// and range are placed from their first observation.
#pragma once

#include <string_view>

#include "core/factors/factor_graph.h"

namespace slamd::core {

enum class InitialGuess { kAsGiven, kSpanningTree, kLago, kIncremental };
// "file" (as given), "spanning-tree", "lago", "incremental".
Result<InitialGuess> ParseInitialGuess(std::string_view name);
// The name ParseInitialGuess reads.
const char* InitialGuessName(InitialGuess method);

// Dispatches to the functions below. `poses` lists the pose keys in order (poses[0] is the root
// whose value fixes the gauge); `chunk` is used by kIncremental only.
Result<Values> MakeInitialGuess(InitialGuess method, const FactorGraph& graph,
                                const Values& initial, const std::vector<Key>& poses,
                                int chunk = 100);

Result<Values> InitializeSpanningTree(const FactorGraph& graph, const Values& initial, Key root);
Result<Values> InitializeLago(const FactorGraph& graph, const Values& initial, Key root);
// `poses`: every pose key in the order to add them (poses[0] is the root); chunk >= 1.
Result<Values> InitializeIncremental(const FactorGraph& graph, const Values& initial,
                                     const std::vector<Key>& poses, int chunk);

}  // namespace slamd::core
