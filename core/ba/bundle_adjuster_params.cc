#include "core/ba/bundle_adjuster_params.h"

#include "core/base/param_check.h"

namespace slamd::core {

const char* BaLinearSolverName(BaLinearSolver solver) {
  switch (solver) {
    case BaLinearSolver::kAuto:
      return "auto";
    case BaLinearSolver::kDenseSchur:
      return "dense-schur";
    case BaLinearSolver::kSparseSchur:
      return "sparse-schur";
    case BaLinearSolver::kIterativeSchur:
      return "iterative-schur";
  }
  return "?";
}

Result<BaLinearSolver> ParseBaLinearSolver(const std::string& name) {
  for (BaLinearSolver s : {BaLinearSolver::kAuto, BaLinearSolver::kDenseSchur,
                           BaLinearSolver::kSparseSchur, BaLinearSolver::kIterativeSchur}) {
    if (name == BaLinearSolverName(s)) return s;
  }
  return InvalidArgument("unknown linear solver '" + name +
                         "' (expected auto, dense-schur, sparse-schur or iterative-schur)");
}

Status BundleAdjusterParams::Validate() const {
  SLAMD_PARAM_CHECK(BundleAdjusterParams, dense_max_camera_dim, >=, 0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, sparse_max_cameras, >=, 1);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, num_threads, >=, 1);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, max_iterations, >=, 1);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, function_tolerance, >=, 0.0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, gradient_tolerance, >=, 0.0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, parameter_tolerance, >=, 0.0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, initial_trust_region_radius, >, 0.0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, min_trust_region_radius, >, 0.0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, max_trust_region_radius, >=, initial_trust_region_radius);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, initial_trust_region_radius, >=, min_trust_region_radius);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, min_relative_decrease, >, 0.0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, min_relative_decrease, <, 1.0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, cg_tolerance, >, 0.0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, cg_tolerance, <, 1.0);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, cg_max_iterations, >=, 1);
  SLAMD_PARAM_CHECK(BundleAdjusterParams, verbosity, >=, 0);
  return Status::Ok();
}

}  // namespace slamd::core
