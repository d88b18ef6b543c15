#include "core/ba/bundle_adjuster.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <variant>

#include "core/ba/border_elimination.h"
#include "core/ba/problem_dispatch.h"
#include "core/base/timing.h"
#include "core/base/worker_pool.h"
#include "core/linear/ordering.h"

namespace slamd::core {
namespace {

using internal::CalibrationBorder;
using internal::ReducedCameraMatrix;

// S solved for several right-hand sides by the exact solver (dense or sparse).
internal::MultiSolve ExactMultiSolve(BaLinearSolver solver, ReducedCameraMatrix* s) {
  return [solver, s](const Eigen::MatrixXd& rhs, Eigen::MatrixXd* x) -> Status {
    if (solver == BaLinearSolver::kDenseSchur) return s->SolveDense(rhs, x);
    SLAMD_RETURN_IF_ERROR(s->FactorSparse());
    x->resize(rhs.rows(), rhs.cols());
    Eigen::VectorXd column;
    for (int c = 0; c < rhs.cols(); ++c) {
      SLAMD_RETURN_IF_ERROR(s->SolveFactored(rhs.col(c), &column));
      x->col(c) = column;
    }
    return Status::Ok();
  };
}

// kAuto between the two exact solvers: dense while S is small.
BaLinearSolver ExactSolver(const BundleAdjusterParams& params, int num_cameras, int block_dim) {
  return num_cameras * block_dim <= params.dense_max_camera_dim ? BaLinearSolver::kDenseSchur
                                                                : BaLinearSolver::kSparseSchur;
}

// kAuto: the exact solver (ExactSolver) or conjugate gradients, whichever costs less per
// iteration by this model of its work, in seconds measured here (2 cores, OpenBLAS; D = 9;
// the ratios matter). An exact solve assembles S point by point, one D x D product per pair of
// cameras that see the point (33 ns), and factors it (0.04 ns per flop: CHOLMOD's supernodal
// or the blocked dense LLᵀ); the iterative one assembles only the diagonal and runs conjugate
// gradients, each iteration a pass over the observations (16 ns each). Conjugate gradients took
// 3-60 iterations per solve on the development problems; counting 30 leans to the exact
// solvers, which need no tolerance. Dense co-visibility (cameras around an object, a city
// block) makes both exact steps grow with the square of the cameras per point.
// `covisibility`: S's block pattern in the exact solver's camera order (read when it is sparse).
BaLinearSolver AutoSolver(const BundleAdjusterParams& params, const Reconstruction& rec,
                          int block_dim, const std::vector<std::vector<int>>& covisibility) {
  const int n = static_cast<int>(rec.images.size());
  const BaLinearSolver exact = ExactSolver(params, n, block_dim);
  std::vector<double> seen_by(rec.points.size(), 0.0);
  for (const SfmObservation& o : rec.observations) seen_by[o.point] += 1.0;
  double pairs = 0.0;
  for (double k : seen_by) pairs += k * (k + 1.0) / 2.0;
  const double dim = static_cast<double>(n) * block_dim;
  const double factor_flops = exact == BaLinearSolver::kDenseSchur
                                  ? dim * dim * dim / 3.0
                                  : internal::BlockCholeskyFlops(block_dim, covisibility);
  const double scale = block_dim / 9.0;  // the measurements' D
  const double exact_s = 33e-9 * scale * scale * pairs + 0.04e-9 * factor_flops;
  constexpr double kExpectedCgIterations = 30.0;
  const double iterative_s =
      kExpectedCgIterations * 16e-9 * scale * static_cast<double>(rec.observations.size());
  return iterative_s < exact_s ? BaLinearSolver::kIterativeSchur : exact;
}

// Preconditioned conjugate gradients on S x = b, or on the system bordered by the shared
// calibrations ([S E; Eᵀ F], x and b stacked poses then calibrations) when `border` is set, with S
// applied implicitly and the inverses of its diagonal blocks (and of F) as preconditioner.
// Returns the iterations run.
template <typename Problem>
int SolveIterative(const Problem& problem, const std::vector<typename Problem::CameraMatrix>& diag,
                   const CalibrationBorder* border, const Eigen::VectorXd& b,
                   const BundleAdjusterParams& params, Eigen::VectorXd* x) {
  constexpr int kD = Problem::kD;
  const int n = static_cast<int>(diag.size());
  std::vector<typename Problem::CameraMatrix> inverse(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::LLT<typename Problem::CameraMatrix> llt(diag[i]);
    inverse[i] = llt.solve(Problem::CameraMatrix::Identity());
  }
  // With the border: M = [D E; Eᵀ F], D S's block diagonal, applied exactly through its Schur
  // complement G = F − Eᵀ D⁻¹ E (the calibrations couple every camera; preconditioning them by F
  // alone made the first steps from a poor start useless).
  Eigen::MatrixXd d_inv_e;  // D⁻¹ E
  Eigen::LLT<Eigen::MatrixXd> g_llt;
  if (border) {
    d_inv_e.resize(border->e.rows(), border->dim());
    for (int i = 0; i < n; ++i) {
      d_inv_e.middleRows<kD>(kD * i).noalias() = inverse[i] * border->e.middleRows<kD>(kD * i);
    }
    g_llt.compute(border->f - border->e.transpose() * d_inv_e);
    if (g_llt.info() != Eigen::Success) {  // M not positive definite: D and F apart
      d_inv_e.setZero();
      g_llt.compute(border->f);
    }
  }
  auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd* z) {
    z->resize(r.size());
    for (int i = 0; i < n; ++i) {
      z->template segment<kD>(kD * i).noalias() = inverse[i] * r.template segment<kD>(kD * i);
    }
    if (!border) return;
    // [D E; Eᵀ F]⁻¹ r: z_k = G⁻¹ (r_k − Eᵀ D⁻¹ r_c), z_c = D⁻¹ r_c − D⁻¹ E z_k.
    const int m = border->dim(), c = static_cast<int>(r.size()) - m;
    const Eigen::VectorXd zk = g_llt.solve(r.tail(m) - d_inv_e.transpose() * r.head(c));
    z->head(c).noalias() -= d_inv_e * zk;
    z->tail(m) = zk;
  };
  const auto multiply_s = [&](const Eigen::VectorXd& v, Eigen::VectorXd* y) {
    problem.MultiplyReduced(v, y);
  };
  const auto multiply = [&](const Eigen::VectorXd& v, Eigen::VectorXd* y) {
    if (border) {
      BorderedProduct(multiply_s, *border, v, y);
    } else {
      multiply_s(v, y);
    }
  };
  x->setZero(b.size());
  Eigen::VectorXd r = b, z, p, q;
  precondition(r, &z);
  p = z;
  double rz = r.dot(z);
  const double stop = params.cg_tolerance * b.norm();
  int k = 0;
  while (k < params.cg_max_iterations) {
    multiply(p, &q);
    const double pq = p.dot(q);
    if (!(pq > 0.0)) break;  // S not positive definite along p: keep what we have
    const double alpha = rz / pq;
    *x += alpha * p;
    r -= alpha * q;
    ++k;
    if (r.norm() <= stop) break;
    precondition(r, &z);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  return k;
}

// |x| of the unknowns in their tangent coordinates (pose: translation and rotation vector).
template <typename State>
double StateNorm(const State& x) {
  double s = 0.0;
  for (const Pose3& pose : x.poses) {
    s += pose.translation().squaredNorm() + Rot3::Log(pose.rotation()).squaredNorm();
  }
  for (const auto& cal : x.cals) s += cal.vector().squaredNorm();
  for (const Point3& p : x.points) s += p.squaredNorm();
  return std::sqrt(s);
}

template <typename Cal, bool kRefineCal>
Result<BundleAdjusterSummary> Adjust(const BundleAdjusterParams& params, Reconstruction* rec) {
  using Problem = internal::BaBorderedProblem<Cal, kRefineCal>;
  constexpr int kD = Problem::kD;
  const Stopwatch total;
  // Calibrations refined but not per camera: some intrinsics are shared by several images.
  const bool shared = params.refine_intrinsics && !kRefineCal;
  BundleAdjusterSummary summary;
  summary.camera_block_dim = kD;
  summary.num_cameras = static_cast<int>(rec->images.size());
  summary.num_points = static_cast<int>(rec->points.size());
  summary.num_observations = static_cast<int>(rec->observations.size());

  BaLinearSolver solver = params.linear_solver;
  if (solver == BaLinearSolver::kAuto && summary.num_cameras > params.sparse_max_cameras) {
    solver = BaLinearSolver::kIterativeSchur;
  }
  // Cameras in a fill-reducing order whenever the sparse solver may run.
  const bool fill_reducing =
      solver == BaLinearSolver::kSparseSchur ||
      (solver == BaLinearSolver::kAuto &&
       ExactSolver(params, summary.num_cameras, kD) == BaLinearSolver::kSparseSchur);
  Result<std::vector<int>> positions = internal::CameraPositions(*rec, fill_reducing);
  if (!positions.ok()) return positions.status();
  WorkerPool pool(params.num_threads - 1);
  Problem problem(*rec, params.robust, std::move(positions).value(), &pool,
                  {.shared = shared, .principal_point = params.refine_principal_point});
  typename Problem::State x = Problem::StateOf(*rec);
  summary.shared_calibrations = problem.num_shared();

  std::unique_ptr<ReducedCameraMatrix> s;
  {
    // S's pattern (Σ over points of their cameras squared to build): for the choice only when
    // it would be sparse, and not kept when the iterative solver runs.
    std::vector<std::vector<int>> covisibility;
    if (solver == BaLinearSolver::kAuto) {
      if (fill_reducing) covisibility = problem.CoVisibility();
      solver = AutoSolver(params, *rec, kD, covisibility);
    }
    if (solver != BaLinearSolver::kIterativeSchur) {
      if (covisibility.empty()) covisibility = problem.CoVisibility();
      s = std::make_unique<ReducedCameraMatrix>(kD, std::move(covisibility));
    }
  }
  summary.linear_solver = solver;
  std::vector<typename Problem::CameraMatrix> diagonal;
  CalibrationBorder border;
  Eigen::VectorXd b, dc, dk;
  std::vector<Vector3> dp;

  Stopwatch phase;
  double cost = problem.Linearize(x);
  summary.evaluate_s += phase.Lap();
  summary.initial_cost = cost;
  double radius = params.initial_trust_region_radius, decrease_factor = 2.0;
  summary.termination = "max iterations";
  if (problem.GradientMaxNorm() <= params.gradient_tolerance) summary.termination = "gradient";
  while (summary.termination == "max iterations" &&
         static_cast<int>(summary.iterations.size()) < params.max_iterations) {
    BaIteration it{.cost = cost, .trust_region_radius = radius, .linear_iterations = 1};
    phase.Restart();
    problem.EliminatePoints(1.0 / radius, s.get(),
                            solver == BaLinearSolver::kIterativeSchur ? &diagonal : nullptr, &b);
    if (shared) problem.EliminateBorder(&border);
    summary.schur_s += phase.Lap();
    Status solved;
    if (solver == BaLinearSolver::kIterativeSchur) {
      if (shared) {
        Eigen::VectorXd bordered_b(b.size() + border.dim()), step;
        bordered_b << b, border.b;
        it.linear_iterations =
            SolveIterative(problem, diagonal, &border, bordered_b, params, &step);
        dc = step.head(b.size());
        dk = step.tail(border.dim());
      } else {
        it.linear_iterations = SolveIterative(problem, diagonal, nullptr, b, params, &dc);
      }
    } else if (shared) {
      solved = internal::SolveBordered(ExactMultiSolve(solver, s.get()), border, b, &dc, &dk);
    } else if (solver == BaLinearSolver::kDenseSchur) {
      solved = s->SolveDense(b, &dc);
    } else {
      solved = s->SolveSparse(b, &dc);
    }
    summary.solve_s += phase.Lap();
    bool taken = false;
    if (solved.ok() && dc.allFinite() && dk.allFinite()) {
      const double model = problem.BackSubstitute(dc, dk, &dp);
      double step2 = dc.squaredNorm() + dk.squaredNorm();
      for (const Vector3& d : dp) step2 += d.squaredNorm();
      const double x_norm = StateNorm(x);
      if (std::sqrt(step2) <= params.parameter_tolerance * (x_norm + params.parameter_tolerance)) {
        summary.termination = "parameter tolerance";
        summary.update_s += phase.Lap();
        it.elapsed_s = total.Seconds();
        summary.iterations.push_back(it);
        break;
      }
      typename Problem::State trial = problem.Retract(x, dc, dk, dp);
      const double trial_cost = problem.Cost(trial);
      summary.update_s += phase.Lap();
      const double rho = model > 0.0 ? (cost - trial_cost) / model : -1.0;
      if (std::isfinite(trial_cost) && rho > params.min_relative_decrease) {
        taken = true;
        const double decrease = cost - trial_cost;
        x = std::move(trial);
        radius = std::min(params.max_trust_region_radius,
                          radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3)));
        decrease_factor = 2.0;
        cost = problem.Linearize(x);
        summary.evaluate_s += phase.Lap();
        if (decrease <= params.function_tolerance * (cost + decrease)) {
          summary.termination = "function tolerance";
        } else if (problem.GradientMaxNorm() <= params.gradient_tolerance) {
          summary.termination = "gradient tolerance";
        }
      }
    }
    if (!taken) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < params.min_trust_region_radius) summary.termination = "trust region too small";
    }
    it.step_taken = taken;
    it.cost = cost;
    it.elapsed_s = total.Seconds();
    summary.iterations.push_back(it);
    if (params.verbosity > 0) {
      std::fprintf(stderr, "  iter %zu cost %.10g radius %.3g %s cg %d  %.3f s\n",
                   summary.iterations.size(), cost, radius, taken ? "taken" : "rejected",
                   it.linear_iterations, it.elapsed_s);
    }
  }

  double squared = 0.0;
  summary.final_cost = problem.Cost(x, &squared, &summary.points_behind_cameras);
  summary.rms_reprojection_px = std::sqrt(squared / std::max(1, summary.num_observations));
  Problem::WriteBack(x, kRefineCal || shared, rec);
  summary.total_s = total.Seconds();
  return summary;
}

}  // namespace

Result<BundleAdjusterSummary> BundleAdjust(const BundleAdjusterParams& params,
                                           Reconstruction* reconstruction) {
  if (Status s = params.Validate(); !s.ok()) return s;
  if (Status s = internal::CheckAdjustable(*reconstruction, "bundle adjustment"); !s.ok()) {
    return s;
  }
  return internal::WithProblemType(params, *reconstruction, [&]<typename Cal, bool kRefineCal>() {
    return Adjust<Cal, kRefineCal>(params, reconstruction);
  });
}

}  // namespace slamd::core
