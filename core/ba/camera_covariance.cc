#include "core/ba/camera_covariance.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <string>

#include "core/ba/ba_problem.h"
#include "core/ba/problem_dispatch.h"
#include "core/base/worker_pool.h"

namespace slamd::core {
namespace {

using internal::BaProblem;
using internal::ReducedCameraMatrix;

// S⁻¹ without the gauge unknowns (positions order), densely: all of it.
Result<Eigen::MatrixXd> DenseInverse(const ReducedCameraMatrix& s, const std::vector<int>& gauge) {
  const Eigen::MatrixXd S = s.ToDense();
  std::vector<int> kept;
  for (int k = 0; k < s.dim(); ++k) {
    if (std::find(gauge.begin(), gauge.end(), k) == gauge.end()) kept.push_back(k);
  }
  const int m = static_cast<int>(kept.size());
  Eigen::MatrixXd reduced(m, m);
  for (int a = 0; a < m; ++a) {
    for (int c = 0; c < m; ++c) reduced(a, c) = S(kept[a], kept[c]);
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(reduced);
  if (llt.info() != Eigen::Success) return NumericalFailure("not positive definite");
  const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(m, m));
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(s.dim(), s.dim());
  for (int a = 0; a < m; ++a) {
    for (int c = 0; c < m; ++c) full(kept[a], kept[c]) = inverse(a, c);
  }
  return full;
}

template <typename Cal, bool kRefineCal>
Result<CameraCovariances> Estimate(const Reconstruction& r, const BundleAdjusterParams& params,
                                   double pixel_sigma, int max_dense_dim) {
  using Problem = BaProblem<Cal, kRefineCal>;
  constexpr int kD = Problem::kD;
  const int n = static_cast<int>(r.images.size());
  CameraCovariances out{.block_dim = kD};
  // The scale: the image farthest from image 0, along its own axis nearest the baseline.
  const Point3 c0 = r.images[0].pose.translation();
  for (int i = 1; i < n; ++i) {
    if ((r.images[i].pose.translation() - c0).norm() >
        (r.images[out.scale_image].pose.translation() - c0).norm()) {
      out.scale_image = i;
    }
  }
  const Pose3& scale_pose = r.images[out.scale_image].pose;
  const Vector3 baseline =
      scale_pose.rotation().matrix().transpose() * (scale_pose.translation() - c0);
  baseline.cwiseAbs().maxCoeff(&out.scale_axis);
  if (out.scale_image == 0 || baseline.norm() == 0.0) {
    return FailedPrecondition("camera covariances: no second camera centre to fix the scale");
  }

  const bool sparse = kD * n > max_dense_dim;
  Result<std::vector<int>> positions = internal::CameraPositions(r, sparse);
  if (!positions.ok()) return positions.status();
  const std::vector<int> position = positions.value();
  WorkerPool pool(params.num_threads - 1);
  Problem problem(r, params.robust, position, &pool,
                  {.principal_point = params.refine_principal_point});
  problem.Linearize(Problem::StateOf(r));
  ReducedCameraMatrix s(kD, problem.CoVisibility());
  Eigen::VectorXd b;
  problem.EliminatePoints(0.0, 1e-12, &s, nullptr, &b);
  std::vector<int> gauge;
  for (int k = 0; k < 6; ++k) gauge.push_back(kD * position[0] + k);
  gauge.push_back(kD * position[out.scale_image] + out.scale_axis);
  if constexpr (kRefineCal) {  // calibration parameters the model holds: no variance
    for (int i = 0; i < n; ++i) {
      for (int c = 0; c < Cal::kDim; ++c) {
        if (problem.cal_basis(i).col(c).isZero()) gauge.push_back(kD * position[i] + 6 + c);
      }
    }
  }

  const std::string singular =
      "camera covariances: the reduced camera system is singular beyond the gauge (cameras that "
      "share too few points with the rest)";
  const double variance = pixel_sigma * pixel_sigma;
  if (!sparse) {
    const Result<Eigen::MatrixXd> inverse = DenseInverse(s, gauge);
    if (!inverse.ok()) return FailedPrecondition(singular);
    for (int i = 0; i < n; ++i) {
      const int p = kD * position[i];
      out.per_image.push_back(variance * inverse->block(p, p, kD, kD));
    }
    return out;
  }
  // Sparse: the gauge unknowns decoupled, one factorisation, and per camera its kD columns of
  // S⁻¹ (kD solves each): the diagonal blocks without the rest of the inverse.
  for (int k : gauge) s.Pin(k);
  if (!s.FactorSparse().ok()) return FailedPrecondition(singular);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(s.dim()), x;
  for (int i = 0; i < n; ++i) {
    const int p = kD * position[i];
    Eigen::MatrixXd block = Eigen::MatrixXd::Zero(kD, kD);
    for (int c = 0; c < kD; ++c) {
      if (std::find(gauge.begin(), gauge.end(), p + c) != gauge.end()) continue;
      e[p + c] = 1.0;
      SLAMD_RETURN_IF_ERROR(s.SolveFactored(e, &x));
      e[p + c] = 0.0;
      block.col(c) = x.segment(p, kD);
    }
    // The gauge rows: x there is e's, 0; the block is symmetric up to round-off.
    out.per_image.push_back(variance * 0.5 * (block + block.transpose()));
  }
  return out;
}

}  // namespace

Result<CameraCovariances> EstimateCameraCovariances(const Reconstruction& reconstruction,
                                                    const BundleAdjusterParams& params,
                                                    double pixel_sigma, int max_dense_dim) {
  if (Status s = params.Validate(); !s.ok()) return s;
  if (!(pixel_sigma > 0.0) || !std::isfinite(pixel_sigma)) {
    return InvalidArgument("camera covariances: pixel_sigma = " + std::to_string(pixel_sigma) +
                           "; must be positive");
  }
  if (Status s = internal::CheckAdjustable(reconstruction, "camera covariances"); !s.ok()) {
    return s;
  }
  if (reconstruction.images.size() < 2) {
    return FailedPrecondition("camera covariances: at least 2 images are needed for a gauge");
  }
  return internal::WithProblemType(params, reconstruction, [&]<typename Cal, bool kRefineCal>() {
    return Estimate<Cal, kRefineCal>(reconstruction, params, pixel_sigma, max_dense_dim);
  });
}

}  // namespace slamd::core
