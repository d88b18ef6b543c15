// BundleAdjusterParams and BundleAdjusterSummary: options and outcome of the bundle adjuster
// (bundle_adjuster.h).
#pragma once

#include <string>
#include <vector>

#include "core/base/status.h"
#include "core/factors/robust_kernel.h"

namespace slamd::core {

// How the reduced camera system S δc = b (the points eliminated) is solved.
enum class BaLinearSolver {
  kAuto,            // the exact solver (dense up to `dense_max_camera_dim`, else sparse) or the
                    // iterative one, whichever a model of the work per iteration finds cheaper
                    // (bundle_adjuster.cc); iterative above `sparse_max_cameras`
  kDenseSchur,      // S formed as a dense matrix, Cholesky (LLᵀ) by Eigen
  kSparseSchur,     // S formed block-sparse (camera co-visibility), Cholesky by CHOLMOD in a
                    // fill-reducing camera order
  kIterativeSchur,  // S never formed: conjugate gradients on implicit products, preconditioned
                    // by the inverses of S's diagonal blocks (Schur-Jacobi)
};
const char* BaLinearSolverName(BaLinearSolver solver);
// "auto", "dense-schur", "sparse-schur", "iterative-schur".
Result<BaLinearSolver> ParseBaLinearSolver(const std::string& name);

struct BundleAdjusterParams {
  BaLinearSolver linear_solver = BaLinearSolver::kAuto;
  // kAuto: the exact solver is dense while the reduced camera system has at most this many
  // scalar unknowns (cameras × block size; 2000 unknowns = 32 MB of matrix). >= 0.
  int dense_max_camera_dim = 2000;
  // kAuto: conjugate gradients above this many cameras whatever the model says. >= 1.
  int sparse_max_cameras = 5000;
  // Threads for the Jacobians, the Schur complement and the implicit products (the caller's
  // thread is one of them). >= 1.
  int num_threads = 2;
  // Robust kernel on each observation's squared pixel error s = |uv − measured|² (pixels²): the
  // cost is ½ Σ ρ(s), as Ceres defines it (e.g. Huber(1): pixels beyond 1 px count linearly).
  RobustKernel robust = RobustKernel();
  // Refine the calibrations: each camera's with its pose when every intrinsics belongs to one
  // image (BAL); otherwise each intrinsics as one unknown shared by its images (a COLMAP camera),
  // the border of the reduced system (its width: calibrations × their dimension; each exact solve
  // solves S for that many right-hand sides). false: every calibration fixed.
  bool refine_intrinsics = true;
  // Refine the principal point of Cal3_S2 and Cal3DS2 calibrations too (CalibrationBasis says
  // which parameters each model refines).
  bool refine_principal_point = false;
  // Iterations (successful or not) at most. >= 1.
  int max_iterations = 50;
  // Stop when a successful step lowers the cost by less than this fraction of it (Ceres's
  // function_tolerance). >= 0.
  double function_tolerance = 1e-6;
  // Stop when the largest gradient entry is below this (Ceres's gradient_tolerance). >= 0.
  double gradient_tolerance = 1e-10;
  // Stop when the step is shorter than this times (|x| + this) (Ceres's parameter_tolerance).
  // >= 0.
  double parameter_tolerance = 1e-8;
  // The trust region: the first radius μ (damping 1/μ · diag(JᵀJ)), and its bounds. > 0.
  double initial_trust_region_radius = 1e4;
  double max_trust_region_radius = 1e16;
  double min_trust_region_radius = 1e-32;
  // A step is taken when the cost fell by at least this fraction of the model's prediction.
  // In (0, 1).
  double min_relative_decrease = 1e-3;
  // Iterative solver: conjugate gradients stop when |S δ − b| ≤ cg_tolerance · |b| or after
  // cg_max_iterations. cg_tolerance in (0, 1); cg_max_iterations >= 1.
  double cg_tolerance = 1e-1;
  int cg_max_iterations = 500;
  // 0: silent; 1: one line per iteration to stderr (progress of long runs; the core otherwise
  // never prints).
  int verbosity = 0;

  // Checks every field; the message names the field, its value and the constraint.
  Status Validate() const;
};

// One iteration of the adjuster (successful or not).
struct BaIteration {
  double cost = 0.0;       // ½ Σ ρ(s) after the iteration (the previous cost if rejected)
  double elapsed_s = 0.0;  // since the adjuster started
  bool step_taken = false;
  double trust_region_radius = 0.0;  // μ used for the step
  int linear_iterations = 0;         // conjugate-gradient iterations (iterative solver), else 1
};

struct BundleAdjusterSummary {
  BaLinearSolver linear_solver = BaLinearSolver::kAuto;  // the one used (never kAuto)
  int num_cameras = 0;                                   // images whose pose was refined
  int camera_block_dim = 0;  // unknowns per camera (6, + the calibration's when refined per camera)
  int shared_calibrations = 0;  // intrinsics refined as unknowns shared by their images
  int num_points = 0;
  int num_observations = 0;
  double initial_cost = 0.0;  // ½ Σ ρ(s), pixels²
  double final_cost = 0.0;
  double rms_reprojection_px = 0.0;  // √(Σ s / num_observations) at the end, without the kernel
  int points_behind_cameras = 0;     // observations whose point ends at or behind its camera
  std::vector<BaIteration> iterations;
  std::string termination;  // why it stopped: "function tolerance", "max iterations", ...
  // Seconds per phase, summed over iterations.
  double evaluate_s = 0.0;  // residuals and Jacobians
  double schur_s = 0.0;     // eliminating the points: S and its right-hand side
  double solve_s = 0.0;     // the reduced camera system
  double update_s = 0.0;    // back-substitution of the points, trial step, its cost
  double total_s = 0.0;
};

}  // namespace slamd::core
