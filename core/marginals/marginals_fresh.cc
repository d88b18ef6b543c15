// BayesTreeMarginals' fresh pass (marginals.h, FRESH PASS): ComputeAll() on a cache with no valid
// entry, depth first with only the current path's full joints, on several threads when large.
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <limits>

#include "core/base/check.h"
#include "core/inference/subtree_split.h"
#include "core/marginals/clique_kernels.h"
#include "core/marginals/marginals.h"

namespace slamd::core {
namespace {

using internal::Prefetch;

constexpr std::size_t kNoBoundary = std::numeric_limits<std::size_t>::max();

// A clique's fixed cost in the work estimate's unit (flops): its cold [R S] and entry, the first
// touch of its Σ_FF's pages, bookkeeping. Fitted to the fresh pass's time on one core over the
// five benchmark datasets: ≈ 0.07 ns per flop + 0.47 µs per clique (2D datasets with ~3000
// small cliques spend most of their time there; with 200 here the threads got unequal shares).
constexpr double kCliqueWork = 6000.0;

// Grows a walk's stack (never shrinks; uninitialised: it is written before it is read).
template <typename Stack>
void Reserve(Stack* st, std::size_t size) {
  if (st->capacity < size) {
    st->data.reset(new double[size]);
    st->capacity = size;
  }
}

}  // namespace

double BayesTreeMarginals::PlanFresh() {
  // 1. Depth first, children in order: the order WalkFresh computes them in, so that the Σ_FF
  //    blocks are written sequentially and each subtree's are contiguous. Work per clique as
  //    counted in COSTS (K, Σ_SF, Σ_FF; plus copying Σ_SS and a fixed cost per clique).
  const int slots = tree_->NumSlots();
  if (static_cast<int>(arena_off_.size()) < slots) {
    arena_off_.resize(slots);
    work_.resize(slots);
    subtree_work_.resize(slots);
    in_top_.resize(slots);
    boundary_off_.resize(slots);
  }
  //    Also the scratch a one-thread walk of the forest needs (as WalkNeed).
  order_.clear();
  std::size_t used = 0;
  double total = 0.0;
  serial_need_ = 0;
  max_nf_ = max_ns_ = max_depth_ = 0;
  size_frames_.clear();
  for (auto r = tree_->roots().rbegin(); r != tree_->roots().rend(); ++r) size_frames_.push_back({*r, 1, 0, 0});
  while (!size_frames_.empty()) {
    const SizeFrame frame = size_frames_.back();
    size_frames_.pop_back();
    const int c = frame.clique;
    order_.push_back(c);
    const Clique& cl = tree_->clique(c);
    const int nf = cl.FrontalDim(), ns = cl.SeparatorDim();
    const std::size_t n = nf + ns;
    arena_off_[c] = used;
    used += static_cast<std::size_t>(nf) * nf;
    const double f = nf, s = ns;
    work_[c] = f * f * f + 3.0 * f * f * s + 2.0 * f * s * s + s * s + kCliqueWork;
    total += work_[c];
    serial_need_ = std::max(serial_need_, frame.off + n * n);
    max_nf_ = std::max(max_nf_, nf);
    max_ns_ = std::max(max_ns_, ns);
    max_depth_ = std::max(max_depth_, frame.depth);
    const std::vector<int>& children = cl.children();
    const std::size_t base = frame.stay + n * n;
    for (std::size_t k = children.size(); k-- > 0;) {
      size_frames_.push_back({children[k], frame.depth + 1, base, k + 1 == children.size() ? frame.stay : base});
    }
  }
  if (diag_capacity_ < used) {
    diag_arena_.reset(new double[used]);
    diag_capacity_ = used;
  }
  return total;
}

std::size_t BayesTreeMarginals::WalkNeed(int root, bool top_only) {
  // WalkFresh's layout, replayed: a clique's joint is computed right after its parent's (`off`)
  // and stays there while its subtree is walked (`stay`), except that the last walked child takes
  // its parent's place.
  std::size_t deepest = 0;
  size_frames_.clear();
  size_frames_.push_back({root, 1, 0, 0});
  while (!size_frames_.empty()) {
    const SizeFrame f = size_frames_.back();
    size_frames_.pop_back();
    const Clique& cl = tree_->clique(f.clique);
    const std::size_t n = cl.FrontalDim() + cl.SeparatorDim();
    deepest = std::max(deepest, f.off + n * n);
    const std::vector<int>& children = cl.children();
    int last = static_cast<int>(children.size()) - 1;
    while (top_only && last >= 0 && !in_top_[children[last]]) --last;
    const std::size_t base = f.stay + n * n;
    for (int k = 0; k <= last; ++k) {
      if (top_only && !in_top_[children[k]]) continue;
      size_frames_.push_back({children[k], f.depth + 1, base, k == last ? f.stay : base});
    }
  }
  return deepest;
}

void BayesTreeMarginals::WalkFresh(JointScratch& js, WalkStack* st, int root, const double* parent_joint,
                                   int parent_n, bool top_only) {
  // A clique's full joint lives on the stack while its subtree is computed (children read their
  // Σ_SS from it); only Σ_FF is kept. The stack is at most the sum of n² along one path instead
  // of the whole tree's, so a fresh cache page-faults in a few MB instead of tens.
  const auto walked = [&](int c) { return !top_only || in_top_[c]; };
  const auto compute = [&](int c, int parent, const double* pj, int pn, std::size_t off) -> Frame {
    const Clique& cl = tree_->clique(c);
    SLAMD_CHECK(pj != nullptr || cl.SeparatorDim() == 0)
        << "clique " << c << " has a separator but no parent (tree between RemoveTop and re-attach?)";
    // The conditionals are scattered over the heap and cold: ask for the next ones early (the
    // first child is computed next; the next sibling is asked for by the loop below).
    if (!cl.children().empty()) Prefetch(tree_->clique(cl.children()[0]));
    const int nf = cl.FrontalDim(), n = nf + cl.SeparatorDim();
    SLAMD_CHECK(off + static_cast<std::size_t>(n) * n <= st->capacity) << "scratch sized wrongly";
    if (pj != nullptr) EnsurePositions(js, parent);
    double* joint = st->data.get() + off;
    // Σ_FS is needed by the children only (with_fs: the same choice for any thread count).
    ComputeJoint(js, cl, pj, pn, !cl.children().empty(), joint);
    Entry& e = entries_[c];
    e.data = diag_arena_.get() + arena_off_[c];
    e.n = n;
    e.nf = nf;
    e.full = n == nf;  // a root's joint is its Σ_FF
    Eigen::Map<Eigen::MatrixXd>(e.data, nf, nf) = Eigen::Map<const Eigen::MatrixXd>(joint, n, n).topLeftCorner(nf, nf);
    Record(c, parent, fresh_generation_ + c);
    if (top_only && boundary_off_[c] != kNoBoundary) {
      std::memcpy(boundary_.get() + boundary_off_[c], joint, sizeof(double) * static_cast<std::size_t>(n) * n);
    }
    return {c, n, off, 0};
  };
  const auto descends = [&](int c) {
    const std::vector<int>& children = tree_->clique(c).children();
    return top_only ? std::any_of(children.begin(), children.end(), walked) : !children.empty();
  };
  std::vector<Frame>& frames = st->frames;
  frames.clear();
  frames.push_back(compute(root, tree_->clique(root).parent(), parent_joint, parent_n, 0));
  while (!frames.empty()) {
    Frame& f = frames.back();
    const std::vector<int>& children = tree_->clique(f.clique).children();
    while (f.next_child < children.size() && !walked(children[f.next_child])) ++f.next_child;
    if (f.next_child == children.size()) {
      frames.pop_back();
      continue;
    }
    const int child = children[f.next_child++];
    while (f.next_child < children.size() && !walked(children[f.next_child])) ++f.next_child;
    if (f.next_child < children.size()) Prefetch(tree_->clique(children[f.next_child]));
    const bool last = f.next_child == children.size();
    const Frame top = f;  // frames may grow below
    Frame cf = compute(child, top.clique, st->data.get() + top.off, top.n,
                       top.off + static_cast<std::size_t>(top.n) * top.n);
    if (!descends(child)) continue;
    if (last) {
      // The parent's joint is not needed any more: the child's moves down into its place, so
      // a chain of only children (the top of an iSAM2 tree) holds two joints, not a path's.
      std::memmove(st->data.get() + top.off, st->data.get() + cf.off,
                   sizeof(double) * static_cast<std::size_t>(cf.n) * cf.n);
      cf.off = top.off;
      frames.back() = cf;
    } else {
      frames.push_back(cf);
    }
  }
}

int BayesTreeMarginals::AssignSubtrees() {
  // The threads take disjoint subtrees (subtree_split.h); a subtree needs only its root's
  // parent's joint, so the cliques above the subtrees (the "top") are computed first, on the
  // calling thread (the reverse of elimination's order).
  const int threads = params_.threads;
  for (int c : order_) subtree_work_[c] = work_[c];
  for (auto it = order_.rbegin(); it != order_.rend(); ++it) {  // children before parents
    const int parent = tree_->clique(*it).parent();
    if (parent != BayesTree::kNone) subtree_work_[parent] += subtree_work_[*it];
  }
  auto for_each_child = [&](int c, auto&& f) {
    for (int child : tree_->clique(c).children()) f(child);
  };
  SplitSubtrees(tree_->roots(), work_, subtree_work_, for_each_child, threads, &split_);
  // Each thread's subtrees in walk order (its Σ_FF blocks written front to back).
  for (int c : order_) in_top_[c] = 0;
  for (int c : split_.top) in_top_[c] = 1;
  std::size_t boundary = 0;
  for (int c : order_) {
    const Clique& cl = tree_->clique(c);
    boundary_off_[c] = kNoBoundary;
    if (in_top_[c] && !std::all_of(cl.children().begin(), cl.children().end(), [&](int x) { return in_top_[x]; })) {
      const std::size_t n = cl.FrontalDim() + cl.SeparatorDim();
      boundary_off_[c] = boundary;
      boundary += n * n;
    }
  }
  if (boundary_capacity_ < boundary) {
    boundary_.reset(new double[boundary]);
    boundary_capacity_ = boundary;
  }
  subtrees_.swap(split_.subtrees);
  int busy = 0;
  for (std::vector<int>& list : subtrees_) {
    std::sort(list.begin(), list.end(), [&](int a, int b) { return arena_off_[a] < arena_off_[b]; });
    busy += !list.empty();
  }
  stats_.top_cliques = static_cast<int>(split_.top.size());
  return busy;
}

void BayesTreeMarginals::ComputeAllFresh() {
  // 1. Σ_FF-only results of an earlier fresh pass point into the arena that is about to be
  //    replaced: drop them (every live clique is recomputed below anyway).
  for (Entry& e : entries_) {
    if (!e.full) {
      e.valid = e.has_result = false;
      e.data = nullptr;
    }
  }
  // 2. The plan; generations reserved up front (clique c's is fresh_generation_ + c), so that
  //    threads need not share a counter.
  const double total = PlanFresh();
  fresh_generation_ = next_generation_;
  next_generation_ += tree_->NumSlots();
  stats_.cliques_checked = stats_.cliques_computed = static_cast<int>(order_.size());
  const int threads = params_.threads > 1 && total >= kParallelMinWork ? AssignSubtrees() : 1;
  if (threads <= 1) {
    // 3. Small (or one thread): the whole forest on the calling thread.
    stats_.top_cliques = 0;
    Reserve(&walk_, serial_need_);
    for (int r : tree_->roots()) WalkFresh(js_, &walk_, r, nullptr, 0, false);
    return;
  }
  stats_.threads_used = threads;
  // 4. Large: the top on the calling thread (its joints above subtrees kept in boundary_), then
  //    the subtrees, each thread walking its own depth first with its own scratch. Each clique is
  //    computed by ComputeJoint from the same inputs as on one thread: the results are the same
  //    bit for bit. Scratch sizes are planned here, as WalkNeed reads shared plan state.
  std::size_t need = 0;
  for (int r : tree_->roots()) {
    if (in_top_[r]) need = std::max(need, WalkNeed(r, true));
  }
  for (int s : subtrees_[0]) need = std::max(need, WalkNeed(s, false));
  Reserve(&walk_, need);
  if (static_cast<int>(helpers_.size()) < params_.threads - 1) helpers_.resize(params_.threads - 1);
  for (int t = 1; t < params_.threads; ++t) {
    Helper& h = helpers_[t - 1];
    std::size_t helper_need = 0;
    for (int s : subtrees_[t]) helper_need = std::max(helper_need, WalkNeed(s, false));
    Reserve(&h.stack, helper_need);
    // Sized here so that the thread allocates nothing (its first malloc would set up an arena).
    JointScratch& js = h.scratch;
    if (static_cast<int>(js.pos.size()) < tree_->NumVariables()) js.pos.resize(tree_->NumVariables());
    js.positions_of = BayesTree::kNone;  // the tree may have changed since the last call
    if (js.rinv.size() < static_cast<std::size_t>(max_nf_) * max_nf_) js.rinv.resize(max_nf_ * max_nf_);
    if (js.k.size() < static_cast<std::size_t>(max_nf_) * max_ns_) js.k.resize(max_nf_ * max_ns_);
    js.runs.reserve(max_ns_);
    h.stack.frames.reserve(max_depth_);
  }
  for (int r : tree_->roots()) {
    if (in_top_[r]) WalkFresh(js_, &walk_, r, nullptr, 0, true);
  }
  const auto walk_subtrees = [this](JointScratch& js, WalkStack* st, const std::vector<int>& subtrees) {
    for (int s : subtrees) {
      const int p = tree_->clique(s).parent();
      if (p == BayesTree::kNone) {
        WalkFresh(js, st, s, nullptr, 0, false);
      } else {
        const Clique& pc = tree_->clique(p);
        WalkFresh(js, st, s, boundary_.get() + boundary_off_[p], pc.FrontalDim() + pc.SeparatorDim(), false);
      }
    }
  };
  pool_.Run(params_.threads - 1, [&](int i) {
    Helper& h = helpers_[i];
    walk_subtrees(h.scratch, &h.stack, subtrees_[i + 1]);
  });
  walk_subtrees(js_, &walk_, subtrees_[0]);
  pool_.Wait();
}

}  // namespace slamd::core
