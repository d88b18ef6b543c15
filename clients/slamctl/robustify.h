// Robust kernels on a dataset's loop closures: the rule `slamctl bench --robust` applies, kept
// apart so the server can apply the same rule to incoming loop closures.
//
// Loop closure (the definition used here): a BetweenFactor<Pose2> or BetweenFactor<Pose3> that is
// not odometry. Odometry is a between factor whose two keys have the same robot byte and the same
// symbol and whose indices differ by exactly 1 (|i − j| = 1, either direction). So inter-robot
// edges and edges between non-consecutive poses of one robot are loop closures; landmark
// observations and priors never are. (Like Dataset::num_loop_like this is a heuristic: a dataset
// whose odometry skips ids, e.g. victoriaPark.txt, would have those odometry edges treated as loop
// closures; a TORO EQUIV between non-consecutive poses is a loop closure.)
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "core/base/status.h"
#include "core/factors/factor_graph.h"
#include "core/factors/robust_kernel.h"

namespace slamd::clients {

// True when `factor` is a loop closure in the sense of the file comment.
bool IsLoopClosure(const core::Factor& factor);

// A copy of `graph` in which every loop closure is rebuilt with `kernel` (same keys, measurement
// and noise model; a kernel the factor already had is replaced). Other factors are shared, not
// copied, and the order (indices) is unchanged. With kNone the result equals `graph` except that
// loop closures lose any kernel they had. `*loop_closures`, when given, receives their count.
core::FactorGraph RobustifyLoopClosures(const core::FactorGraph& graph, const core::RobustKernel& kernel,
                                        std::size_t* loop_closures = nullptr);

// The parameter used when KERNEL is given without one (see robust_kernel.h for its meaning):
//   huber, cauchy, gemanmcclure: k = 3 (a whitened-residual norm: "3 sigma"; the norm of a 3-dof
//   inlier exceeds it 3% of the time, of a 6-dof one 14%); dcs: Φ = 9 = k² (Φ is a squared norm;
//   DCS then weighs a residual 4x as much as Geman-McClure with k = 3 does, capped at 1, and
//   never down-weights one under 3 sigma). 0 for none.
// Why not the textbook values (Huber 1.345, DCS Φ = 1): with chi2-scaled kernels on 3-dof
// residuals they down-weight most inliers, and from an odometry initial guess DCS Φ = 1 stalls
// in a poor minimum (tests/clients/slamctl/robust_outliers_test.cc; ATE 0.14-1.8 m against
// 0.09-0.11 m at Φ = 9 on 800-pose Manhattan worlds, seeds 1-5, outlier-free).
double DefaultRobustParameter(core::RobustKernel::Kind kind);

// Parses "KERNEL[:PARAM]", KERNEL one of none, huber, cauchy, gemanmcclure (or geman-mcclure),
// dcs; PARAM a positive finite number (default: DefaultRobustParameter). "none" takes no
// parameter. kInvalidArgument with a message naming the spec otherwise.
core::Result<core::RobustKernel> ParseRobustSpec(std::string_view spec);

// "cauchy:1", "none": the inverse of ParseRobustSpec, for reports.
std::string RobustSpecString(const core::RobustKernel& kernel);

}  // namespace slamd::clients
