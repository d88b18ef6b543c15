#include "core/inference/chow_liu.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <utility>

#include "core/base/check.h"
#include "core/factors/linear_container_factor.h"

namespace slamd::core {
namespace {

// An eigenvalue of the summary's information below this times its largest is a null direction.
constexpr double kNullTolerance = 1e-10;
// A variable whose tangent the null space's basis covers with singular values below this (of
// at most 1) cannot be the root.
constexpr double kMinSpan = 1e-6;
// The prior given to null directions the root does not take.
constexpr double kRegularization = 1e-9;
// |AN| below this x |A||N|: the summary does not see the root's rigid motion.
constexpr double kRigidTolerance = 1e-8;
// TreeEdgeFrame::kParent: an edge factor drops a term below this x the scale of its coupling.
constexpr double kEdgeTolerance = 0.05;
// parents == 2: a second parent that would lower the divergence by less than this (nats) is
// round-off, not taken: it would cost the factor a key for nothing.
constexpr double kMinSecondParentGain = 1e-6;

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

// N (n x TangentDim(root)) of the rigid motion of every variable with a pose root: δ = N δ_r
// moves each by the root's right perturbation δ_r in its frame (N_r = I), read off the
// root-relative form's Jacobian at x0 (its coordinates y_i have ∂y_i/∂δ_r = −N_i there). Empty
// when the root is no pose or a variable cannot be taken relative to it.
Eigen::MatrixXd RigidMotionOfRoot(const KeyVector& keys, const std::vector<Variable>& x0, int root,
                                  const std::vector<int>& at) {
  const int k = static_cast<int>(keys.size());
  const int n = at.back(), dr = at[root + 1] - at[root];
  KeyVector order;
  std::vector<Variable> values;
  for (int i = 0; i < k; ++i) {
    if (i != root) order.push_back(keys[i]), values.push_back(x0[i]);
  }
  order.push_back(keys[root]);
  values.push_back(x0[root]);
  Result<FactorPtr> probe = LinearContainerFactor::CreateRootRelative(
      order, values, Eigen::MatrixXd::Identity(n - dr, n - dr), Eigen::VectorXd::Zero(n - dr));
  if (!probe.ok()) return {};
  std::vector<const Variable*> x;
  for (const Variable& v : values) x.push_back(&v);
  std::vector<Eigen::MatrixXd> H(values.size());
  static_cast<const LinearContainerFactor&>(**probe).Evaluate(x, &H);
  Eigen::MatrixXd N(n, dr);
  for (int i = 0, row = 0; i < k; ++i) {
    if (i == root) {
      N.middleRows(at[i], dr).setIdentity();
      continue;
    }
    const int d = at[i + 1] - at[i];
    N.middleRows(at[i], d) = -H.back().middleRows(row, d);
    row += d;
  }
  return N;
}

}  // namespace

Result<std::vector<FactorPtr>> ChowLiuTree(const KeyVector& keys, const std::vector<Variable>& x0,
                                           const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                           std::span<const char> preferred,
                                           TreeEdgeFrame edge_frame, int parents) {
  const int k = static_cast<int>(keys.size());
  SLAMD_CHECK(k >= 3 && x0.size() == keys.size()) << "ChowLiuTree of " << k << " variables";
  std::vector<int> at{0};  // first column of each variable in δ
  for (const Variable& v : x0) at.push_back(at.back() + TangentDim(TypeOf(v)));
  const int n = at.back();
  const auto dim = [&](int i) { return at[i + 1] - at[i]; };
  if (!A.allFinite() || !b.allFinite()) {
    return FailedPrecondition("ChowLiuTree: the summary has non-finite entries");
  }

  // The gauge: in the null space V of Λ = AᵀA. The root is shifted out along it: with
  // N = V V_r⁺ (N_r = I when V_r has full row rank) and AN = 0, δ = N δ_r + y on the other
  // variables' y_i = δ_i − N_i δ_r, and the summary is |A_y y + b|² (A_y: A without the root's
  // columns). The root is a variable of the largest tangent V spans (a pose, not a landmark:
  // it takes the whole gauge), the best spanned among those.
  const Eigen::MatrixXd full_info = A.transpose() * A;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(full_info);
  const Eigen::VectorXd& lambda = eigen.eigenvalues();  // ascending
  int nullity = 0;
  while (nullity < n && lambda(nullity) <= kNullTolerance * lambda(n - 1)) ++nullity;
  int root = -1;  // the shifted variable, or -1
  Eigen::MatrixXd N;
  bool relative = false;  // the tree's factors in the root-relative form
  if (nullity > 0) {
    const Eigen::MatrixXd V = eigen.eigenvectors().leftCols(nullity);
    std::tuple<int, bool, double> best{0, false, 0.0};
    for (int i = 0; i < k; ++i) {
      if (dim(i) > nullity) continue;
      const double sigma = Eigen::JacobiSVD<Eigen::MatrixXd>(V.middleRows(at[i], dim(i)))
                               .singularValues()
                               .minCoeff();
      if (sigma < kMinSpan) continue;
      const std::tuple<int, bool, double> rank{dim(i), !preferred.empty() && preferred[i], sigma};
      if (root < 0 || rank > best) best = rank, root = i;
    }
    if (root >= 0) {
      // A pose root whose rigid motion, carrying the others along, the summary does not see
      // (AN = 0 for the N of that motion): the tree's factors take the others' values in its
      // frame (LinearContainerFactor's root-relative form), whose first-order coordinates are
      // y with that N, so that a later rigid correction of the region does not bend them.
      N = RigidMotionOfRoot(keys, x0, root, at);
      relative = N.size() > 0 && (A * N).norm() <= kRigidTolerance * A.norm() * N.norm();
      if (!relative) {
        const Eigen::MatrixXd Vr = V.middleRows(at[root], dim(root));
        N = V * Vr.transpose() * (Vr * Vr.transpose()).inverse();
      }
    }
  }
  // The variables of the tree (all but the root) and their columns in y.
  std::vector<int> var, col{0};
  for (int i = 0; i < k; ++i) {
    if (i == root) continue;
    var.push_back(i);
    col.push_back(col.back() + dim(i));
  }
  const int m = static_cast<int>(var.size());
  Eigen::MatrixXd Ay(A.rows(), col.back());
  for (int t = 0; t < m; ++t) {
    Ay.middleCols(col[t], dim(var[t])) = A.middleCols(at[var[t]], dim(var[t]));
  }
  // What is left singular is not the gauge: directions the removed factors did not inform (a
  // pose seen only through one landmark's range and bearing), each local to a few variables.
  // They get kRegularization x the mean diagonal, a negligible prior.
  Eigen::MatrixXd info = Ay.transpose() * Ay;
  if (nullity > (root >= 0 ? dim(root) : 0)) {
    info.diagonal().array() += kRegularization * std::max(info.diagonal().mean(), 1e-300);
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(info);
  if (llt.info() != Eigen::Success) {
    return FailedPrecondition("ChowLiuTree: the summary's information is not positive definite");
  }
  const Eigen::VectorXd mean = llt.solve(-(Ay.transpose() * b));
  const Eigen::MatrixXd cov = llt.solve(Eigen::MatrixXd::Identity(col.back(), col.back()));
  // A conditional given one variable holds at most the information the variable has given all
  // the others (Σ_{i|p}⁻¹ ⪯ Λii; on p, KᵀΣ_{i|p}⁻¹K ⪯ Λpp): a tree factor holding more is
  // round-off (near-singular directions): the tree is refused.
  const auto plausible = [&](int t, const Eigen::MatrixXd& w) {
    const int d = col[t + 1] - col[t];
    return w.squaredNorm() <= 1.01 * info.block(col[t], col[t], d, d).trace() + 1e-300;
  };
  const auto block = [&](int s, int t) {
    return cov.block(col[s], col[t], col[s + 1] - col[s], col[t + 1] - col[t]);
  };

  // Maximum spanning tree of the mutual information I(s; t) = ½ (log|Σss| + log|Σtt| − log|Σ|)
  // (Prim, O(m²) pairs), rooted at the first tree variable, or with a shifted root at the pose
  // the root's frame determines best (the smallest covariance): its unary factor stands for its
  // link to the root, and the tree's edges then run out from the root as the summary does
  // (TreeEdgeFrame::kParent: a chain's conditionals each carry the child with its parent).
  std::vector<double> log_det(m);
  for (int t = 0; t < m; ++t) log_det[t] = LogDet(block(t, t));
  const auto mutual_information = [&](int s, int t) {
    const int ds = col[s + 1] - col[s], dt = col[t + 1] - col[t];
    Eigen::MatrixXd joint(ds + dt, ds + dt);
    joint << block(s, s), block(s, t), block(t, s), block(t, t);
    return 0.5 * (log_det[s] + log_det[t] - LogDet(joint));
  };
  std::vector<int> parent(m, -1);
  std::vector<double> best(m, -std::numeric_limits<double>::infinity());
  std::vector<char> in_tree(m, 0);
  std::vector<int> order;  // tree order: every variable after its parent
  int next = 0;
  if (root >= 0) {
    int closest = -1;
    for (int t = 0; t < m; ++t) {
      if (TypeOf(x0[var[t]]) != TypeOf(x0[root])) continue;
      if (closest < 0 || log_det[t] < log_det[closest]) closest = t;
    }
    if (closest >= 0) next = closest;
  }
  for (int step = 0; step < m; ++step) {
    in_tree[next] = 1;
    order.push_back(next);
    int pick = -1;
    for (int t = 0; t < m; ++t) {
      if (in_tree[t]) continue;
      // Round-off can make a pair's determinant meaningless (NaN): it counts as no information,
      // and every variable gets a parent in the tree.
      const double mi = mutual_information(next, t);
      const double weight = std::isnan(mi) ? -std::numeric_limits<double>::infinity() : mi;
      if (parent[t] < 0 || weight > best[t]) best[t] = weight, parent[t] = next;
      if (pick < 0 || best[t] > best[pick]) pick = t;
    }
    next = pick;
  }

  // A factor |Σ C_t y_t + rhs|² on tree variables, written on δ: y_t = δ_t − N_t δ_root adds
  // −Σ C_t N_t on the root's columns.
  std::vector<FactorPtr> out;
  const auto make = [&](const std::vector<std::pair<int, Eigen::MatrixXd>>& terms,
                        const Eigen::VectorXd& rhs) -> Status {
    KeyVector factor_keys;
    std::vector<Variable> points;
    const int rows = static_cast<int>(rhs.size());
    // The root's columns: none in the root-relative form, else −Σ C_t N_t.
    int width = root >= 0 && !relative ? dim(root) : 0;
    for (const auto& term : terms) width += dim(var[term.first]);
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, width);
    int c = 0;
    for (const auto& [t, C] : terms) {
      factor_keys.push_back(keys[var[t]]);
      points.push_back(x0[var[t]]);
      a.middleCols(c, C.cols()) = C;
      if (root >= 0 && !relative) {
        a.rightCols(dim(root)) -= C * N.middleRows(at[var[t]], C.cols());
      }
      c += static_cast<int>(C.cols());
    }
    if (root >= 0) {
      factor_keys.push_back(keys[root]);
      points.push_back(x0[root]);
    }
    Result<FactorPtr> f = relative
                              ? LinearContainerFactor::CreateRootRelative(
                                    std::move(factor_keys), std::move(points), std::move(a), rhs)
                              : LinearContainerFactor::Create(std::move(factor_keys),
                                                              std::move(points), std::move(a), rhs);
    if (!f.ok()) return f.status();
    out.push_back(std::move(f).value());
    return Status::Ok();
  };
  // The tree's root: its marginal, |W (y_r − μ_r)|² with WᵀW = Σrr⁻¹.
  const int r = order[0];
  const int dr = col[r + 1] - col[r];
  Result<Eigen::MatrixXd> w =
      SqrtInformation(Eigen::MatrixXd(block(r, r)).llt().solve(Eigen::MatrixXd::Identity(dr, dr)));
  if (!w.ok()) return w.status();
  if (!plausible(r, *w)) return FailedPrecondition("ChowLiuTree: the root's marginal is round-off");
  SLAMD_RETURN_IF_ERROR(make({{r, *w}}, -(*w) * mean.segment(col[r], dr)));
  // parents == 2: each variable after the tree's second also conditioned on the earlier one
  // (in tree order) that tells most about it beyond its tree parent, the largest conditional
  // mutual information I(i; q | p) = ½ (log|Σ_{i|p}| + log|Σ_{q|p}| − log|Σ_{iq|p}|): the
  // divergence from the dense summary drops by exactly that (a Bayes net's is Σ_i H(i | its
  // parents) − H(all)), and every tree parent stays.
  std::vector<int> second(m, -1);
  for (std::size_t s = 2; parents >= 2 && s < order.size(); ++s) {
    const int i = order[s], p = parent[i], di = col[i + 1] - col[i];
    const Eigen::LLT<Eigen::MatrixXd> pp(block(p, p));
    double best_gain = kMinSecondParentGain;
    for (std::size_t u = 0; u < s; ++u) {
      const int q = order[u];
      if (q == p) continue;
      const int dq = col[q + 1] - col[q];
      Eigen::MatrixXd joint(di + dq, di + dq), cross(di + dq, col[p + 1] - col[p]);
      joint << block(i, i), block(i, q), block(q, i), block(q, q);
      cross << block(i, p), block(q, p);
      joint -= cross * pp.solve(Eigen::MatrixXd(cross.transpose()));
      const double gain = 0.5 * (LogDet(joint.topLeftCorner(di, di)) +
                                 LogDet(joint.bottomRightCorner(dq, dq)) - LogDet(joint));
      // (Not finite: a conditional round-off left singular, no information to trust.)
      if (std::isfinite(gain) && gain > best_gain) best_gain = gain, second[i] = q;
    }
  }

  // Each edge: p(y_i | y_S) = N(μ_i + K (y_S − μ_S), Σii − K ΣSi), K = ΣiS ΣSS⁻¹ over its
  // parents S (p, and q if it has one), as |W (y_i − K y_S − c)|² with c = μ_i − K μ_S and WᵀW
  // the conditional's information.
  for (std::size_t s = 1; s < order.size(); ++s) {
    const int i = order[s], p = parent[i], q = second[i];
    const int di = col[i + 1] - col[i], dp = col[p + 1] - col[p];
    const int dq = q >= 0 ? col[q + 1] - col[q] : 0;
    Eigen::MatrixXd SS(dp + dq, dp + dq), Si(dp + dq, di);
    Eigen::VectorXd mS(dp + dq);
    SS.topLeftCorner(dp, dp) = block(p, p);
    Si.topRows(dp) = block(p, i);
    mS.head(dp) = mean.segment(col[p], dp);
    if (q >= 0) {
      SS.topRightCorner(dp, dq) = block(p, q);
      SS.bottomLeftCorner(dq, dp) = block(q, p);
      SS.bottomRightCorner(dq, dq) = block(q, q);
      Si.bottomRows(dq) = block(q, i);
      mS.tail(dq) = mean.segment(col[q], dq);
    }
    const Eigen::MatrixXd K = SS.llt().solve(Si).transpose();
    const Eigen::MatrixXd conditional = block(i, i) - K * Si;
    w = SqrtInformation(conditional.llt().solve(Eigen::MatrixXd::Identity(di, di)));
    if (!w.ok()) return w.status();
    const Eigen::MatrixXd WKp = (*w) * K.leftCols(dp), WKq = (*w) * K.rightCols(dq);
    if (!plausible(i, *w) || !plausible(p, WKp) || (q >= 0 && !plausible(q, WKq))) {
      return FailedPrecondition("ChowLiuTree: the conditional of " + KeyToString(keys[var[i]]) +
                                " is round-off");
    }
    const Eigen::VectorXd c = mean.segment(col[i], di) - K * mS;
    std::vector<std::pair<int, Eigen::MatrixXd>> terms{{i, *w}};  // without the tree parent's
    if (q >= 0) terms.emplace_back(q, -WKq);
    if (relative && edge_frame == TreeEdgeFrame::kParent) {
      // On fewer keys where that drops next to nothing against the parent's column in the
      // parent's frame, W (N_i^p − K_q N_q^p) (the parent carrying the others along; W alone if
      // the parent is no pose): the others in the parent's frame, |W (z_i − K_q z_q − c)|² with
      // z ≈ y − N^p y_p (dropping W (N_i^p − K_q N_q^p − K_p) y_p), or in the root's without
      // the parent, |W (y_i − K_q y_q − c)|² (dropping W K_p y_p: the parent says little).
      KeyVector in_keys{keys[var[i]]};
      std::vector<Variable> in_x0{x0[var[i]]};
      Eigen::MatrixXd in_a(di, di + dq);
      in_a << *w, -WKq;
      if (q >= 0) in_keys.push_back(keys[var[q]]), in_x0.push_back(x0[var[q]]);
      in_keys.push_back(keys[var[p]]);
      in_x0.push_back(x0[var[p]]);
      Result<FactorPtr> in_parent = LinearContainerFactor::CreateRootRelative(
          std::move(in_keys), in_x0, std::move(in_a), -(*w) * c);
      Eigen::MatrixXd parent_column;  // at x0, −W (N_i^p − K_q N_q^p)
      if (in_parent.ok()) {
        std::vector<const Variable*> at_x0;
        for (const Variable& v : in_x0) at_x0.push_back(&v);
        std::vector<Eigen::MatrixXd> H(in_x0.size());
        static_cast<const LinearContainerFactor&>(**in_parent).Evaluate(at_x0, &H);
        parent_column = H.back();
      }
      const double scale = in_parent.ok() ? parent_column.norm() : w->norm();
      if (in_parent.ok() && (parent_column + WKp).norm() <= kEdgeTolerance * scale) {
        out.push_back(std::move(in_parent).value());
        continue;
      }
      if (WKp.norm() <= kEdgeTolerance * scale) {
        SLAMD_RETURN_IF_ERROR(make(terms, -(*w) * c));
        continue;
      }
    }
    terms.emplace_back(p, -WKp);
    SLAMD_RETURN_IF_ERROR(make(terms, -(*w) * c));
  }
  return out;
}

}  // namespace slamd::core
