// Batch nonlinear least squares: Gauss-Newton and Levenberg-Marquardt over a whole factor graph,
// on the sparse normal equations (normal_equations.h: block COLAMD ordering, CHOLMOD).
//
// It minimises Σ_f ρ_f(|R_f·e_f(x)|²) (chi2 without robust kernels; no ½). It is slamd's oracle:
// every incremental result is tested against it. Levenberg-Marquardt follows Madsen, Nielsen &
// Tingleff, "Methods for non-linear least squares problems" (2004), §3.2: a step δ solves
// (H + λD)δ = b; the gain ratio ϱ = (F(x) − F(x ⊕ δ)) / (L(0) − L(δ)) decides: ϱ > 0 accepts the
// step and scales λ by max(1/3, 1 − (2ϱ − 1)³); otherwise λ grows by ν, ν doubles.
//
// The graph must fix the gauge (e.g. a prior on one pose) for Gauss-Newton; Levenberg-Marquardt
// tolerates a free gauge through its damping but converges faster with a prior.
#pragma once

#include <string>

#include "core/batch/batch_params.h"
#include "core/factors/factor_graph.h"

namespace slamd::core {

enum class BatchTermination {
  kConverged,           // the cost decrease fell under a tolerance
  kMaxIterations,       // max_iterations reached
  kLambdaOverflow,      // LM: no damping value lowered the cost (at a minimum up to round-off)
  kNumericalFailure,    // the linear system was indeterminate (status names a variable)
  kInvalidInput,        // params or graph/values were invalid (status says what)
};
const char* BatchTerminationName(BatchTermination t);

struct BatchSummary {
  int iterations = 0;          // linearisations
  int linear_solves = 0;       // factorisations (LM retries included)
  int rejected_steps = 0;      // LM steps that raised the cost
  double initial_chi2 = 0.0;   // Σ|R·e|² at the initial values
  double final_chi2 = 0.0;
  double initial_cost = 0.0;   // Σρ(|R·e|²): equals chi2 without robust kernels
  double final_cost = 0.0;
  double final_lambda = 0.0;
  BatchTermination termination = BatchTermination::kInvalidInput;
  // Landmarks eliminated before the other variables (BatchParams::ordering); 0: plain COLAMD.
  int landmarks_first = 0;
  // Wall-clock seconds per phase.
  double setup_s = 0.0;        // checks, ordering, symbolic structure (order_s included)
  double order_s = 0.0;        // the block ordering
  double linearize_s = 0.0;
  double factorize_s = 0.0;
  double solve_s = 0.0;        // triangular solves
  double evaluate_s = 0.0;     // retracting candidates and evaluating their cost
  double total_s = 0.0;

  // One line: "LM: 7 iterations, chi2 1.2e6 -> 137.93, converged, 0.041 s".
  std::string Brief() const;
};

struct BatchResult {
  Status status;     // not ok on invalid input or numerical failure (values then = the best so far)
  Values values;     // the optimised values (keys and slots as in the input)
  BatchSummary summary;
};

// Fixes the gauge of a pose graph (datasets leave it free): adds a prior on `pose` at its value in
// `values` with isotropic sigma `sigma` (metres and radians). At the optimum it contributes ~0.
Status AddGaugePrior(const Values& values, Key pose, double sigma, FactorGraph* graph);

// Optimises `initial` against `graph`. Validates params and the graph first.
BatchResult Optimize(const FactorGraph& graph, const Values& initial, const BatchParams& params = {});

}  // namespace slamd::core
