#include "core/batch/auto_initialization.h"

#include <cmath>

namespace slamd::core {

Result<AutoInitialization> OptimizeWithAutoInitialization(const FactorGraph& graph,
                                                          const Values& initial,
                                                          const std::vector<Key>& poses,
                                                          const BatchParams& params, int chunk,
                                                          double poor_chi2_per_dim) {
  AutoInitialization best;
  bool solved = false;
  Status last_error = FailedPrecondition("no initial guess could be made");
  std::vector<double> start_chi2;  // of the starts solved so far: an identical start is skipped
  auto attempt = [&](InitialGuess method) {
    Result<Values> start = MakeInitialGuess(method, graph, initial, poses, chunk);
    if (!start.ok()) {
      last_error = start.status();
      return;
    }
    const double chi2 = graph.Chi2(start.value());
    for (double seen : start_chi2) {
      if (std::abs(chi2 - seen) <= 1e-12 * seen) return;  // e.g. a tree of odometry only
    }
    start_chi2.push_back(chi2);
    BatchResult result = Optimize(graph, start.value(), params);
    if (!result.status.ok()) {
      last_error = result.status;
      return;
    }
    best.tried.emplace_back(method, result.summary.final_cost);
    if (!solved || result.summary.final_cost < best.result.summary.final_cost * (1.0 - 1e-9)) {
      best.chosen = method;
      best.result = std::move(result);
      solved = true;
    }
  };
  attempt(InitialGuess::kAsGiven);
  const bool planar = !poses.empty() && initial.Find<Pose2>(poses.front()) != nullptr;
  if (planar) {
    attempt(InitialGuess::kSpanningTree);
    int dims = 0;
    for (const FactorPtr& f : graph) dims += f->dim();
    if (!solved || best.result.summary.final_cost > poor_chi2_per_dim * dims) {
      attempt(InitialGuess::kIncremental);
    }
  }
  if (!solved) return last_error;
  return best;
}

}  // namespace slamd::core
