// Marginal covariances from a Bayes tree (Kaess & Dellaert, "Covariance recovery from a square
// root information matrix for data association", RAS 2009, in its Bayes-tree form).
//
// Each clique holds p(F | S) as R δ_F + S δ_S = d (see clique.h), i.e. δ_F = R⁻¹(d − S δ_S) + R⁻¹w
// with w ~ N(0, I) independent of δ_S. Hence, top-down,
//     root:   Σ_FF = R⁻¹R⁻ᵀ
//     child:  Σ_FS = −R⁻¹S Σ_SS,   Σ_FF = R⁻¹R⁻ᵀ + R⁻¹S Σ_SS SᵀR⁻ᵀ,
// where Σ_SS is read from the parent's joint (a child's separator lies in its parent's frontals
// and separator). BayesTreeMarginals keeps, per clique, the joint marginal over [F; S] (frontals
// in R's row order, then the separator in S's column order; or only Σ_FF, see FRESH PASS) and
// reuses it until the clique's conditional or the Σ_SS it was computed from changes (see CHANGE
// DETECTION).
//
// CONVENTION. Covariances are of the tree's unknown δ, i.e. in the tangent space at the
// LINEARISATION POINT θ with slamd's right-perturbation charts (variable.h): Pose2 θ·Pose2(δ)
// (GTSAM's chart, δ = (x, y, θ)), Pose3 θ·Exp(ξ) with ξ = (v, ω) translation first, points θ + δ.
// EstimateTangentJacobian converts to the tangent space at the current estimate E = θ ⊕ δ̂:
// Σ_E = J Σ_θ Jᵀ with J = ∂ Local(E, θ ⊕ (δ̂ + ε)) / ∂ε at ε = 0 (Pose2: blockdiag(R(δ̂_θ)ᵀ, 1);
// Pose3: the SE(3) right Jacobian Jr(δ̂); points: I). Isam2Marginals offers both frames.
//
// CHANGE DETECTION. Each cached joint records the generation stamp of the clique it was computed
// from (Clique::generation(): unique across the process, renewed by every Reset() /
// ResetForElimination(), which every writer of a clique's content calls first; see clique.h),
// its parent's id, and the generation number of the parent's joint it was computed from. A
// cached joint is reused iff the clique's stamp matches (an O(1) check that reads no matrix) and
// either the parent and its generation match, or the Σ_SS the joint was computed from equals (to
// MarginalsParams::reuse_tolerance) the parent's current one. This second rule matters: iSAM2
// re-creates the top cliques every update, so "recompute below every changed conditional" alone
// would recompute the whole tree each step, while after an odometry step the marginals below the
// top are unchanged. A re-eliminated clique is recomputed even when it reproduced its conditional
// bit for bit (the stamp cannot tell; the former hash of [R S] could, but checking every clique
// that way cost more per step than such recomputations save, see COSTS).
// A changed conditional or a changed Σ_SS forces recomputation; nothing else does. Invalidate()
// forces it explicitly; a joint recomputed from the same conditional and the same parent joint
// is the same (the computation is deterministic), so it keeps its generation and its subtree
// stays valid. BayesTree::RestoreRemoved() and a tree copied back keep their stamps, and so the
// cached joints computed from them.
//
// FRESH PASS. ComputeAll() on a cache with no valid entry (a new object, or after
// InvalidateAll()) keeps only Σ_FF per clique: it walks the tree depth first with the full joints
// of the current root-to-clique path on a scratch stack (a child reads its Σ_SS there, or in
// place when it is one block of the parent's joint and the child has no children), and copies
// each Σ_FF into one contiguous arena. Memory touched: Σ nF² + max over paths of Σ n² instead of
// Σ n² (n = nF + nS; input_M3500 0.4 + 1.9 MB instead of 9.5 MB, parking-garage 1.0 + 2.5 MB
// instead of 20 MB); on first use every page costs a fault (~0.3-0.5 µs per 4 KB here), which
// was most of the old first pass. A Σ_FF-only entry serves CachedMarginal() and Marginal() of its
// frontals and stays valid while its parent's generation is unchanged; it cannot be checked
// against a changed parent (no Σ_SS kept), so it is recomputed then. Anything that needs a full
// joint (Marginal()/JointMarginal() paths, a recomputed child) recomputes it from its parent's,
// with the same generation. Consequence: the ComputeAll() after the first update that follows a
// fresh pass recomputes the whole tree once (as a first pass did before); later ones are
// incremental as described above.
//
// COSTS (nF, nS: a clique's frontal and separator dimensions).
//   * computing one clique's joint: K = R⁻¹S (nF²nS), Σ_SF = −Σ_SS Kᵀ (2nF nS², the bulk; a
//     register-blocked kernel on Eigen's packets, 1.3-2x Eigen's GEMM at nF <= 6),
//     Σ_FF = R⁻¹R⁻ᵀ − K Σ_SF (nF³ + 2nF²nS, halved for nF >= 12 by updating one triangle).
//     Totals: input_M3500 ~15 Mflop, parking-garage ~45 Mflop, victoriaPark ~7 Mflop.
//   * ComputeAll(): checks every clique (stamp, O(1)) and recomputes the changed ones.
//   * Marginal(var), or JointMarginal of variables that all lie in one clique's frontals and
//     separator: validates and recomputes only the path from the variable's clique to the root
//     (the newest pose of an incremental SLAM problem sits in a clique at or next to the root: O(1)).
//   * JointMarginal of variables spread over several cliques: k = Σ dims columns of Σ = (RᵀR)⁻¹,
//     solved with the conditionals restricted to U, the union of the paths from their cliques to
//     the root: a forward solve Rᵀy = e_j (y is zero off the path of e_j's clique) and a back
//     substitution R x = y down U; O(k · Σ_{c∈U} nF(nF+nS)) flops. Does not use or touch the cache.
// No heap allocation per call once warm (scratch and cache storage are reused), except to resize
// *cov and in Isam2Marginals' frame conversion of a joint.
// Measured with `slamctl bench FILE --solver isam2 --marginals all --marginals-every 100000
// --json`, column marginals_final_all_ms (a fresh Isam2Marginals: ComputeAll, then CachedMarginal
// of every key in the estimate's tangent), 2-core VM with load average 2-3 from other jobs.
// Earlier, the full-joint-per-clique layout -> the FRESH PASS layout: input_M3500 10.9 -> 4.7 ms,
// manhattan 10.1 -> 5.2, intel 2.7 -> 1.2, parking-garage 13.2 -> 6.2, victoriaPark 11.7 -> 7.2.
// Replacing the per-clique hash of [R S] by the stamp left it within noise (parking-garage 6.63 ->
// 6.50 ms, median of 15 interleaved runs): the fresh pass reads every [R S] anyway, and the cache
// misses the hash took are now taken by the computation. Of parking-garage's, ~4 ms is arithmetic
// (45 Mflop, SSE2 build), the rest cold tree data, page faults and 0.7 ms of per-key Pose3 frame
// conversion. ComputeAll after each step (--marginals all, column marginal_ms p50), hash -> stamp:
// input_M3500 0.30 -> 0.05 ms, manhattan 0.29 -> 0.05, intel 0.097 -> 0.016 (checking was most of
// it), parking-garage 1.7 -> 1.7, victoriaPark ~1.5 -> 1.2 (recomputation dominates); newest pose
// (--marginals latest) 0.75 µs median on input_M3500.
//
// Thread safety: not thread-safe (queries update the cache). The tree must not change during a
// call; it may change between calls (that is what the cache checks are for).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/base/key.h"
#include "core/base/status.h"
#include "core/factors/variable.h"
#include "core/inference/bayes_tree.h"

namespace slamd::core {

class Isam2;

// A square matrix of at most kMaxVariableDim rows, stored inline (no heap).
using TangentMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                                    kMaxVariableDim, kMaxVariableDim>;

// J such that Σ_E = J Σ_θ Jᵀ re-expresses a covariance of a variable's tangent at θ in the
// tangent at the estimate E = θ ⊕ δ (see the file comment), for a variable of `type` and its
// update δ (TangentDim(type) entries). It depends on δ only.
TangentMatrix EstimateTangentJacobian(VariableType type, const double* delta);

struct MarginalsParams {
  // A clique whose conditional is unchanged keeps its cached joint after its parent's joint
  // was recomputed if its Σ_SS moved by at most this, relative to max |Σ_SS| (0: only if
  // bit-identical). iSAM2 re-creates the top cliques every step; after an odometry step the
  // marginals below are mathematically unchanged but the re-eliminated top reproduces them only
  // to ~1e-12..1e-10 relative (input_M3500: 0 → ~3000 of 3117 cliques recomputed per step,
  // 1e-12 → ~400, 1e-11 → ~2, with a worst drift of cached vs fresh marginals of 8e-12 after
  // 3500 steps). A reused joint is stale by about this much (relative).
  double reuse_tolerance = 1e-11;
};

class BayesTreeMarginals {
 public:
  // Counts of the last call, for tests and benchmarks.
  struct Stats {
    int cliques_checked = 0;   // cached joints validated (stamp compared)
    int cliques_computed = 0;  // joints (re)computed
    int cliques_reused = 0;    // kept although the parent's joint was recomputed (see MarginalsParams)
  };

  // The tree must outlive this object.
  explicit BayesTreeMarginals(const BayesTree* tree, const MarginalsParams& params = {})
      : tree_(tree), params_(params) {}

  // Brings every clique's joint marginal up to date in one top-down pass: the block diagonal of
  // Σ for all variables is then available through CachedMarginal() (O(1) each) or Marginal()
  // (path check; after a fresh pass, see FRESH PASS, it first recomputes its path's full joints).
  void ComputeAll();

  // Marginal covariance (dim x dim) of variable `var` (a tree variable id, i.e. Isam2's slot).
  // NotFound if the variable is not in the tree.
  Status Marginal(int var, Eigen::MatrixXd* cov);

  // The same from the cache alone, with no check that the tree is unchanged: for reading all
  // variables right after ComputeAll() (O(1) each). NotFound if nothing is cached for `var`.
  Status CachedMarginal(int var, Eigen::MatrixXd* cov) const;

  // Joint marginal of `vars` (distinct ids): a (Σ dims) square matrix, blocks in the order given,
  // cross-covariances included. NotFound for an unknown variable, InvalidArgument for a repeat.
  Status JointMarginal(std::span<const int> vars, Eigen::MatrixXd* cov);

  // Forces the joints of these cliques (and so of their subtrees) to be recomputed.
  void Invalidate(std::span<const int> cliques);
  void InvalidateAll();

  // The cached joint over [frontals; separator] of a clique; valid after a query whose path
  // covered it (or ComputeAll() on a cache that held valid joints), until the tree changes.
  // After ComputeAll() on an empty cache only Σ_FF is kept (FrontalDim() square; see COSTS).
  Eigen::Map<const Eigen::MatrixXd> CliqueJoint(int clique) const;

  const Stats& stats() const { return stats_; }

 private:
  struct Entry {
    bool valid = false;       // result usable (has_result and not Invalidate()d)
    bool has_result = false;  // data holds the result computed from (clique_generation, parent,
                              // parent_generation)
    bool full = false;        // data is the n x n joint; else only Σ_FF (nf x nf, in diag_arena_)
    std::uint64_t clique_generation = 0;  // Clique::generation() of the conditional used
    int parent = BayesTree::kNone;
    std::uint64_t parent_generation = 0;
    std::uint64_t generation = 0;  // changes whenever the joint changes
    std::uint64_t computed_in = 0;  // pass_ of the last recomputation
    int n = 0;   // FrontalDim() + SeparatorDim()
    int nf = 0;  // FrontalDim()
    double* data = nullptr;  // column-major, leading dimension n (full) or nf
    // Own storage of a full joint. Uninitialised (not std::vector): the first pass over a large
    // tree writes megabytes, and zero-filling them first cost a visible share of its time.
    std::unique_ptr<double[]> own;
    std::size_t capacity = 0;
  };

  // Grows the per-clique and per-variable arrays to the tree's current sizes; starts a pass.
  void Resize();
  // True if clique c's cached result may be used under `parent` (whose own entry is valid).
  // need_full: only a full joint will do.
  bool IsValid(int c, int parent, bool need_full);
  // Recomputes clique c's full joint into its own storage (upgrading the parent first if it
  // holds only Σ_FF).
  void Compute(int c, int parent);
  // Bookkeeping common to both kinds of recomputation (generations, stats).
  void Record(int c, int parent);

  // The n x n joint of clique `cl` into `out` (leading dimension n); `parent_joint` is the
  // parent's full joint (parent_n square) with its layout in pos_ (ignored for a root).
  // Without with_fs only Σ_FF and Σ_SF are sure to be written (Σ_SS may be read in place).
  void ComputeJoint(const Clique& cl, const double* parent_joint, int parent_n, bool with_fs, double* out);
  // ComputeAll on a cache with no valid entry: depth-first, full joints only on a scratch stack
  // (the current path), Σ_FF of each clique kept in one contiguous arena (see COSTS).
  void ComputeAllFresh();
  // Recomputes the full joints of c and of those of its ancestors that hold only Σ_FF.
  void EnsureFull(int c);
  // pos_[v] = row of v in clique c's joint, for its frontals and separator.
  void SetPositions(int c);
  void EnsurePositions(int c);
  // runs_ = the separator of `cl` as maximal runs contiguous both in its joint and in the
  // parent's (whose layout must be in pos_).
  void SeparatorRuns(const Clique& cl);
  // Makes the joints on the path from clique c to its root valid and full.
  void EnsurePath(int c);
  // JointMarginal when the variables do not share a clique (see COSTS).
  void JointBySolving(std::span<const int> vars, Eigen::MatrixXd* cov);

  struct Run {
    int own, parent, size;  // rows in this clique's joint, in the parent's joint, count
  };
  struct Frame {
    int clique;
    int n;            // its joint is n x n ...
    std::size_t off;  // ... at scratch_[off]
    std::size_t next_child;
  };

  const BayesTree* tree_;
  MarginalsParams params_;
  std::vector<Entry> entries_;  // by clique id
  std::vector<int> pos_;        // by variable id, scratch
  struct FrontalBlock {
    std::uint64_t generation = 0;  // of the entry it was recorded with
    int offset = 0, dim = 0;       // of the variable's block in that entry's Σ_FF
  };
  std::vector<FrontalBlock> frontal_block_;  // by variable id
  int positions_of_ = BayesTree::kNone;  // the clique whose layout pos_ holds (this call)
  std::uint64_t next_generation_ = 1;
  std::uint64_t pass_ = 0;
  Stats stats_;

  // Σ_FF blocks of the cliques computed by ComputeAllFresh (not full), contiguous.
  std::unique_ptr<double[]> diag_arena_;
  std::size_t diag_capacity_ = 0;
  // ComputeAllFresh's stack of full joints (the current root-to-clique path).
  std::unique_ptr<double[]> scratch_;
  std::size_t scratch_capacity_ = 0;
  std::vector<Frame> frames_;

  // Scratch, reused across calls.
  std::vector<Run> runs_;
  std::vector<int> stack_, path_, depth_, cliques_, row_;
  std::vector<double> k_, rinv_, y_, xs_;
};

// Marginals of an Isam2 solver by key, in either tangent frame. The solver must outlive this.
class Isam2Marginals {
 public:
  enum class Frame {
    kLinearizationPoint,  // tangent at θ (what the Bayes tree gives; GTSAM ISAM2's convention)
    kEstimate,            // tangent at the current estimate θ ⊕ δ (what slamd publishes)
  };

  explicit Isam2Marginals(const Isam2* isam);

  void ComputeAll() { marginals_.ComputeAll(); }
  // NotFound for an unknown key.
  Status Marginal(Key key, Frame frame, Eigen::MatrixXd* cov);
  Status JointMarginal(std::span<const Key> keys, Frame frame, Eigen::MatrixXd* cov);
  // Reads the cache without checking it: valid right after ComputeAll() and before the solver
  // changes (reading every variable this way costs O(n), not O(n · depth)). NotFound for an
  // unknown key.
  Status CachedMarginal(Key key, Frame frame, Eigen::MatrixXd* cov) const;

  BayesTreeMarginals& tree_marginals() { return marginals_; }

 private:
  const Isam2* isam_;
  BayesTreeMarginals marginals_;
  std::vector<int> vars_;
};

}  // namespace slamd::core
