#include "clients/slamctl/trajectory_error.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/SVD>

#include "core/io/dataset.h"

namespace slamd::clients {

core::Result<RigidAlignment> AlignRigid(const Eigen::MatrixXd& estimate, const Eigen::MatrixXd& truth) {
  const Eigen::Index d = estimate.rows(), n = estimate.cols();
  if ((d != 2 && d != 3) || truth.rows() != d || truth.cols() != n || n < 1) {
    return core::InvalidArgument("AlignRigid: point sets must both be 2xN or 3xN with N >= 1");
  }
  if (!estimate.allFinite() || !truth.allFinite()) {
    return core::InvalidArgument("AlignRigid: non-finite coordinates");
  }
  // 1. Centroids; the optimal t maps the estimate's centroid onto the truth's.
  const Eigen::VectorXd mu_e = estimate.rowwise().mean();
  const Eigen::VectorXd mu_t = truth.rowwise().mean();
  // 2. Cross-covariance Σ = Σ_i (truth_i − μ_t)(est_i − μ_e)ᵀ (the 1/n does not change R).
  const Eigen::MatrixXd S = (truth.colwise() - mu_t) * (estimate.colwise() - mu_e).transpose();
  // 3. Umeyama: with Σ = U D Vᵀ, R = U · diag(1, .., 1, det(U)·det(V)) · Vᵀ, which is the best
  //    proper rotation even when the best orthogonal matrix would be a reflection.
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::VectorXd signs = Eigen::VectorXd::Ones(d);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) signs(d - 1) = -1.0;
  RigidAlignment a;
  a.R = svd.matrixU() * signs.asDiagonal() * svd.matrixV().transpose();
  if (n == 1) a.R = Eigen::MatrixXd::Identity(d, d);  // S = 0: every rotation is optimal
  a.t = mu_t - a.R * mu_e;
  return a;
}

namespace {

// The position of a pose variable, or an empty vector for other kinds.
Eigen::VectorXd Position(const core::Variable& v) {
  if (const auto* p = std::get_if<core::Pose2>(&v)) return p->translation();
  if (const auto* p = std::get_if<core::Pose3>(&v)) return p->translation();
  return {};
}

}  // namespace

core::Result<TrajectoryError> AbsoluteTrajectoryError(const core::Values& estimate, const core::Values& truth) {
  std::vector<Eigen::VectorXd> est, tru;
  Eigen::Index dim = 0;
  for (core::Key key : estimate.keys()) {
    const int slot = truth.SlotOf(key);
    if (slot < 0) continue;
    Eigen::VectorXd e = Position(estimate.Get(key));
    Eigen::VectorXd t = Position(truth.VariableAt(slot));
    if (e.size() == 0 || t.size() == 0) continue;
    if (e.size() != t.size() || (dim != 0 && e.size() != dim)) {
      return core::InvalidArgument("ATE: " + core::KeyToString(key) + " mixes 2D and 3D poses");
    }
    dim = e.size();
    est.push_back(std::move(e));
    tru.push_back(std::move(t));
  }
  if (est.empty()) return core::InvalidArgument("ATE: the estimate and the ground truth share no pose");
  Eigen::MatrixXd E(dim, static_cast<Eigen::Index>(est.size())), T(dim, E.cols());
  for (Eigen::Index i = 0; i < E.cols(); ++i) {
    E.col(i) = est[i];
    T.col(i) = tru[i];
  }
  core::Result<RigidAlignment> aligned = AlignRigid(E, T);
  if (!aligned.ok()) return aligned.status();
  TrajectoryError out;
  out.poses = est.size();
  const Eigen::MatrixXd residual = (aligned->R * E).colwise() + aligned->t - T;
  const Eigen::VectorXd norms = residual.colwise().norm();
  out.rmse = std::sqrt(norms.squaredNorm() / static_cast<double>(norms.size()));
  out.max = norms.maxCoeff();
  out.alignment = std::move(aligned).value();
  return out;
}

core::Result<core::Values> ReadGroundTruth(const std::string& path) {
  core::Result<core::Dataset> data = core::ReadDataset(path);
  if (!data.ok()) return data.status();
  core::Values poses;
  for (core::Key key : data->poses) {
    const core::Status s = poses.Insert(key, data->initial.Get(key));
    if (!s.ok()) return s;
  }
  return poses;
}

}  // namespace slamd::clients
