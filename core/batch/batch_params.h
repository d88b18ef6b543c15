// BatchParams: options of the batch nonlinear least-squares solver (batch_solver.h).
#pragma once

#include <string>

#include "core/base/param_check.h"
#include "core/base/status.h"

namespace slamd::core {

struct BatchParams {
  enum class Algorithm {
    kGaussNewton,         // undamped steps, always accepted: fast near the optimum, no safeguard
    kLevenbergMarquardt,  // trust region with gain-ratio damping updates (Madsen, Nielsen, Tingleff)
  };
  enum class Damping {
    kIdentity,  // H + λI (GTSAM's default; invariant to nothing but cheap and robust)
    kDiagonal,  // H + λ·diag(H), diag clamped to [1e-6, 1e32] (Marquardt: scale-invariant)
  };

  // The elimination order of the normal equations (normal_equations.h).
  enum class Ordering {
    kAuto,            // kLandmarksFirst on graphs with many landmarks (visual SLAM), else kColamd
    kColamd,          // fill-reducing (COLAMD) over all variables
    kLandmarksFirst,  // the points first, then COLAMD on the rest: the Schur complement (COLAMD
                      // when no point is, some factor joins two, or nothing else is left)
  };

  Algorithm algorithm = Algorithm::kLevenbergMarquardt;
  Damping damping = Damping::kIdentity;
  Ordering ordering = Ordering::kAuto;
  // Upper bound on accepted-or-rejected iterations (linearisations). >= 1.
  int max_iterations = 100;
  // Stop when an accepted step lowers the cost by less than this fraction of it. >= 0.
  double relative_tolerance = 1e-5;
  // Stop when an accepted step lowers the cost by less than this (chi2 units). >= 0.
  double absolute_tolerance = 1e-5;
  // Levenberg-Marquardt: the first damping λ. >= 0. The default 0 starts with undamped
  // (Gauss-Newton) steps: near a good initial guess they converge fastest, and a fixed small λ
  // slows convergence along weakly constrained directions (parking-garage's near-free rotations
  // take 10 iterations at λ = 1e-5 instead of 4). A rejected undamped step switches damping on.
  double initial_lambda = 0.0;
  // Levenberg-Marquardt: the smallest nonzero damping. A rejected undamped step restarts the
  // damping at this value; an accepted step that would take λ below it switches back to
  // undamped steps. > 0.
  double lambda_floor = 1e-5;
  // Levenberg-Marquardt: give up when λ grows past this (no step lowers the cost).
  // > initial_lambda and > lambda_floor.
  double max_lambda = 1e10;
  // 0: silent; 1: one line per iteration to stderr (the core otherwise never prints).
  int verbosity = 0;

  // Checks every field; the message names the field, its value and the constraint.
  Status Validate() const;
};

}  // namespace slamd::core
