#include "core/batch/batch_solver.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/base/timing.h"
#include "core/batch/normal_equations.h"
#include "core/factors/prior_factor.h"

namespace slamd::core {

const char* BatchTerminationName(BatchTermination t) {
  switch (t) {
    case BatchTermination::kConverged: return "converged";
    case BatchTermination::kMaxIterations: return "max iterations";
    case BatchTermination::kLambdaOverflow: return "lambda overflow";
    case BatchTermination::kNumericalFailure: return "numerical failure";
    case BatchTermination::kInvalidInput: return "invalid input";
  }
  return "unknown";
}

std::string BatchSummary::Brief() const {
  char line[256];
  std::snprintf(line, sizeof(line), "%d iterations (%d solves), chi2 %.9g -> %.9g, %s, %.4f s",
                iterations, linear_solves, initial_chi2, final_chi2,
                BatchTerminationName(termination), total_s);
  return line;
}

namespace {

// True when an accepted decrease from `before` to `after` is small enough to stop.
bool Converged(double before, double after, const BatchParams& p) {
  const double decrease = before - after;
  return decrease < p.absolute_tolerance || decrease < p.relative_tolerance * before;
}

// The damping after a rejected step (Nielsen: λ·ν, ν doubling), starting at the floor when the
// rejected step was undamped.
double Increase(double lambda, double* nu, const BatchParams& p) {
  if (lambda < p.lambda_floor) return p.lambda_floor;
  const double next = lambda * *nu;
  *nu *= 2.0;
  return next;
}

}  // namespace

Status AddGaugePrior(const Values& values, Key pose, double sigma, FactorGraph* graph) {
  if (const Pose2* p = values.Find<Pose2>(pose)) {
    Result<NoiseModel> noise = NoiseModel::Isotropic(3, sigma);
    if (!noise.ok()) return noise.status();
    graph->Emplace<PriorFactor<Pose2>>(pose, *p, *noise);
  } else if (const Pose3* q = values.Find<Pose3>(pose)) {
    Result<NoiseModel> noise = NoiseModel::Isotropic(6, sigma);
    if (!noise.ok()) return noise.status();
    graph->Emplace<PriorFactor<Pose3>>(pose, *q, *noise);
  } else {
    return InvalidArgument("gauge prior: " + KeyToString(pose) + " is not a pose in the values");
  }
  return Status::Ok();
}

BatchResult Optimize(const FactorGraph& graph, const Values& initial, const BatchParams& params) {
  Stopwatch total;
  BatchResult result{.status = params.Validate(), .values = initial, .summary = {}};
  BatchSummary& sum = result.summary;
  if (!result.status.ok()) return result;

  Stopwatch phase;
  Result<std::unique_ptr<internal::NormalEquations>> created =
      internal::NormalEquations::Create(graph, initial, params.ordering);
  if (!created.ok()) {
    result.status = created.status();
    return result;
  }
  internal::NormalEquations& equations = **created;
  sum.setup_s = phase.Lap();
  sum.order_s = equations.order_seconds();
  sum.landmarks_first = equations.landmarks_first();

  const bool lm = params.algorithm == BatchParams::Algorithm::kLevenbergMarquardt;
  const bool diagonal = params.damping == BatchParams::Damping::kDiagonal;
  Values& x = result.values;
  Values candidate = x;
  double cost = graph.Cost(x);
  sum.initial_cost = cost;
  sum.initial_chi2 = graph.Chi2(x);
  double lambda = params.initial_lambda;
  double nu = 2.0;
  Eigen::VectorXd delta;
  sum.evaluate_s += phase.Lap();
  sum.termination = BatchTermination::kMaxIterations;

  while (sum.iterations < params.max_iterations) {
    ++sum.iterations;
    equations.Linearize(x);
    sum.linearize_s += phase.Lap();
    if (lm) equations.SaveUndamped();

    bool accepted = false;
    bool stop = false;
    double new_cost = cost;
    while (!accepted) {
      if (lm) equations.Damp(lambda, diagonal);
      ++sum.linear_solves;
      const Status solved = equations.Solve(&delta);
      phase.Lap();
      if (!solved.ok()) {
        if (!lm || lambda * nu > params.max_lambda) {
          result.status = solved;
          sum.termination = BatchTermination::kNumericalFailure;
          stop = true;
          break;
        }
        lambda = Increase(lambda, &nu, params);  // indefinite at this damping: damp harder
        continue;
      }
      equations.RetractAll(x, delta, &candidate);
      new_cost = graph.Cost(candidate);
      sum.evaluate_s += phase.Lap();
      if (!lm) {
        accepted = true;
        break;
      }
      // Predicted decrease of the quadratic model: 2δᵀb − δᵀHδ = δᵀb + λ·δᵀDδ.
      const double predicted = delta.dot(equations.rhs()) + lambda * equations.DampingNorm(delta, diagonal);
      const double rho = (cost - new_cost) / predicted;
      if (params.verbosity > 0) {
        std::fprintf(stderr, "  iter %d lambda %.3g cost %.10g -> %.10g rho %.3g\n", sum.iterations,
                     lambda, cost, new_cost, rho);
      }
      if (predicted > 0.0 && rho > 0.0) {
        accepted = true;
        const double t = 2.0 * rho - 1.0;
        lambda *= std::max(1.0 / 3.0, 1.0 - t * t * t);
        if (lambda < params.lambda_floor) lambda = 0.0;  // back to undamped steps
        nu = 2.0;
      } else {
        ++sum.rejected_steps;
        lambda = Increase(lambda, &nu, params);
        if (lambda > params.max_lambda) {
          sum.termination = BatchTermination::kLambdaOverflow;
          stop = true;
          break;
        }
      }
    }
    if (stop) break;
    std::swap(x, candidate);
    const double before = cost;
    cost = new_cost;
    // A small decrease means convergence only for a (nearly) undamped step: a heavily damped
    // step is small because of the damping, not because the optimum is near.
    if (Converged(before, cost, params) && (!lm || lambda <= 10.0 * params.lambda_floor)) {
      sum.termination = BatchTermination::kConverged;
      break;
    }
  }
  sum.factorize_s = equations.factorize_seconds();
  sum.solve_s = equations.solve_seconds();
  sum.final_cost = cost;
  sum.final_chi2 = graph.Chi2(x);
  sum.final_lambda = lambda;
  sum.total_s = total.Seconds();
  return result;
}

}  // namespace slamd::core
