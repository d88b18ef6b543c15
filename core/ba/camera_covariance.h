// Marginal covariances of the cameras of a bundle-adjusted reconstruction, from the reduced
// camera system: with the points eliminated, the cameras' joint covariance is S⁻¹ (S = U −
// W V⁻¹ Wᵀ of ba_problem.h, undamped), so no point covariance is ever formed.
//
// Gauge: the reprojection error does not change under a similarity of the whole scene (7
// degrees of freedom), so S is singular and a covariance needs a gauge. Here: the pose of
// `gauge_image` (image 0) is held fixed, and the scale by holding one translation unknown of
// `scale_image` (the image whose centre is farthest from image 0's) along `scale_axis` (the axis
// of its own frame most aligned with the baseline between the two). Those unknowns have zero
// rows and columns in the result; every other covariance is relative to that gauge.
//
// Units: each camera's unknowns are those of the adjuster: pose (v, ω: right perturbation of
// T_wc, metres and radians) then its calibration's parameters when they are refined per camera
// (BundleAdjusterParams::refine_intrinsics; a parameter its model holds, CalibrationBasis, has
// zero variance; a calibration shared by several images is refined once, `per_intrinsics`, and
// the poses' covariances include its uncertainty). Pixel noise:
// `pixel_sigma` pixels on each coordinate of every observation (the covariance scales with its
// square).
//
// Cost: up to `max_dense_dim` camera unknowns S is inverted densely, O((cameras · block)³);
// above, CHOLMOD factors S once (cameras in a fill-reducing order) and each camera's diagonal
// block of S⁻¹ takes `block` solves, O(cameras · block · nnz(L)) in all, memory O(nnz(L)).
// Points seen by one camera only carry no
// information about the cameras; they are damped by 1e-12 · their diagonal so that their
// blocks stay invertible.
#pragma once

#include <vector>

#include "core/ba/bundle_adjuster_params.h"
#include "core/base/status.h"
#include "core/geometry/eigen_types.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core {

struct CameraCovariances {
  int block_dim = 0;                            // unknowns per camera
  std::vector<Eigen::MatrixXd> per_image = {};  // block_dim x block_dim, one per image
  // Calibrations refined as shared by their images: per intrinsics its parameters' covariance
  // (empty for an intrinsics no image uses, and without shared calibrations).
  std::vector<Eigen::MatrixXd> per_intrinsics = {};
  int gauge_image = 0;
  int scale_image = 0;
  int scale_axis = 0;  // 0, 1, 2: x, y, z of scale_image's own frame
};

// `params` says which unknowns a camera has (refine_intrinsics) and the threads to use.
// kFailedPrecondition when the gauge cannot be set (fewer than 2 images) or the reconstruction
// does not constrain its cameras (S singular beyond the gauge: the message
// says so); kInvalidArgument as BundleAdjust.
Result<CameraCovariances> EstimateCameraCovariances(const Reconstruction& reconstruction,
                                                    const BundleAdjusterParams& params,
                                                    double pixel_sigma = 1.0,
                                                    int max_dense_dim = 6000);

}  // namespace slamd::core
