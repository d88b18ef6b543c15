#include "core/inference/chow_liu.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

#include "core/base/check.h"
#include "core/factors/linear_container_factor.h"

namespace slamd::core {
namespace {

constexpr double kRegularization = 1e-9;

// log det of a symmetric positive-definite block; -inf when it is not.
double LogDet(const Eigen::MatrixXd& m) {
  const Eigen::LLT<Eigen::MatrixXd> llt(m);
  if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  return 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
}

// Upper-triangular W with WᵀW = info.
Result<Eigen::MatrixXd> SqrtInformation(const Eigen::MatrixXd& info) {
  const Eigen::LLT<Eigen::MatrixXd> llt(info);
  if (llt.info() != Eigen::Success || !info.allFinite()) {
    return FailedPrecondition("ChowLiuTree: a conditional's information is not positive definite");
  }
  return Eigen::MatrixXd(llt.matrixU());
}

}  // namespace

Result<std::vector<FactorPtr>> ChowLiuTree(const KeyVector& keys, const std::vector<Variable>& x0,
                                           const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  const int k = static_cast<int>(keys.size());
  SLAMD_CHECK(k >= 3 && x0.size() == keys.size()) << "ChowLiuTree of " << k << " variables";
  std::vector<int> at{0};  // first column of each variable
  for (const Variable& v : x0) at.push_back(at.back() + TangentDim(TypeOf(v)));
  const int n = at.back();
  // The Gaussian: information Λ = AᵀA, mean μ minimising |Aδ + b|² (regularised).
  Eigen::MatrixXd info = A.transpose() * A;
  const double reg = kRegularization * std::max(info.diagonal().mean(), 1e-300);
  info.diagonal().array() += reg;
  const Eigen::LLT<Eigen::MatrixXd> llt(info);
  if (llt.info() != Eigen::Success || !info.allFinite()) {
    return FailedPrecondition("ChowLiuTree: the summary's information is not positive definite");
  }
  const Eigen::VectorXd mean = llt.solve(-(A.transpose() * b));
  const Eigen::MatrixXd cov = llt.solve(Eigen::MatrixXd::Identity(n, n));
  // A conditional given one variable holds at most the information the variable has given all
  // the others (Σ_{i|p}⁻¹ ⪯ Λii; on p, KᵀΣ_{i|p}⁻¹K ⪯ Λpp): a tree factor holding more is
  // round-off of the regularised covariance (near-singular directions): the tree is refused.
  const auto plausible = [&](int i, const Eigen::MatrixXd& w) {
    const int d = at[i + 1] - at[i];
    return w.squaredNorm() <= 1.01 * info.block(at[i], at[i], d, d).trace() + 1e-300;
  };
  const auto block = [&](int i, int j) {
    return cov.block(at[i], at[j], at[i + 1] - at[i], at[j + 1] - at[j]);
  };

  // Maximum spanning tree of the mutual information I(i; j) = ½ (log|Σii| + log|Σjj| − log|Σ|)
  // (Prim, O(k²) pairs), rooted at variable 0.
  std::vector<double> log_det(k);
  for (int i = 0; i < k; ++i) log_det[i] = LogDet(block(i, i));
  const auto mutual_information = [&](int i, int j) {
    const int di = at[i + 1] - at[i], dj = at[j + 1] - at[j];
    Eigen::MatrixXd joint(di + dj, di + dj);
    joint << block(i, i), block(i, j), block(j, i), block(j, j);
    return 0.5 * (log_det[i] + log_det[j] - LogDet(joint));
  };
  std::vector<int> parent(k, -1);
  std::vector<double> best(k, -std::numeric_limits<double>::infinity());
  std::vector<char> in_tree(k, 0);
  std::vector<int> order;  // tree order: every variable after its parent
  int next = 0;
  for (int step = 0; step < k; ++step) {
    in_tree[next] = 1;
    order.push_back(next);
    int pick = -1;
    for (int j = 0; j < k; ++j) {
      if (in_tree[j]) continue;
      // Round-off can make a pair's determinant meaningless (NaN): it counts as no information,
      // and every variable gets a parent in the tree.
      const double mi = mutual_information(next, j);
      const double weight = std::isnan(mi) ? -std::numeric_limits<double>::infinity() : mi;
      if (parent[j] < 0 || weight > best[j]) best[j] = weight, parent[j] = next;
      if (pick < 0 || best[j] > best[pick]) pick = j;
    }
    next = pick;
  }

  std::vector<FactorPtr> out;
  const auto make = [&](KeyVector factor_keys, std::vector<Variable> points, Eigen::MatrixXd a,
                        Eigen::VectorXd rhs) -> Status {
    Result<FactorPtr> f = LinearContainerFactor::Create(std::move(factor_keys), std::move(points),
                                                        std::move(a), std::move(rhs));
    if (!f.ok()) return f.status();
    out.push_back(std::move(f).value());
    return Status::Ok();
  };
  // The root: its marginal, |W (δ_r − μ_r)|² with WᵀW = Σrr⁻¹.
  const int r = order[0];
  const int dr = at[r + 1] - at[r];
  Result<Eigen::MatrixXd> w =
      SqrtInformation(Eigen::MatrixXd(block(r, r)).llt().solve(Eigen::MatrixXd::Identity(dr, dr)));
  if (!w.ok()) return w.status();
  if (!plausible(r, *w)) return FailedPrecondition("ChowLiuTree: the root's marginal is round-off");
  SLAMD_RETURN_IF_ERROR(make({keys[r]}, {x0[r]}, *w, -(*w) * mean.segment(at[r], dr)));
  // Each edge: p(x_i | x_p) = N(μ_i + K (δ_p − μ_p), Σii − K Σpi), K = Σip Σpp⁻¹, as
  // |W (δ_i − K δ_p − c)|² with c = μ_i − K μ_p and WᵀW the conditional's information.
  for (std::size_t t = 1; t < order.size(); ++t) {
    const int i = order[t], p = parent[i];
    const int di = at[i + 1] - at[i], dp = at[p + 1] - at[p];
    const Eigen::MatrixXd pp = block(p, p);
    const Eigen::MatrixXd K = pp.llt().solve(Eigen::MatrixXd(block(p, i))).transpose();
    const Eigen::MatrixXd conditional = block(i, i) - K * block(p, i);
    w = SqrtInformation(conditional.llt().solve(Eigen::MatrixXd::Identity(di, di)));
    if (!w.ok()) return w.status();
    if (!plausible(i, *w) || !plausible(p, (*w) * K)) {
      return FailedPrecondition("ChowLiuTree: the conditional of " + KeyToString(keys[i]) +
                                " is round-off");
    }
    Eigen::MatrixXd edge(di, di + dp);
    edge << *w, -(*w) * K;
    const Eigen::VectorXd c = mean.segment(at[i], di) - K * mean.segment(at[p], dp);
    SLAMD_RETURN_IF_ERROR(make({keys[i], keys[p]}, {x0[i], x0[p]}, edge, -(*w) * c));
  }
  return out;
}

}  // namespace slamd::core
