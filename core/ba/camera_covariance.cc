#include "core/ba/camera_covariance.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <string>

#include "core/ba/border_elimination.h"
#include "core/ba/problem_dispatch.h"
#include "core/base/worker_pool.h"

namespace slamd::core {
namespace {

using internal::CalibrationBorder;
using internal::ReducedCameraMatrix;

// The inverse of the symmetric `a` without the `pinned` unknowns (zero rows and columns there).
Result<Eigen::MatrixXd> InverseWithout(const Eigen::MatrixXd& a, const std::vector<int>& pinned) {
  std::vector<int> kept;
  for (int k = 0; k < a.rows(); ++k) {
    if (std::find(pinned.begin(), pinned.end(), k) == pinned.end()) kept.push_back(k);
  }
  const int m = static_cast<int>(kept.size());
  Eigen::MatrixXd reduced(m, m);
  for (int i = 0; i < m; ++i) {
    for (int c = 0; c < m; ++c) reduced(i, c) = a(kept[i], kept[c]);
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(reduced);
  if (llt.info() != Eigen::Success) return NumericalFailure("not positive definite");
  const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(m, m));
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(a.rows(), a.cols());
  for (int i = 0; i < m; ++i) {
    for (int c = 0; c < m; ++c) full(kept[i], kept[c]) = inverse(i, c);
  }
  return full;
}

template <typename Cal, bool kRefineCal>
Result<CameraCovariances> Estimate(const Reconstruction& r, const BundleAdjusterParams& params,
                                   double pixel_sigma, int max_dense_dim) {
  using Problem = internal::BaBorderedProblem<Cal, kRefineCal>;
  constexpr int kD = Problem::kD, kC = Cal::kDim;
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
  const bool shared = params.refine_intrinsics && !kRefineCal;
  Problem problem(r, params.robust, position, &pool,
                  {.shared = shared, .principal_point = params.refine_principal_point});
  problem.Linearize(Problem::StateOf(r));
  ReducedCameraMatrix s(kD, problem.CoVisibility());
  Eigen::VectorXd b;
  problem.EliminatePoints(0.0, 1e-12, &s, nullptr, &b);
  CalibrationBorder border;  // shared calibrations: [S E; Eᵀ F], undamped
  if (shared) problem.EliminateBorder(&border);
  std::vector<int> gauge;  // pose unknowns held (S's positions)
  for (int k = 0; k < 6; ++k) gauge.push_back(kD * position[0] + k);
  gauge.push_back(kD * position[out.scale_image] + out.scale_axis);
  std::vector<int> held;  // calibration parameters the model holds: no variance
  for (int i = 0; i < n; ++i) {
    for (int c = 0; c < kC && (kRefineCal || shared); ++c) {
      if (!problem.cal_basis(i).col(c).isZero()) continue;
      const int k = kRefineCal ? kD * position[i] + 6 + c : kC * problem.shared_of(i) + c;
      if (std::find(held.begin(), held.end(), k) == held.end()) held.push_back(k);
    }
  }
  if constexpr (kRefineCal) gauge.insert(gauge.end(), held.begin(), held.end());
  std::vector<int> shared_index(r.intrinsics.size(), -1);  // intrinsics → shared unknown
  for (int i = 0; i < n && shared; ++i) shared_index[r.images[i].intrinsics] = problem.shared_of(i);

  const std::string singular =
      "camera covariances: the reduced camera system is singular beyond the gauge (cameras that "
      "share too few points with the rest)";
  const double variance = pixel_sigma * pixel_sigma;
  const int m = border.dim(), dim = s.dim();
  // Each shared calibration's covariance from the inverse of its block of the system's.
  const auto calibrations = [&](const Eigen::MatrixXd& inverse, int offset) {
    if (!shared) return;
    out.per_intrinsics.resize(r.intrinsics.size());
    for (size_t k = 0; k < r.intrinsics.size(); ++k) {
      const int u = shared_index[k];
      if (u >= 0)
        out.per_intrinsics[k] = variance * inverse.block(offset + kC * u, offset + kC * u, kC, kC);
    }
  };
  if (!sparse) {
    Eigen::MatrixXd full = s.ToDense();
    std::vector<int> pinned = gauge;
    if (shared) {
      full.conservativeResize(dim + m, dim + m);
      full.topRightCorner(dim, m) = border.e;
      full.bottomLeftCorner(m, dim) = border.e.transpose();
      full.bottomRightCorner(m, m) = border.f;
      for (int k : held) pinned.push_back(dim + k);
    }
    const Result<Eigen::MatrixXd> inverse = InverseWithout(full, pinned);
    if (!inverse.ok()) return FailedPrecondition(singular);
    for (int i = 0; i < n; ++i) {
      const int p = kD * position[i];
      out.per_image.push_back(variance * inverse->block(p, p, kD, kD));
    }
    calibrations(*inverse, dim);
    return out;
  }
  // Sparse: the gauge unknowns decoupled, one factorisation, and per camera its kD columns of
  // S⁻¹ (kD solves each): the diagonal blocks without the rest of the inverse. Shared
  // calibrations add Y G⁻¹ Yᵀ to them (Y = S⁻¹ E, G = F − Eᵀ Y: the border's inverse).
  for (int k : gauge) s.Pin(k);
  if (!s.FactorSparse().ok()) return FailedPrecondition(singular);
  Eigen::MatrixXd y(dim, m), g_inverse;
  Eigen::VectorXd e = Eigen::VectorXd::Zero(dim), x;
  if (shared) {
    for (int k : gauge) border.e.row(k).setZero();
    for (int c = 0; c < m; ++c) {
      SLAMD_RETURN_IF_ERROR(s.SolveFactored(border.e.col(c), &x));
      y.col(c) = x;
    }
    const Result<Eigen::MatrixXd> inverse =
        InverseWithout(border.f - border.e.transpose() * y, held);
    if (!inverse.ok()) return FailedPrecondition(singular);
    g_inverse = *inverse;
    calibrations(g_inverse, 0);
  }
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
    if (shared) block += y.middleRows(p, kD) * g_inverse * y.middleRows(p, kD).transpose();
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
