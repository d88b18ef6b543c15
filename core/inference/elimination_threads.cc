// Eliminator's scheduling: each clique's dims and estimated work, which cliques each thread
// eliminates (disjoint subtrees on the helpers, the top after them on the calling thread), and
// the serial path. The numeric work of
// one clique is in elimination.cc.
#include <algorithm>

#include "core/inference/elimination.h"
#include "core/inference/subtree_split.h"

namespace slamd::core {

Status Eliminator::EliminateSerial(const EliminationProblem& problem, BayesTree* tree,
                                   EliminationResult* result) {
  Workspace* ws = &workspaces_[0];
  for (int c = 0; c < forest_.NumCliques(); ++c) {
    const Status s = EliminateClique(problem, c, tree, ws, &result->hessian_cliques);
    if (!s.ok()) {
      result->failed_variable = ws->failed_variable;
      return s;
    }
  }
  return Status::Ok();
}

void Eliminator::CliqueDims(const EliminationProblem& problem) {
  const int num = forest_.NumCliques();
  clique_nf_.assign(num, 0);
  clique_ns_.assign(num, 0);
  for (int c = 0; c < num; ++c) {
    for (int p = forest_.first_frontal[c]; p != -1; p = forest_.next_frontal[p]) {
      clique_nf_[c] += problem.var_dims[problem.ordering[p]];
    }
    for (int i = forest_.sep_begin[c]; i < forest_.sep_end[c]; ++i) {
      clique_ns_[c] += problem.var_dims[problem.ordering[forest_.sep_data[i]]];
    }
  }
}

double Eliminator::EstimateWork() {
  // Per clique: partial Cholesky nf·(nf²/3 + nf·ns + ns²) plus assembling its share of the
  // parent, ns² (nf, ns: frontal and separator dims). Subtree sums in creation order.
  const int num = forest_.NumCliques();
  work_.assign(num, 0.0);
  subtree_work_.assign(num, 0.0);
  double total = 0.0;
  for (int c = 0; c < num; ++c) {
    const double nf = clique_nf_[c], ns = clique_ns_[c];
    work_[c] = nf * (nf * nf / 3.0 + nf * ns + ns * ns) + ns * ns;
    subtree_work_[c] += work_[c];
    total += work_[c];
    const int parent = forest_.Parent(c);
    if (parent >= 0) subtree_work_[parent] += subtree_work_[c];
  }
  return total;
}

void Eliminator::AssignSubtrees() {
  // Threads take disjoint subtrees (subtree_split.h); the top comes after them, on the calling
  // thread. owner_: the thread, or -1 for the top.
  const int num = forest_.NumCliques();
  roots_.clear();
  for (int c = 0; c < num; ++c) {
    if (forest_.Parent(c) < 0) roots_.push_back(c);
  }
  auto for_each_child = [&](int c, auto&& f) {
    for (int child = forest_.first_child[c]; child != -1; child = forest_.next_sibling[child]) {
      f(child);
    }
  };
  SplitSubtrees(roots_, work_, subtree_work_, for_each_child, threads_, &split_);
  owner_.assign(num, -2);  // -2: not yet known
  for (int c : split_.top) owner_[c] = -1;
  for (int t = 0; t < threads_; ++t) {
    for (int c : split_.subtrees[t]) owner_[c] = t;
  }
  for (int c = num - 1; c >= 0; --c) {  // parents before children: inherit the subtree's thread
    if (owner_[c] == -2) owner_[c] = owner_[forest_.Parent(c)];
  }
}

bool Eliminator::EliminateParallel(const EliminationProblem& problem, BayesTree* tree,
                                   EliminationResult* result) {
  AssignSubtrees();
  const int num = forest_.NumCliques();
  std::vector<char> failed(threads_, 0);
  // The helpers' cliques are shaped and their workspaces sized here, so that the helpers
  // allocate nothing (but a transient list for a factor of more than 4 variables): what a helper
  // allocates comes from its own malloc arena, whose free blocks the rest of the solver cannot
  // reuse (parking-garage: 0.5 MB more peak RSS).
  for (int c = 0; c < num; ++c) {
    if (owner_[c] <= 0) continue;
    ShapeClique(problem, c, tree, &workspaces_[0]);
    Workspace& ws = workspaces_[owner_[c]];
    const Clique& clique = tree->clique(tree_id_[c]);
    const std::size_t ld = clique.FrontalDim() + clique.SeparatorDim() + 1;
    if (ws.matrix.size() < ld * ld) ws.matrix.resize(ld * ld);
    ws.ref.reserve(ld);
    // A cached factor or Hessian assembled here has at most the clique's variables.
    ws.scatter_blocks.reserve(clique.num_frontals() + clique.num_separator() + 1);
  }
  // Thread t eliminates the cliques owned by `owner` in creation order (children first).
  auto eliminate_own = [&](int owner, int t) {
    for (int c = 0; c < num; ++c) {
      if (owner_[c] != owner) continue;
      if (!EliminateClique(problem, c, tree, &workspaces_[t], &result->hessian_cliques,
                           /*shaped=*/owner > 0)
               .ok()) {
        failed[t] = 1;
        return;
      }
    }
  };
  pool_.Run(threads_ - 1, [&](int i) { eliminate_own(i + 1, i + 1); });
  eliminate_own(0, 0);
  pool_.Wait();
  if (std::find(failed.begin(), failed.end(), 1) != failed.end()) return false;
  eliminate_own(-1, 0);  // the top, on the calling thread
  return !failed[0];
}

}  // namespace slamd::core
