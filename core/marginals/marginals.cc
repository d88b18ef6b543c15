#include "core/marginals/marginals.h"

#include <Eigen/LU>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>

#include "core/base/check.h"
#include "core/isam/isam2.h"

namespace slamd::core {
namespace {

using MatrixMap = Eigen::Map<Eigen::MatrixXd>;

// Grows `buffer` (never shrinks) and views its front as a rows x cols matrix.
MatrixMap View(std::vector<double>* buffer, int rows, int cols) {
  const std::size_t n = static_cast<std::size_t>(rows) * cols;
  if (buffer->size() < n) buffer->resize(n);
  return {buffer->data(), rows, cols};
}

// Eight independent multiply-rotate lanes (so the loop is not one long dependency chain), then a
// splitmix finaliser. Detects any change of structure or of a bit of [R S]; not cryptographic.
class Hasher {
 public:
  void Add(std::uint64_t x) { Step(&lanes_[0], x); }
  void AddDoubles(const double* p, std::size_t n) {
    std::size_t i = 0;
    for (; i + kLanes <= n; i += kLanes) {
      for (int l = 0; l < kLanes; ++l) Step(&lanes_[l], std::bit_cast<std::uint64_t>(p[i + l]));
    }
    for (; i < n; ++i) Step(&lanes_[i % kLanes], std::bit_cast<std::uint64_t>(p[i]));
  }
  std::uint64_t Finish() const {
    std::uint64_t h = 0;
    for (std::uint64_t l : lanes_) h = SplitMix(h ^ l);
    return h;
  }

 private:
  static void Step(std::uint64_t* lane, std::uint64_t x) {
    *lane = std::rotl((*lane ^ x) * 0x9E3779B97F4A7C15ull, 31);
  }
  static std::uint64_t SplitMix(std::uint64_t z) {
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  static constexpr int kLanes = 8;
  std::uint64_t lanes_[kLanes] = {1, 2, 3, 4, 5, 6, 7, 8};
};

std::uint64_t HashClique(const Clique& c) {
  Hasher h;
  const int nf = c.num_frontals(), ns = c.num_separator();
  h.Add((static_cast<std::uint64_t>(nf) << 32) | static_cast<std::uint32_t>(ns));
  for (int k = 0; k < nf; ++k) {
    h.Add((static_cast<std::uint64_t>(c.frontal(k)) << 32) | static_cast<std::uint32_t>(c.frontal_dim(k)));
  }
  for (int k = 0; k < ns; ++k) {
    h.Add((static_cast<std::uint64_t>(c.separator()[k]) << 32) |
          static_cast<std::uint32_t>(c.separator_dim(k)));
  }
  // R and S are the first FrontalDim() x (FrontalDim() + SeparatorDim()) entries of [R S d];
  // d does not enter the covariance.
  const auto rs = c.conditional();
  h.AddDoubles(rs.data(), static_cast<std::size_t>(c.FrontalDim()) * (c.FrontalDim() + c.SeparatorDim()));
  return h.Finish();
}

// Index of `var` among the clique's frontals (it must be one).
int FrontalIndex(const Clique& c, int var) {
  for (int k = 0; k < c.num_frontals(); ++k) {
    if (c.frontal(k) == var) return k;
  }
  SLAMD_CHECK(false) << "variable " << var << " is not frontal in its clique";
  return -1;
}

}  // namespace

TangentMatrix EstimateTangentJacobian(const Variable& theta, const Variable& estimate) {
  SLAMD_CHECK(theta.index() == estimate.index()) << "EstimateTangentJacobian: different types";
  switch (TypeOf(theta)) {
    case VariableType::kPose2: {
      // θ·P(δ+ε) seen from E = θ·P(δ): P(δ)⁻¹P(δ+ε) = (Rot(ε_θ), R(δ_θ)ᵀ ε_xy), exactly linear.
      const Vector3 d = std::get<Pose2>(theta).LocalCoordinates(std::get<Pose2>(estimate));
      const double c = std::cos(d[2]), s = std::sin(d[2]);
      TangentMatrix J = TangentMatrix::Identity(3, 3);
      J(0, 0) = c;
      J(0, 1) = s;
      J(1, 0) = -s;
      J(1, 1) = c;
      return J;
    }
    case VariableType::kPose3: {
      // Log(Exp(δ)⁻¹ Exp(δ+ε)) = Jr(δ) ε + O(ε²).
      const Vector6 d = std::get<Pose3>(theta).LocalCoordinates(std::get<Pose3>(estimate));
      Matrix6 H;
      (void)Pose3::Exp(d, &H);
      return H;
    }
    case VariableType::kPoint2: return TangentMatrix::Identity(2, 2);
    case VariableType::kPoint3: return TangentMatrix::Identity(3, 3);
  }
  return {};
}

// ------------------------------------------------------------------------------------------------
// BayesTreeMarginals

void BayesTreeMarginals::Resize() {
  positions_of_ = BayesTree::kNone;  // the tree may have changed since the last call
  if (static_cast<int>(entries_.size()) < tree_->NumSlots()) entries_.resize(tree_->NumSlots());
  if (static_cast<int>(depth_.size()) < tree_->NumSlots()) depth_.resize(tree_->NumSlots(), -1);
  if (static_cast<int>(pos_.size()) < tree_->NumVariables()) {
    pos_.resize(tree_->NumVariables(), 0);
    row_.resize(tree_->NumVariables(), 0);
  }
}

Eigen::Map<const Eigen::MatrixXd> BayesTreeMarginals::CliqueJoint(int clique) const {
  const Entry& e = entries_[clique];
  return {e.joint.get(), e.n, e.n};
}

void BayesTreeMarginals::Invalidate(std::span<const int> cliques) {
  for (int c : cliques) {
    if (c >= 0 && c < static_cast<int>(entries_.size())) entries_[c].valid = false;
  }
}

void BayesTreeMarginals::InvalidateAll() {
  for (Entry& e : entries_) e.valid = false;
}

bool BayesTreeMarginals::IsValid(int c, int parent, std::uint64_t* hash) {
  ++stats_.cliques_checked;
  *hash = HashClique(tree_->clique(c));
  Entry& e = entries_[c];
  if (!e.valid || e.hash != *hash) return false;
  if (parent == BayesTree::kNone) return e.parent == BayesTree::kNone;  // a root's joint is R⁻¹R⁻ᵀ
  if (e.parent == parent && e.parent_generation == entries_[parent].generation) return true;
  // The parent's joint was recomputed. This joint is still right if the Σ_SS it was computed
  // from (its own bottom-right block) equals the parent's new one: iSAM2 re-creates the top
  // cliques every step, but an odometry step leaves the marginals below them unchanged up to
  // round-off (and the re-attached orphan may have a new parent id). Keeping `generation` then
  // spares the whole subtree.
  EnsurePositions(parent);
  const Clique& cl = tree_->clique(c);
  const int ns = cl.SeparatorDim();
  const Entry& pe = entries_[parent];
  const Eigen::Map<const Eigen::MatrixXd> P(pe.joint.get(), pe.n, pe.n);
  const Eigen::Map<const Eigen::MatrixXd> J(e.joint.get(), e.n, e.n);
  const double allowed = params_.reuse_tolerance * J.bottomRightCorner(ns, ns).cwiseAbs().maxCoeff();
  SeparatorRuns(cl);
  for (const Run& b : runs_) {
    for (const Run& a : runs_) {
      const double diff = (P.block(a.parent, b.parent, a.size, b.size) - J.block(a.own, b.own, a.size, b.size))
                              .cwiseAbs()
                              .maxCoeff();
      if (!(diff <= allowed)) return false;
    }
  }
  ++stats_.cliques_reused;
  e.parent = parent;
  e.parent_generation = pe.generation;
  return true;
}

void BayesTreeMarginals::SeparatorRuns(const Clique& cl) {
  // A separator is listed in elimination order and so is the parent's layout [F; S]: consecutive
  // separator variables are mostly adjacent in the parent too. Merging them into runs turns the
  // block-by-block copy of Σ_SS into a few large copies.
  runs_.clear();
  const std::span<const int> sep = cl.separator();
  const int nf = cl.FrontalDim();
  for (int k = 0; k < cl.num_separator(); ++k) {
    const int own = nf + cl.separator_offset(k), in_parent = pos_[sep[k]], d = cl.separator_dim(k);
    if (!runs_.empty() && runs_.back().own + runs_.back().size == own &&
        runs_.back().parent + runs_.back().size == in_parent) {
      runs_.back().size += d;
    } else {
      runs_.push_back({own, in_parent, d});
    }
  }
}

void BayesTreeMarginals::EnsurePositions(int c) {
  if (positions_of_ != c) SetPositions(c);
}

void BayesTreeMarginals::SetPositions(int c) {
  const Clique& cl = tree_->clique(c);
  for (int k = 0; k < cl.num_frontals(); ++k) pos_[cl.frontal(k)] = cl.frontal_offset(k);
  const int nf = cl.FrontalDim();
  for (int k = 0; k < cl.num_separator(); ++k) pos_[cl.separator()[k]] = nf + cl.separator_offset(k);
  positions_of_ = c;
}

void BayesTreeMarginals::Compute(int c, int parent, std::uint64_t hash) {
  ++stats_.cliques_computed;
  const Clique& cl = tree_->clique(c);
  const int nf = cl.FrontalDim(), ns = cl.SeparatorDim(), n = nf + ns;
  Entry& e = entries_[c];
  e.n = n;
  const std::size_t size = static_cast<std::size_t>(n) * n;
  // Grow as needed; shrink when far too large (a recycled clique slot may have been the root).
  if (e.capacity < size || (e.capacity > 4 * size && e.capacity > 1024)) {
    e.joint.reset(new double[size]);
    e.capacity = size;
  }
  MatrixMap J(e.joint.get(), n, n);
  const auto R = cl.R();
  MatrixMap Rinv = View(&rinv_, nf, nf);
  Rinv.setIdentity();
  R.triangularView<Eigen::Upper>().solveInPlace(Rinv);
  if (ns == 0) {
    J.noalias() = Rinv * Rinv.transpose();
  } else {
    SLAMD_CHECK(parent != BayesTree::kNone)
        << "clique " << c << " has a separator but no parent (tree between RemoveTop and re-attach?)";
    // Σ_SS from the parent's joint.
    EnsurePositions(parent);
    const Entry& pe = entries_[parent];
    const Eigen::Map<const Eigen::MatrixXd> P(pe.joint.get(), pe.n, pe.n);
    SeparatorRuns(cl);
    for (const Run& b : runs_) {
      for (const Run& a : runs_) J.block(a.own, b.own, a.size, b.size) = P.block(a.parent, b.parent, a.size, b.size);
    }
    // K = R⁻¹S; Σ_FS = −K Σ_SS; Σ_FF = R⁻¹R⁻ᵀ − Σ_FS Kᵀ (= R⁻¹R⁻ᵀ + K Σ_SS Kᵀ).
    MatrixMap K = View(&k_, nf, ns);
    K = cl.S();
    R.triangularView<Eigen::Upper>().solveInPlace(K);
    J.topRightCorner(nf, ns).noalias() = -K * J.bottomRightCorner(ns, ns);
    J.bottomLeftCorner(ns, nf) = J.topRightCorner(nf, ns).transpose();
    J.topLeftCorner(nf, nf).noalias() = Rinv * Rinv.transpose();
    J.topLeftCorner(nf, nf).noalias() -= J.topRightCorner(nf, ns) * K.transpose();
  }
  e.valid = true;
  e.hash = hash;
  e.parent = parent;
  e.parent_generation = parent == BayesTree::kNone ? 0 : entries_[parent].generation;
  e.generation = next_generation_++;
}

void BayesTreeMarginals::ComputeAll() {
  Resize();
  stats_ = {};
  stack_.clear();
  std::uint64_t hash;
  for (int r : tree_->roots()) {
    if (!IsValid(r, BayesTree::kNone, &hash)) Compute(r, BayesTree::kNone, hash);
    stack_.push_back(r);
  }
  while (!stack_.empty()) {
    const int c = stack_.back();
    stack_.pop_back();
    for (int child : tree_->clique(c).children()) {
      if (!IsValid(child, c, &hash)) Compute(child, c, hash);
      stack_.push_back(child);
    }
  }
}

void BayesTreeMarginals::EnsurePath(int c) {
  path_.clear();
  for (int x = c; x != BayesTree::kNone; x = tree_->clique(x).parent()) path_.push_back(x);
  int parent = BayesTree::kNone;
  std::uint64_t hash;
  for (int i = static_cast<int>(path_.size()) - 1; i >= 0; --i) {
    const int x = path_[i];
    if (!IsValid(x, parent, &hash)) Compute(x, parent, hash);
    parent = x;
  }
}

Status BayesTreeMarginals::Marginal(int var, Eigen::MatrixXd* cov) {
  Resize();
  stats_ = {};
  const int c = tree_->CliqueOf(var);
  if (c == BayesTree::kNone) {
    return NotFound("variable " + std::to_string(var) + " is not in the Bayes tree");
  }
  EnsurePath(c);
  const Clique& cl = tree_->clique(c);
  const int k = FrontalIndex(cl, var);
  const int o = cl.frontal_offset(k), d = cl.frontal_dim(k);
  *cov = CliqueJoint(c).block(o, o, d, d);
  return Status::Ok();
}

Status BayesTreeMarginals::CachedMarginal(int var, Eigen::MatrixXd* cov) const {
  const int c = tree_->CliqueOf(var);
  if (c == BayesTree::kNone || c >= static_cast<int>(entries_.size()) || !entries_[c].valid) {
    return NotFound("no cached marginal for variable " + std::to_string(var));
  }
  const Clique& cl = tree_->clique(c);
  const int k = FrontalIndex(cl, var);
  const int o = cl.frontal_offset(k), d = cl.frontal_dim(k);
  *cov = CliqueJoint(c).block(o, o, d, d);
  return Status::Ok();
}

Status BayesTreeMarginals::JointMarginal(std::span<const int> vars, Eigen::MatrixXd* cov) {
  Resize();
  stats_ = {};
  int total = 0;
  for (std::size_t i = 0; i < vars.size(); ++i) {
    const int c = tree_->CliqueOf(vars[i]);
    if (c == BayesTree::kNone) {
      return NotFound("variable " + std::to_string(vars[i]) + " is not in the Bayes tree");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (vars[j] == vars[i]) {
        return InvalidArgument("variable " + std::to_string(vars[i]) + " requested twice");
      }
    }
    const Clique& cl = tree_->clique(c);
    total += cl.frontal_dim(FrontalIndex(cl, vars[i]));
  }
  cov->resize(total, total);
  if (vars.empty()) return Status::Ok();

  // Fast path: all variables in one clique's frontals and separator (then that clique is the
  // deepest of their cliques; try each candidate).
  for (int v : vars) {
    const int c = tree_->CliqueOf(v);
    const Clique& cl = tree_->clique(c);
    bool all = true;
    for (int u : vars) {
      if (tree_->CliqueOf(u) == c) continue;
      const std::span<const int> sep = cl.separator();
      if (std::find(sep.begin(), sep.end(), u) == sep.end()) {
        all = false;
        break;
      }
    }
    if (!all) continue;
    EnsurePath(c);
    EnsurePositions(c);
    const auto J = CliqueJoint(c);
    int oi = 0;
    for (int vi : vars) {
      const int di = tree_->clique(tree_->CliqueOf(vi)).frontal_dim(
          FrontalIndex(tree_->clique(tree_->CliqueOf(vi)), vi));
      int oj = 0;
      for (int vj : vars) {
        const int dj = tree_->clique(tree_->CliqueOf(vj)).frontal_dim(
            FrontalIndex(tree_->clique(tree_->CliqueOf(vj)), vj));
        cov->block(oi, oj, di, dj) = J.block(pos_[vi], pos_[vj], di, dj);
        oj += dj;
      }
      oi += di;
    }
    return Status::Ok();
  }
  JointBySolving(vars, cov);
  return Status::Ok();
}

void BayesTreeMarginals::JointBySolving(std::span<const int> vars, Eigen::MatrixXd* cov) {
  // 1. U = the union of the paths from the variables' cliques to the root, with depths; sorted
  //    deepest first (children before parents).
  cliques_.clear();
  for (int v : vars) {
    path_.clear();
    int x = tree_->CliqueOf(v);
    while (x != BayesTree::kNone && depth_[x] < 0) {
      path_.push_back(x);
      x = tree_->clique(x).parent();
    }
    int d = x == BayesTree::kNone ? -1 : depth_[x];
    for (int i = static_cast<int>(path_.size()) - 1; i >= 0; --i) {
      depth_[path_[i]] = ++d;
      cliques_.push_back(path_[i]);
    }
  }
  std::sort(cliques_.begin(), cliques_.end(), [&](int a, int b) { return depth_[a] > depth_[b]; });

  // 2. Rows of the frontals of U (a clique's frontals are contiguous, in R's order).
  int m = 0;
  for (int c : cliques_) {
    const Clique& cl = tree_->clique(c);
    for (int k = 0; k < cl.num_frontals(); ++k) row_[cl.frontal(k)] = m + cl.frontal_offset(k);
    m += cl.FrontalDim();
  }
  const int k_cols = static_cast<int>(cov->cols());
  MatrixMap Y = View(&y_, m, k_cols);
  Y.setZero();
  int col = 0;
  for (int v : vars) {
    const Clique& cl = tree_->clique(tree_->CliqueOf(v));
    const int d = cl.frontal_dim(FrontalIndex(cl, v));
    for (int t = 0; t < d; ++t) Y(row_[v] + t, col + t) = 1.0;
    col += d;
  }

  // 3. Forward: Rᵀ Y = E, bottom-up. Each clique solves its frontal rows, then pushes Sᵀ y_F into
  //    the rows of its separator (frontals of ancestors, all in U and solved later).
  for (int c : cliques_) {
    const Clique& cl = tree_->clique(c);
    const int nf = cl.FrontalDim();
    auto Yf = Y.middleRows(row_[cl.frontal(0)], nf);
    cl.R().transpose().triangularView<Eigen::Lower>().solveInPlace(Yf);
    const auto S = cl.S();
    for (int k = 0; k < cl.num_separator(); ++k) {
      const int s = cl.separator()[k];
      Y.middleRows(row_[s], cl.separator_dim(k)).noalias() -=
          S.middleCols(cl.separator_offset(k), cl.separator_dim(k)).transpose() * Yf;
    }
  }
  // 4. Back: R X = Y, top-down over U (X overwrites Y).
  for (auto it = cliques_.rbegin(); it != cliques_.rend(); ++it) {
    const Clique& cl = tree_->clique(*it);
    const int nf = cl.FrontalDim(), ns = cl.SeparatorDim();
    auto Yf = Y.middleRows(row_[cl.frontal(0)], nf);
    if (ns > 0) {
      MatrixMap Xs = View(&xs_, ns, k_cols);
      for (int k = 0; k < cl.num_separator(); ++k) {
        Xs.middleRows(cl.separator_offset(k), cl.separator_dim(k)) =
            Y.middleRows(row_[cl.separator()[k]], cl.separator_dim(k));
      }
      Yf.noalias() -= cl.S() * Xs;
    }
    cl.R().triangularView<Eigen::Upper>().solveInPlace(Yf);
  }

  // 5. Gather the requested rows; symmetrise the round-off.
  int oi = 0;
  for (int v : vars) {
    const Clique& cl = tree_->clique(tree_->CliqueOf(v));
    const int d = cl.frontal_dim(FrontalIndex(cl, v));
    cov->middleRows(oi, d) = Y.middleRows(row_[v], d);
    oi += d;
  }
  *cov = 0.5 * (*cov + cov->transpose()).eval();
  for (int c : cliques_) depth_[c] = -1;
}

// ------------------------------------------------------------------------------------------------
// Isam2Marginals

Isam2Marginals::Isam2Marginals(const Isam2* isam) : isam_(isam), marginals_(&isam->tree()) {}

namespace {

// Σ ← J Σ Jᵀ: the covariance of `slot` moved from θ's tangent space to the estimate's.
void ToEstimateFrame(const Isam2& isam, int slot, Eigen::MatrixXd* cov) {
  const Values& theta = isam.linearization_point();
  const TangentMatrix J =
      EstimateTangentJacobian(theta.VariableAt(slot), isam.CalculateEstimate(theta.KeyAt(slot)));
  const TangentMatrix JS = J * (*cov);
  cov->noalias() = JS * J.transpose();
}

}  // namespace

Status Isam2Marginals::Marginal(Key key, Frame frame, Eigen::MatrixXd* cov) {
  const int slot = isam_->linearization_point().SlotOf(key);
  if (slot < 0) return NotFound("no variable " + KeyToString(key));
  SLAMD_RETURN_IF_ERROR(marginals_.Marginal(slot, cov));
  if (frame == Frame::kEstimate) ToEstimateFrame(*isam_, slot, cov);
  return Status::Ok();
}

Status Isam2Marginals::CachedMarginal(Key key, Frame frame, Eigen::MatrixXd* cov) const {
  const int slot = isam_->linearization_point().SlotOf(key);
  if (slot < 0) return NotFound("no variable " + KeyToString(key));
  SLAMD_RETURN_IF_ERROR(marginals_.CachedMarginal(slot, cov));
  if (frame == Frame::kEstimate) ToEstimateFrame(*isam_, slot, cov);
  return Status::Ok();
}

Status Isam2Marginals::JointMarginal(std::span<const Key> keys, Frame frame, Eigen::MatrixXd* cov) {
  const Values& theta = isam_->linearization_point();
  vars_.clear();
  for (Key key : keys) {
    const int slot = theta.SlotOf(key);
    if (slot < 0) return NotFound("no variable " + KeyToString(key));
    vars_.push_back(slot);
  }
  SLAMD_RETURN_IF_ERROR(marginals_.JointMarginal(vars_, cov));
  if (frame == Frame::kEstimate) {
    // Σ_E = blockdiag(J_i) Σ_θ blockdiag(J_i)ᵀ, applied block row by block row, then by columns.
    int o = 0;
    for (std::size_t i = 0; i < keys.size(); ++i) {
      const TangentMatrix J = EstimateTangentJacobian(theta.VariableAt(vars_[i]), isam_->CalculateEstimate(keys[i]));
      const int d = static_cast<int>(J.rows());
      cov->middleRows(o, d) = (J * cov->middleRows(o, d)).eval();
      cov->middleCols(o, d) = (cov->middleCols(o, d) * J.transpose()).eval();
      o += d;
    }
  }
  return Status::Ok();
}

}  // namespace slamd::core
