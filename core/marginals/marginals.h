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
// THREADS. A fresh pass whose estimated work reaches kParallelMinWork (about 1 ms) uses
// MarginalsParams::threads (marginals_fresh.cc): a subtree needs only the full joint of its
// root's parent, so the tree is split as Eliminator splits it (the heaviest subtree's root moves
// to the "top" while that lowers the estimated time), the top is computed first on the calling
// thread (keeping, in a separate buffer, the full joints of the top cliques that have a child
// below the top), then each thread walks its share of the subtrees depth first with its own path
// stack and scratch, writing only its cliques' entries and Σ_FF blocks (no locks; the helper
// threads are kept: core/base/worker_pool.h). Every clique is computed by the same code from the same inputs as on one thread, so the
// results are the same bit for bit for any thread count. Extra memory: that buffer (27-580 KB on
// the benchmark datasets) and one path stack per thread (each at most the one-thread stack).
// Everything else (a warm cache, Marginal(), JointMarginal(), small trees) runs on the calling
// thread.
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
// of every key in the estimate's tangent), 2-core VM with load average 2-3 from other jobs
// (figures before THREADS: one thread).
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
// THREADS, `--threads T` (sets the marginals' threads too), marginals_final_all_ms, medians of
// interleaved runs (parking-garage 9, others 3), load average 1.5-1.8 from other jobs; T = 1 -> 2
// (the code before THREADS, same T: 1 / 2): parking-garage 6.44 -> 4.15 ms (5.99 / 5.56),
// input_M3500 5.44 -> 4.16 (4.18 / 5.22), manhattan 5.41 -> 4.05 (5.83 / 4.47), victoriaPark
// 6.19 -> 5.54 (6.37 / 6.00), intel 1.31 -> 1.29 (below kParallelMinWork; 1.25 / 1.23). The
// old code depends on T through the tree's memory layout (iSAM2 eliminates on T threads). The
// fresh ComputeAll() alone (in-process loop, idle machine, medians of 9): parking-garage 4.75 ->
// 2.63 ms (top 7 cliques, 0.3 ms), input_M3500 2.62 -> 2.42 (top 38 cliques, 0.3-0.6 ms),
// manhattan 3.05 -> 1.84, victoriaPark 3.52 -> 2.21; bitwise equal on all five.
//
// Thread safety: not thread-safe (queries update the cache). The tree must not change during a
// call; it may change between calls (that is what the cache checks are for). A large fresh pass
// starts threads of its own (THREADS) and joins them before it returns.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "core/base/key.h"
#include "core/base/status.h"
#include "core/base/worker_pool.h"
#include "core/inference/bayes_tree.h"
#include "core/inference/subtree_split.h"
#include "core/variables/variable.h"

namespace slamd::core {

class Isam2;

struct MarginalsParams {
  // A clique whose conditional is unchanged keeps its cached joint after its parent's joint
  // was recomputed if its Σ_SS moved by at most this, relative to max |Σ_SS| (0: only if
  // bit-identical). iSAM2 re-creates the top cliques every step; after an odometry step the
  // marginals below are mathematically unchanged but the re-eliminated top reproduces them only
  // to ~1e-12..1e-10 relative (input_M3500: 0 → ~3000 of 3117 cliques recomputed per step,
  // 1e-12 → ~400, 1e-11 → ~2, with a worst drift of cached vs fresh marginals of 8e-12 after
  // 3500 steps). A reused joint is stale by about this much (relative).
  double reuse_tolerance = 1e-11;
  // Threads of a large fresh pass (see FRESH PASS; >= 1). The results do not depend on it (bit
  // for bit); other calls always run on the calling thread.
  int threads = 2;

  Status Validate() const;
};

class BayesTreeMarginals {
 public:
  // Counts of the last call, for tests and benchmarks.
  struct Stats {
    int cliques_checked = 0;   // cached joints validated (stamp compared)
    int cliques_computed = 0;  // joints (re)computed
    int cliques_reused = 0;    // kept although the parent's joint was recomputed (see MarginalsParams)
    int threads_used = 1;      // > 1 only for a fresh pass large enough to use MarginalsParams::threads
    int top_cliques = 0;       // of such a pass: cliques computed first, on the calling thread
  };

  // The tree must outlive this object. `params` must be valid (checked: call Validate() first on
  // anything that came from a user).
  explicit BayesTreeMarginals(const BayesTree* tree, const MarginalsParams& params = {});

  // Estimated work of a fresh pass (flops of ComputeJoint, see COSTS, plus a fixed cost per
  // clique) from which it uses MarginalsParams::threads: about 1 ms on one core here (≈ 0.07 ns
  // per unit). Lower did not pay in `slamctl bench` on this VM: intel (1.3e7, 0.85 ms) was
  // 0.3 ms faster with 2 threads in a warm in-process loop, but 0.25 ms slower (median of 7) in
  // the bench, whose times were bimodal (1.3 or 1.6-1.7 ms; presumably the idle second core's
  // wake-up: the helper started ~50 µs after the call in the loop).
  static constexpr double kParallelMinWork = 1.5e7;

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

  struct Run {
    int own, parent, size;  // rows in this clique's joint, in the parent's joint, count
  };
  // One thread's scratch for computing joints.
  struct JointScratch {
    std::vector<int> pos;  // by variable id: row of the variable in the joint of `positions_of`
    int positions_of = BayesTree::kNone;
    std::vector<Run> runs;
    std::vector<double> k, rinv;
  };
  struct Frame {
    int clique;
    int n;            // its joint is n x n ...
    std::size_t off;  // ... at data[off]
    std::size_t next_child;
  };
  // A depth-first walk's stack of full joints (the current path; see FRESH PASS).
  struct WalkStack {
    std::unique_ptr<double[]> data;
    std::size_t capacity = 0;
    std::vector<Frame> frames;
  };
  // A helper thread's share of a parallel fresh pass.
  struct Helper {
    JointScratch scratch;
    WalkStack stack;
  };

  // Grows the per-clique and per-variable arrays to the tree's current sizes; starts a pass.
  void Resize();
  // True if clique c's cached result may be used under `parent` (whose own entry is valid).
  // need_full: only a full joint will do.
  bool IsValid(int c, int parent, bool need_full);
  // Recomputes clique c's full joint into its own storage (upgrading the parent first if it
  // holds only Σ_FF).
  void Compute(int c, int parent);
  // Bookkeeping of a recomputation: generations (`new_generation` unless the result is the one
  // it replaces), frontal blocks. Touches only clique c's entry and its frontals' blocks.
  void Record(int c, int parent, std::uint64_t new_generation);

  // The n x n joint of clique `cl` into `out` (leading dimension n); `parent_joint` is the
  // parent's full joint (parent_n square) with its layout in js.pos (ignored for a root).
  // Without with_fs only Σ_FF and Σ_SF are sure to be written (Σ_SS may be read in place).
  // Reads only the tree and its arguments: threads with their own `js` may run it at once.
  void ComputeJoint(JointScratch& js, const Clique& cl, const double* parent_joint, int parent_n,
                    bool with_fs, double* out) const;
  // ComputeAll on a cache with no valid entry (see FRESH PASS), on several threads when large.
  void ComputeAllFresh();
  // The fresh pass's plan: order_ (depth first, children in order), arena_off_, work_,
  // serial_need_, max_*; returns the total work.
  double PlanFresh();
  // Scratch a WalkFresh from `root` needs (top_only: the walk of the top).
  std::size_t WalkNeed(int root, bool top_only);
  // Depth first from `root`, whose parent's full joint is `parent_joint` (parent_n square; null
  // for a tree's root): each clique's Σ_FF into the arena. top_only: only the cliques in the top
  // (in_top_), saving in boundary_ the joints of those with a child outside it. Touches only js,
  // *st and the entries and frontal blocks of the cliques walked (so threads may walk disjoint
  // subtrees at once).
  void WalkFresh(JointScratch& js, WalkStack* st, int root, const double* parent_joint, int parent_n,
                 bool top_only);
  // Splits the tree into the top and subtrees for the threads (in_top_, subtrees_; see the .cc);
  // returns the number of threads given subtrees.
  int AssignSubtrees();
  // Recomputes the full joints of c and of those of its ancestors that hold only Σ_FF.
  void EnsureFull(int c);
  // js.pos[v] = row of v in clique c's joint, for its frontals and separator.
  void SetPositions(JointScratch& js, int c) const;
  void EnsurePositions(JointScratch& js, int c) const;
  // js.runs = the separator of `cl` as maximal runs contiguous both in its joint and in the
  // parent's (whose layout must be in js.pos).
  void SeparatorRuns(JointScratch& js, const Clique& cl) const;
  // Makes the joints on the path from clique c to its root valid and full.
  void EnsurePath(int c);
  // Marginal() of the frontal block at offset o (dimension d) of a root clique from its R alone,
  // without computing or caching the root's joint: after an update the newest pose, eliminated
  // last, is the root's trailing block, so its marginal costs one d x d inversion.
  void RootTrailingMarginal(const Clique& cl, int o, int d, Eigen::MatrixXd* cov);
  // JointMarginal when the variables do not share a clique (see COSTS).
  void JointBySolving(std::span<const int> vars, Eigen::MatrixXd* cov);

  const BayesTree* tree_;
  MarginalsParams params_;
  std::vector<Entry> entries_;  // by clique id
  struct FrontalBlock {
    std::uint64_t generation = 0;  // of the entry it was recorded with
    int offset = 0, dim = 0;       // of the variable's block in that entry's Σ_FF
  };
  std::vector<FrontalBlock> frontal_block_;  // by variable id
  std::uint64_t next_generation_ = 1;
  std::uint64_t pass_ = 0;
  Stats stats_;

  // Σ_FF blocks of the cliques computed by ComputeAllFresh (not full), contiguous.
  std::unique_ptr<double[]> diag_arena_;
  std::size_t diag_capacity_ = 0;
  // The fresh pass: the calling thread's walk, the plan (by clique id unless said otherwise),
  // the top's joints that subtrees start from, and the helper threads' scratch.
  WalkStack walk_;
  std::vector<int> order_;                // live cliques, depth first
  std::vector<std::size_t> arena_off_;    // Σ_FF's offset in diag_arena_
  std::vector<double> work_, subtree_work_;
  std::vector<char> in_top_;              // computed first, on the calling thread
  std::vector<std::size_t> boundary_off_;  // a top clique's joint in boundary_
  std::unique_ptr<double[]> boundary_;
  std::size_t boundary_capacity_ = 0;
  std::vector<std::vector<int>> subtrees_;  // by thread (0: the calling one)
  SubtreeSplit split_;  // AssignSubtrees' scratch
  std::vector<Helper> helpers_;             // threads 1 .. threads - 1
  WorkerPool pool_;                         // runs them (threads - 1 helpers)
  std::uint64_t fresh_generation_ = 0;      // clique c's new generation is this + c
  struct SizeFrame {
    int clique, depth;
    std::size_t off, stay;  // where its joint is computed, where it stays for its subtree
  };
  std::vector<SizeFrame> size_frames_;
  std::size_t serial_need_ = 0;  // scratch of a one-thread walk of the whole forest
  int max_nf_ = 0, max_ns_ = 0, max_depth_ = 0;  // over the forest

  // Scratch of the calling thread, reused across calls.
  JointScratch js_;
  std::vector<int> stack_, path_, depth_, cliques_, row_;
  std::vector<double> y_, xs_;
};

// Marginals of an Isam2 solver by key, in either tangent frame. The solver must outlive this.
class Isam2Marginals {
 public:
  enum class Frame {
    kLinearizationPoint,  // tangent at θ (what the Bayes tree gives; GTSAM ISAM2's convention)
    kEstimate,            // tangent at the current estimate θ ⊕ δ (what slamd publishes)
  };

  explicit Isam2Marginals(const Isam2* isam, const MarginalsParams& params = {});

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
