// Bundle adjustment: Levenberg-Marquardt on the reprojection error of a reconstruction, with the
// points eliminated first (the Schur complement: the reduced camera system).
//
// Unknowns: every image's pose (right perturbation of T_wc), each image's calibration when it is
// refined (BundleAdjusterParams::refine_intrinsics; only for intrinsics used by one image), and
// every point. Cost: ½ Σ ρ(|uv(pose, calibration, point) − measured|²) in pixels², Ceres's
// definition. No gauge is fixed: the damping keeps each step well posed, and the cost does not
// depend on the gauge.
//
// Each iteration (Ceres's Levenberg-Marquardt trust-region strategy): linearise at the current
// estimate (after a successful step); eliminate the points with damping 1/μ·diag(JᵀJ) to get
// S δc = b; solve it densely, by CHOLMOD or by preconditioned conjugate gradients (params);
// back-substitute the points; take the step if the cost fell by at least min_relative_decrease
// of what the linear model predicted, and widen or narrow the trust region μ from that ratio.
//
// Failure: kInvalidArgument for invalid params or reconstruction (Reconstruction::Validate),
// cameras of different calibration models, or no observation. A step whose reduced system is not
// positive definite counts as a rejected step (more damping). The reconstruction is written back
// only on success (the best estimate found, also after max_iterations).
#pragma once

#include "core/ba/bundle_adjuster_params.h"
#include "core/base/status.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core {

Result<BundleAdjusterSummary> BundleAdjust(const BundleAdjusterParams& params,
                                           Reconstruction* reconstruction);

}  // namespace slamd::core
