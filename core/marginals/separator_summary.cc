#include "core/marginals/separator_summary.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <string>
#include <unordered_map>

#include "core/factors/linear_container_factor.h"
#include "core/factors/linearized_factor.h"
#include "core/factors/values.h"

namespace slamd::core {

Result<FactorPtr> SeparatorSummary(const KeyVector& keys, const std::vector<Variable>& at,
                                   const Eigen::MatrixXd& joint_cov,
                                   std::span<const FactorPtr> excluded,
                                   const SeparatorSummaryParams& params) {
  if (!(params.rank_tolerance > 0.0 && params.rank_tolerance < 1.0)) {
    return InvalidArgument("SeparatorSummaryParams.rank_tolerance = " +
                           std::to_string(params.rank_tolerance) + "; must be in (0, 1)");
  }
  if (params.kept_keys == 0 || params.kept_keys > static_cast<int>(keys.size())) {
    return InvalidArgument(
        "SeparatorSummaryParams.kept_keys = " + std::to_string(params.kept_keys) +
        "; must be -1 or in [1, " + std::to_string(keys.size()) + "]");
  }
  if (keys.empty() || at.size() != keys.size()) {
    return InvalidArgument("separator summary: " + std::to_string(keys.size()) + " keys and " +
                           std::to_string(at.size()) + " values");
  }
  Values values;
  std::unordered_map<Key, int> column;
  int n = 0;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    SLAMD_RETURN_IF_ERROR(values.Insert(keys[i], at[i]));
    column[keys[i]] = n;
    n += TangentDim(TypeOf(at[i]));
  }
  if (joint_cov.rows() != n || joint_cov.cols() != n || !joint_cov.allFinite()) {
    return InvalidArgument("separator summary: the joint covariance is " +
                           std::to_string(joint_cov.rows()) + "x" +
                           std::to_string(joint_cov.cols()) + " (or not finite); expected " +
                           std::to_string(n) + "x" + std::to_string(n));
  }
  const double scale = joint_cov.cwiseAbs().maxCoeff();
  if (!((joint_cov - joint_cov.transpose()).cwiseAbs().maxCoeff() <= 1e-9 * scale)) {
    return InvalidArgument("separator summary: the joint covariance is not symmetric");
  }
  Eigen::LLT<Eigen::MatrixXd> llt(joint_cov);
  if (llt.info() != Eigen::Success) {
    return FailedPrecondition("separator summary: the joint covariance is not positive definite");
  }
  Eigen::MatrixXd information = llt.solve(Eigen::MatrixXd::Identity(n, n));
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
  LinearizedFactor lf;
  for (const FactorPtr& f : excluded) {
    for (Key k : f->keys()) {
      if (!column.contains(k)) {
        return InvalidArgument("separator summary: an excluded " + std::string(f->Name()) +
                               " factor is on " + KeyToString(k) + ", not one of the keys");
      }
    }
    f->Linearize(values, &lf);
    for (int a = 0; a < lf.num_keys(); ++a) {
      const int ca = column[f->keys()[a]];
      g.segment(ca, lf.dim(a)) -= lf.Block(a).transpose() * lf.Rhs();
      for (int b = 0; b < lf.num_keys(); ++b) {
        const int cb = column[f->keys()[b]];
        information.block(ca, cb, lf.dim(a), lf.dim(b)) -= lf.Block(a).transpose() * lf.Block(b);
      }
    }
  }
  information = 0.5 * (information + information.transpose()).eval();
  const int kept = params.kept_keys < 0 ? static_cast<int>(keys.size()) : params.kept_keys;
  if (kept < static_cast<int>(keys.size())) {
    const int m = column[keys[kept]];  // the kept keys' columns come first
    const double left = information.rightCols(n - m).cwiseAbs().maxCoeff();
    if (left > 1e-6 * information.cwiseAbs().maxCoeff()) {
      return FailedPrecondition("separator summary: " + KeyToString(keys[kept]) +
                                " and the keys after it still carry information (" +
                                std::to_string(left) + ") once the excluded factors are out");
    }
    information = information.topLeftCorner(m, m).eval();
    g = g.head(m).eval();
    n = m;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(information);
  const Eigen::VectorXd& lambda = eig.eigenvalues();  // ascending
  const double floor = params.rank_tolerance * std::max(lambda(n - 1), 0.0);
  int first = 0;
  while (first < n && !(lambda(first) > floor)) ++first;
  const int rank = n - first;
  if (rank == 0) return FactorPtr();
  const Eigen::MatrixXd V = eig.eigenvectors().rightCols(rank);
  const Eigen::ArrayXd root = lambda.tail(rank).array().sqrt();
  Eigen::MatrixXd A = root.matrix().asDiagonal() * V.transpose();
  Eigen::VectorXd b = (V.transpose() * g).array() / root;
  return LinearContainerFactor::Create(KeyVector(keys.begin(), keys.begin() + kept),
                                       std::vector<Variable>(at.begin(), at.begin() + kept),
                                       std::move(A), std::move(b));
}

Result<FactorPtr> SeparatorSummary(const Isam2& solver, Isam2Marginals& marginals,
                                   const KeyVector& keys, std::span<const FactorPtr> excluded,
                                   const SeparatorSummaryParams& params) {
  std::vector<Variable> at;
  at.reserve(keys.size());
  for (Key k : keys) {
    if (!solver.linearization_point().Contains(k)) {
      return NotFound("separator summary: no variable " + KeyToString(k));
    }
    at.push_back(solver.CalculateEstimate(k));
  }
  Eigen::MatrixXd cov;
  SLAMD_RETURN_IF_ERROR(marginals.JointMarginal(keys, Isam2Marginals::Frame::kEstimate, &cov));
  return SeparatorSummary(keys, at, cov, excluded, params);
}

}  // namespace slamd::core
