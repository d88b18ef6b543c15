#include "core/ba/camera_covariance.h"

#include <Eigen/Cholesky>
#include <numeric>
#include <string>

#include "core/ba/ba_problem.h"
#include "core/ba/problem_dispatch.h"
#include "core/base/worker_pool.h"

namespace slamd::core {
namespace {

using internal::BaProblem;
using internal::ReducedCameraMatrix;

template <typename Cal, bool kRefineCal>
Result<CameraCovariances> Estimate(const Reconstruction& r, const BundleAdjusterParams& params,
                                   double pixel_sigma, int max_dense_dim) {
  using Problem = BaProblem<Cal, kRefineCal>;
  constexpr int kD = Problem::kD;
  const int n = static_cast<int>(r.images.size());
  if (kD * n > max_dense_dim) {
    return FailedPrecondition("camera covariances: " + std::to_string(kD * n) +
                              " camera unknowns, more than the dense limit of " +
                              std::to_string(max_dense_dim));
  }
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

  std::vector<int> identity(n);
  std::iota(identity.begin(), identity.end(), 0);
  WorkerPool pool(params.num_threads - 1);
  Problem problem(r, params.robust, identity, &pool);
  problem.Linearize(Problem::StateOf(r));
  ReducedCameraMatrix s(kD, problem.CoVisibility());
  Eigen::VectorXd b;
  problem.EliminatePoints(0.0, 1e-12, &s, nullptr, &b);
  const Eigen::MatrixXd S = s.ToDense();

  // Keep every unknown but the gauge's.
  std::vector<int> kept;
  for (int k = 0; k < kD * n; ++k) {
    if (k < 6 || k == kD * out.scale_image + out.scale_axis) continue;
    kept.push_back(k);
  }
  const int m = static_cast<int>(kept.size());
  Eigen::MatrixXd reduced(m, m);
  for (int a = 0; a < m; ++a) {
    for (int c = 0; c < m; ++c) reduced(a, c) = S(kept[a], kept[c]);
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(reduced);
  if (llt.info() != Eigen::Success) {
    return FailedPrecondition(
        "camera covariances: the reduced camera system is singular beyond the gauge (cameras "
        "that share too few points with the rest)");
  }
  const Eigen::MatrixXd inverse =
      llt.solve(Eigen::MatrixXd::Identity(m, m)) * (pixel_sigma * pixel_sigma);
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(kD * n, kD * n);
  for (int a = 0; a < m; ++a) {
    for (int c = 0; c < m; ++c) full(kept[a], kept[c]) = inverse(a, c);
  }
  for (int i = 0; i < n; ++i) out.per_image.push_back(full.block(kD * i, kD * i, kD, kD));
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
