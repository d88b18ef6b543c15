#include "core/marginals/marginals.h"

#include <Eigen/LU>
#include <algorithm>
#include <cstddef>
#include <cmath>
#include <cstring>
#include <string>

#include "core/base/check.h"
#include "core/base/param_check.h"
#include "core/marginals/clique_kernels.h"
#include "core/isam/isam2.h"

namespace slamd::core {
namespace {

using internal::NegProductTransposed;
using internal::Prefetch;

using MatrixMap = Eigen::Map<Eigen::MatrixXd>;

// Grows `buffer` (never shrinks) and views its front as a rows x cols matrix.
MatrixMap View(std::vector<double>* buffer, int rows, int cols) {
  const std::size_t n = static_cast<std::size_t>(rows) * cols;
  if (buffer->size() < n) buffer->resize(n);
  return {buffer->data(), rows, cols};
}

// Below this frontal dimension, plain loops replace Eigen's triangular solve and product: at a
// few poses (the cliques at the root, which every step changes) their blocking and packing cost
// more than the arithmetic.
constexpr int kSmallFrontal = 12;

// X ← R⁻¹X in place, R upper triangular nf x nf (column-major, leading dimension ldr), X nf x m
// contiguous column-major.
void SolveUpperSmall(const double* r, int ldr, int nf, double* x, int m) {
  for (int j = 0; j < m; ++j) {
    double* col = x + static_cast<std::size_t>(j) * nf;
    for (int i = nf - 1; i >= 0; --i) {
      const double xi = col[i] / r[i + static_cast<std::size_t>(i) * ldr];
      col[i] = xi;
      const double* r_col = r + static_cast<std::size_t>(i) * ldr;
      for (int k = 0; k < i; ++k) col[k] -= r_col[k] * xi;
    }
  }
}

// dst ← U' U'ᵀ for U' the first `rows` rows of U, upper triangular nf x nf (contiguous); dst
// (rows x rows) has leading dimension ld. Entry (i, j) sums over k >= max(i, j) only; both
// triangles are written.
void UpperGramSmall(const double* u, int nf, int rows, double* dst, int ld) {
  for (int j = 0; j < rows; ++j) {
    for (int i = j; i < rows; ++i) {
      double sum = 0.0;
      for (int k = i; k < nf; ++k) {
        sum += u[i + static_cast<std::size_t>(k) * nf] * u[j + static_cast<std::size_t>(k) * nf];
      }
      dst[i + static_cast<std::size_t>(j) * ld] = sum;
      dst[j + static_cast<std::size_t>(i) * ld] = sum;
    }
  }
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

Status MarginalsParams::Validate() const {
  SLAMD_PARAM_CHECK(MarginalsParams, threads, >=, 1);
  return Status::Ok();
}

// ------------------------------------------------------------------------------------------------
// BayesTreeMarginals

BayesTreeMarginals::BayesTreeMarginals(const BayesTree* tree, const MarginalsParams& params)
    : tree_(tree), params_(params), pool_(std::max(params.threads, 1) - 1) {
  const Status valid = params.Validate();
  SLAMD_CHECK(valid.ok()) << valid.ToString();
}

void BayesTreeMarginals::Resize() {
  ++pass_;
  js_.positions_of = BayesTree::kNone;  // the tree may have changed since the last call
  if (static_cast<int>(entries_.size()) < tree_->NumSlots()) entries_.resize(tree_->NumSlots());
  if (static_cast<int>(depth_.size()) < tree_->NumSlots()) depth_.resize(tree_->NumSlots(), -1);
  if (static_cast<int>(js_.pos.size()) < tree_->NumVariables()) {
    js_.pos.resize(tree_->NumVariables(), 0);
    row_.resize(tree_->NumVariables(), 0);
    frontal_block_.resize(tree_->NumVariables());
  }
}

Eigen::Map<const Eigen::MatrixXd> BayesTreeMarginals::CliqueJoint(int clique) const {
  const Entry& e = entries_[clique];
  const int n = e.full ? e.n : e.nf;
  return {e.data, n, n};
}

void BayesTreeMarginals::Invalidate(std::span<const int> cliques) {
  for (int c : cliques) {
    if (c >= 0 && c < static_cast<int>(entries_.size())) entries_[c].valid = false;
  }
}

void BayesTreeMarginals::InvalidateAll() {
  for (Entry& e : entries_) e.valid = false;
}

bool BayesTreeMarginals::IsValid(int c, int parent, bool need_full) {
  ++stats_.cliques_checked;
  Entry& e = entries_[c];
  if (!e.valid || e.clique_generation != tree_->clique(c).generation() || (need_full && !e.full)) return false;
  if (parent == BayesTree::kNone) return e.parent == BayesTree::kNone;  // a root's joint is R⁻¹R⁻ᵀ
  const Entry& pe = entries_[parent];
  if (e.parent == parent && e.parent_generation == pe.generation) {
    // Also when the parent was recomputed this pass but reproduced the same joint (Invalidate()).
    if (pe.computed_in == pass_) ++stats_.cliques_reused;
    return true;
  }
  // The parent's joint was recomputed. This joint is still right if the Σ_SS it was computed
  // from (its own bottom-right block) equals the parent's new one: iSAM2 re-creates the top
  // cliques every step, but an odometry step leaves the marginals below them unchanged up to
  // round-off (and the re-attached orphan may have a new parent id). Keeping `generation` then
  // spares the whole subtree. A Σ_FF-only entry cannot tell (it does not keep Σ_SS).
  if (!e.full || !pe.full) return false;
  EnsurePositions(js_, parent);
  const Clique& cl = tree_->clique(c);
  const int ns = cl.SeparatorDim();
  const Eigen::Map<const Eigen::MatrixXd> P(pe.data, pe.n, pe.n);
  const Eigen::Map<const Eigen::MatrixXd> J(e.data, e.n, e.n);
  const double allowed = params_.reuse_tolerance * J.bottomRightCorner(ns, ns).cwiseAbs().maxCoeff();
  SeparatorRuns(js_, cl);
  for (const Run& b : js_.runs) {
    for (const Run& a : js_.runs) {
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

void BayesTreeMarginals::SeparatorRuns(JointScratch& js, const Clique& cl) const {
  // A separator is listed in elimination order and so is the parent's layout [F; S]: consecutive
  // separator variables are mostly adjacent in the parent too. Merging them into runs turns the
  // block-by-block copy of Σ_SS into a few large copies.
  std::vector<Run>& runs = js.runs;
  runs.clear();
  const std::span<const int> sep = cl.separator();
  const int nf = cl.FrontalDim();
  for (int k = 0; k < cl.num_separator(); ++k) {
    const int own = nf + cl.separator_offset(k), in_parent = js.pos[sep[k]], d = cl.separator_dim(k);
    if (!runs.empty() && runs.back().own + runs.back().size == own &&
        runs.back().parent + runs.back().size == in_parent) {
      runs.back().size += d;
    } else {
      runs.push_back({own, in_parent, d});
    }
  }
}

void BayesTreeMarginals::EnsurePositions(JointScratch& js, int c) const {
  if (js.positions_of != c) SetPositions(js, c);
}

void BayesTreeMarginals::SetPositions(JointScratch& js, int c) const {
  const Clique& cl = tree_->clique(c);
  for (int k = 0; k < cl.num_frontals(); ++k) js.pos[cl.frontal(k)] = cl.frontal_offset(k);
  const int nf = cl.FrontalDim();
  for (int k = 0; k < cl.num_separator(); ++k) js.pos[cl.separator()[k]] = nf + cl.separator_offset(k);
  js.positions_of = c;
}

void BayesTreeMarginals::ComputeJoint(JointScratch& js, const Clique& cl, const double* parent_joint, int parent_n,
                                      bool with_fs, double* out) const {
  const int nf = cl.FrontalDim(), ns = cl.SeparatorDim(), n = nf + ns;
  MatrixMap J(out, n, n);
  const auto R = cl.R();
  const bool small = nf <= kSmallFrontal;
  MatrixMap Rinv = View(&js.rinv, nf, nf);
  Rinv.setIdentity();
  if (small) {
    SolveUpperSmall(R.data(), static_cast<int>(R.outerStride()), nf, Rinv.data(), nf);
  } else {
    R.triangularView<Eigen::Upper>().solveInPlace(Rinv);
  }
  // R⁻¹R⁻ᵀ: R⁻¹ is upper triangular; Eigen's triangular product is faster from ~24 rows up.
  const auto inverse_gram = [&](auto&& dst) {
    if (small) {
      UpperGramSmall(Rinv.data(), nf, nf, dst.data(), static_cast<int>(dst.outerStride()));
    } else if (nf >= 24) {
      dst.noalias() = Rinv.triangularView<Eigen::Upper>() * Rinv.transpose();
    } else {
      dst.noalias() = Rinv * Rinv.transpose();
    }
  };
  if (ns == 0) {
    inverse_gram(J);
    return;
  }
  // Σ_SS from the parent's joint: copied into this joint (children read it there, and a cached
  // joint is compared with its parent's through it), or, when only Σ_FF is wanted and the
  // separator is one contiguous block of the parent's joint, read in place.
  const Eigen::Map<const Eigen::MatrixXd> P(parent_joint, parent_n, parent_n);
  SeparatorRuns(js, cl);
  const std::vector<Run>& runs = js.runs;
  const double* ss_data = out + nf + static_cast<std::size_t>(nf) * n;
  int ss_stride = n;
  if (!with_fs && runs.size() == 1) {
    ss_data = parent_joint + runs[0].parent + static_cast<std::size_t>(runs[0].parent) * parent_n;
    ss_stride = parent_n;
  } else {
    for (const Run& b : runs) {
      for (const Run& a : runs) J.block(a.own, b.own, a.size, b.size) = P.block(a.parent, b.parent, a.size, b.size);
    }
  }
  // K = R⁻¹S; Σ_SF = −Σ_SS Kᵀ; Σ_FF = R⁻¹R⁻ᵀ − K Σ_SF (= R⁻¹R⁻ᵀ + K Σ_SS Kᵀ).
  // Σ_SF (ns x nf) rather than Σ_FS: the long dimension as rows suits the kernel's packets.
  MatrixMap K = View(&js.k, nf, ns);
  K = cl.S();
  if (small) {
    SolveUpperSmall(R.data(), static_cast<int>(R.outerStride()), nf, K.data(), ns);
  } else {
    R.triangularView<Eigen::Upper>().solveInPlace(K);
  }
  NegProductTransposed(ss_data, ss_stride, ns, K.data(), nf, out + nf, n);
  auto SF = J.bottomLeftCorner(ns, nf);
  auto FF = J.topLeftCorner(nf, nf);
  inverse_gram(FF);
  if (small) {
    // Σ_FF −= K Σ_SF: the lower triangle, mirrored (symmetric), in plain loops.
    const double* k = K.data();
    const double* sf = SF.data();
    const std::size_t ld = static_cast<std::size_t>(n);
    for (int j = 0; j < nf; ++j) {
      for (int i = j; i < nf; ++i) {
        double sum = 0.0;
        for (int q = 0; q < ns; ++q) sum += k[i + static_cast<std::size_t>(q) * nf] * sf[q + j * ld];
        FF(i, j) -= sum;
        if (i != j) FF(j, i) = FF(i, j);
      }
    }
  } else {
    // Large frontal blocks (3D, several poses): only the lower triangle of the symmetric
    // update (half the flops), then mirrored.
    FF.triangularView<Eigen::Lower>() -= K * SF;
    FF.triangularView<Eigen::StrictlyUpper>() = FF.transpose();
  }
  if (with_fs) J.topRightCorner(nf, ns) = SF.transpose();
}

void BayesTreeMarginals::Record(int c, int parent, std::uint64_t new_generation) {
  Entry& e = entries_[c];
  const Clique& cl = tree_->clique(c);
  const std::uint64_t parent_generation = parent == BayesTree::kNone ? 0 : entries_[parent].generation;
  // Same conditional and same parent joint as the result it replaces (only Invalidate()d, or
  // upgraded from Σ_FF to the full joint): the computation is deterministic, so the joint is
  // the same and the subtree below may keep theirs.
  const bool same = e.has_result && e.clique_generation == cl.generation() && e.parent == parent &&
                    e.parent_generation == parent_generation;
  if (!same) e.generation = new_generation;
  e.valid = e.has_result = true;
  e.clique_generation = cl.generation();
  e.parent = parent;
  e.parent_generation = parent_generation;
  e.computed_in = pass_;
  // Where each frontal's block is, tagged with the result it belongs to (generations are unique
  // to one entry and kept only when the clique's content, so its structure, is the same).
  for (int k = 0; k < cl.num_frontals(); ++k) {
    frontal_block_[cl.frontal(k)] = {e.generation, cl.frontal_offset(k), cl.frontal_dim(k)};
  }
}

void BayesTreeMarginals::Compute(int c, int parent) {
  const Clique& cl = tree_->clique(c);
  const int nf = cl.FrontalDim(), ns = cl.SeparatorDim(), n = nf + ns;
  const double* parent_joint = nullptr;
  int parent_n = 0;
  if (ns > 0) {
    SLAMD_CHECK(parent != BayesTree::kNone)
        << "clique " << c << " has a separator but no parent (tree between RemoveTop and re-attach?)";
    if (!entries_[parent].full) EnsureFull(parent);
    EnsurePositions(js_, parent);
    parent_joint = entries_[parent].data;
    parent_n = entries_[parent].n;
  }
  Entry& e = entries_[c];
  const std::size_t size = static_cast<std::size_t>(n) * n;
  // Grow as needed; shrink when far too large (a recycled clique slot may have been the root).
  if (e.capacity < size || (e.capacity > 4 * size && e.capacity > 1024)) {
    e.own.reset(new double[size]);
    e.capacity = size;
  }
  ComputeJoint(js_, cl, parent_joint, parent_n, true, e.own.get());
  e.data = e.own.get();
  e.n = n;
  e.nf = nf;
  e.full = true;
  ++stats_.cliques_computed;
  Record(c, parent, next_generation_++);
}

void BayesTreeMarginals::EnsureFull(int c) {
  // Only reached for valid entries (their clique's stamp is current); the recomputed joints
  // reproduce the results they replace, so Record() keeps their generations.
  std::vector<int>& up = stack_;
  const std::size_t base = up.size();
  for (int x = c; x != BayesTree::kNone && !entries_[x].full; x = tree_->clique(x).parent()) up.push_back(x);
  while (up.size() > base) {
    const int x = up.back();
    up.pop_back();
    Compute(x, tree_->clique(x).parent());
  }
}

// ComputeAllFresh and its helpers: marginals_fresh.cc.

void BayesTreeMarginals::ComputeAll() {
  Resize();
  stats_ = {};
  bool any_valid = false;
  for (int c = 0; c < tree_->NumSlots() && !any_valid; ++c) any_valid = entries_[c].valid && tree_->IsLive(c);
  if (!any_valid) {
    ComputeAllFresh();
    return;
  }
  stack_.clear();
  for (int r : tree_->roots()) {
    if (!IsValid(r, BayesTree::kNone, false)) Compute(r, BayesTree::kNone);
    stack_.push_back(r);
  }
  while (!stack_.empty()) {
    const int c = stack_.back();
    stack_.pop_back();
    for (int child : tree_->clique(c).children()) {
      if (!IsValid(child, c, false)) Compute(child, c);
      stack_.push_back(child);
    }
  }
}

void BayesTreeMarginals::EnsurePath(int c) {
  path_.clear();
  for (int x = c; x != BayesTree::kNone; x = tree_->clique(x).parent()) path_.push_back(x);
  int parent = BayesTree::kNone;
  for (int i = static_cast<int>(path_.size()) - 1; i >= 0; --i) {
    const int x = path_[i];
    if (!IsValid(x, parent, true)) Compute(x, parent);
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
  const Clique& cl = tree_->clique(c);
  const int k = FrontalIndex(cl, var);
  const int o = cl.frontal_offset(k), d = cl.frontal_dim(k);
  if (cl.parent() == BayesTree::kNone && cl.FrontalDim() - o <= kSmallFrontal &&
      !IsValid(c, BayesTree::kNone, false)) {
    RootTrailingMarginal(cl, o, d, cov);
    return Status::Ok();
  }
  EnsurePath(c);
  *cov = CliqueJoint(c).block(o, o, d, d);
  return Status::Ok();
}

void BayesTreeMarginals::RootTrailingMarginal(const Clique& cl, int o, int d,
                                              Eigen::MatrixXd* cov) {
  // Σ = R⁻¹R⁻ᵀ in a root. R⁻¹ is upper triangular, so its rows from o on are the inverse of R's
  // trailing block T = R[o:, o:], and the variable's block is T⁻¹[0:d, :] T⁻¹[0:d, :]ᵀ.
  const int m = cl.FrontalDim() - o;
  const auto R = cl.R();
  MatrixMap Tinv = View(&js_.rinv, m, m);
  Tinv.setIdentity();
  const int ldr = static_cast<int>(R.outerStride());
  SolveUpperSmall(R.data() + o + static_cast<std::size_t>(o) * ldr, ldr, m, Tinv.data(), m);
  cov->resize(d, d);
  UpperGramSmall(Tinv.data(), m, d, cov->data(), d);
  ++stats_.cliques_computed;
}

Status BayesTreeMarginals::CachedMarginal(int var, Eigen::MatrixXd* cov) const {
  const int c = tree_->CliqueOf(var);
  if (c == BayesTree::kNone || c >= static_cast<int>(entries_.size()) || !entries_[c].valid) {
    return NotFound("no cached marginal for variable " + std::to_string(var));
  }
  // The variable's block as recorded when its clique's entry was computed (reading every
  // variable then touches no clique structure); else found among the clique's frontals.
  const Entry& e = entries_[c];
  const FrontalBlock& b = frontal_block_[var];
  int o, d;
  if (b.generation == e.generation) {
    o = b.offset;
    d = b.dim;
  } else {
    const Clique& cl = tree_->clique(c);
    const int k = FrontalIndex(cl, var);
    o = cl.frontal_offset(k);
    d = cl.frontal_dim(k);
  }
  const int ld = e.full ? e.n : e.nf;
  *cov = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>(e.data + o + static_cast<std::size_t>(o) * ld, d, d,
                                                                     Eigen::OuterStride<>(ld));
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
    EnsurePositions(js_, c);
    const auto J = CliqueJoint(c);
    int oi = 0;
    for (int vi : vars) {
      const int di = tree_->clique(tree_->CliqueOf(vi)).frontal_dim(
          FrontalIndex(tree_->clique(tree_->CliqueOf(vi)), vi));
      int oj = 0;
      for (int vj : vars) {
        const int dj = tree_->clique(tree_->CliqueOf(vj)).frontal_dim(
            FrontalIndex(tree_->clique(tree_->CliqueOf(vj)), vj));
        cov->block(oi, oj, di, dj) = J.block(js_.pos[vi], js_.pos[vj], di, dj);
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

Isam2Marginals::Isam2Marginals(const Isam2* isam, const MarginalsParams& params)
    : isam_(isam), marginals_(&isam->tree(), params) {}

namespace {

// Σ ← J Σ Jᵀ: the covariance of `slot` moved from θ's tangent space to the estimate's.
void ToEstimateFrame(const Isam2& isam, int slot, Eigen::MatrixXd* cov) {
  const TangentMatrix J =
      EstimateTangentJacobian(isam.linearization_point().TypeAt(slot), isam.Delta(slot));
  // Σ ← J Σ Jᵀ in plain loops: at most 6 x 6, where a general product's set-up outweighs the
  // arithmetic (this runs after every step for the newest pose).
  const int d = static_cast<int>(J.rows());
  double js[6 * 6];
  double* c = cov->data();
  for (int j = 0; j < d; ++j) {
    for (int i = 0; i < d; ++i) {
      double sum = 0.0;
      for (int k = 0; k < d; ++k) sum += J(i, k) * c[k + j * d];
      js[i + j * d] = sum;
    }
  }
  for (int j = 0; j < d; ++j) {
    for (int i = 0; i < d; ++i) {
      double sum = 0.0;
      for (int k = 0; k < d; ++k) sum += js[i + k * d] * J(j, k);
      c[i + j * d] = sum;
    }
  }
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
      const TangentMatrix J = EstimateTangentJacobian(theta.TypeAt(vars_[i]), isam_->Delta(vars_[i]));
      const int d = static_cast<int>(J.rows());
      cov->middleRows(o, d) = (J * cov->middleRows(o, d)).eval();
      cov->middleCols(o, d) = (cov->middleCols(o, d) * J.transpose()).eval();
      o += d;
    }
  }
  return Status::Ok();
}

}  // namespace slamd::core
