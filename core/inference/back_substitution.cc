#include "core/inference/back_substitution.h"

#include <algorithm>
#include <cmath>

#include "core/base/check.h"

namespace slamd::core {

namespace {

// t ← R⁻¹ (t − S xs) for [R S d] stored column-major with nf rows (cond). kNf > 0 fixes nf at
// compile time so the short column loops unroll; 0 means runtime nf.
template <int kNf>
void SolveSmall(const double* __restrict cond, int nf_runtime, int ns, const double* __restrict xs,
                double* __restrict tp) {
  const int nf = kNf > 0 ? kNf : nf_runtime;
  // Four columns of S per pass over t; every t[i] still gets its updates in column order.
  int c = 0;
  for (; c + 4 <= ns; c += 4) {
    const double* s0 = cond + static_cast<size_t>(nf + c) * nf;
    const double *s1 = s0 + nf, *s2 = s1 + nf, *s3 = s2 + nf;
    const double x0 = xs[c], x1 = xs[c + 1], x2 = xs[c + 2], x3 = xs[c + 3];
    for (int i = 0; i < nf; ++i) {
      double v = tp[i];
      v -= s0[i] * x0;
      v -= s1[i] * x1;
      v -= s2[i] * x2;
      v -= s3[i] * x3;
      tp[i] = v;
    }
  }
  for (; c < ns; ++c) {
    const double* s_col = cond + static_cast<size_t>(nf + c) * nf;
    const double x = xs[c];
    for (int i = 0; i < nf; ++i) tp[i] -= s_col[i] * x;
  }
  for (int j = nf - 1; j >= 0; --j) {  // column-oriented back-substitution
    const double* r_col = cond + static_cast<size_t>(j) * nf;
    tp[j] /= r_col[j];
    const double x = tp[j];
    for (int i = 0; i < j; ++i) tp[i] -= r_col[i] * x;
  }
}

}  // namespace

std::vector<int> StackedOffsets(std::span<const int> var_dims) {
  std::vector<int> offsets(var_dims.size() + 1, 0);
  for (size_t v = 0; v < var_dims.size(); ++v) offsets[v + 1] = offsets[v] + var_dims[v];
  return offsets;
}

double SolveClique(const Clique& clique, std::span<const int> var_offsets, Eigen::VectorXd* delta,
                   std::vector<double>* scratch, std::span<double> frontal_changes) {
  const int nf = clique.FrontalDim();
  const int ns = clique.SeparatorDim();
  scratch->resize(nf + ns);
  Eigen::Map<Eigen::VectorXd> t(scratch->data(), nf);
  Eigen::Map<Eigen::VectorXd> xs(scratch->data() + nf, ns);
  // 1. Gather the separator values (solved in ancestors).
  //    Plain loops: the variables are a few scalars each, too short for Eigen's dynamic segments.
  const double* from = delta->data();
  for (int k = 0; k < clique.num_separator(); ++k) {
    const double* src = from + var_offsets[clique.separator()[k]];
    double* dst = xs.data() + clique.separator_offset(k);
    for (int j = 0, dim = clique.separator_dim(k); j < dim; ++j) dst[j] = src[j];
  }
  // 2. t = d − S δ_S, then R δ_F = t. Cliques are small (a few variables) in the bulk of the
  //    tree, where plain column loops beat Eigen's general kernels' set-up cost.
  constexpr int kSmall = 32;
  t = clique.d();
  if (nf <= kSmall) {
    const double* cond = clique.conditional().data();
    switch (nf) {  // compile-time sizes for the common single-pose cliques
      case 3:
        SolveSmall<3>(cond, nf, ns, xs.data(), t.data());
        break;
      case 6:
        SolveSmall<6>(cond, nf, ns, xs.data(), t.data());
        break;
      case 12:
        SolveSmall<12>(cond, nf, ns, xs.data(), t.data());
        break;
      default:
        SolveSmall<0>(cond, nf, ns, xs.data(), t.data());
    }
  } else {
    if (ns > 0) t.noalias() -= clique.S() * xs;
    clique.R().triangularView<Eigen::Upper>().solveInPlace(t);
  }
  // 3. Scatter the frontals, measuring the change.
  double max_change = 0.0;
  for (int k = 0; k < clique.num_frontals(); ++k) {
    double* x = delta->data() + var_offsets[clique.frontal(k)];
    const double* x_new = t.data() + clique.frontal_offset(k);
    double change = 0.0;
    for (int j = 0, dim = clique.frontal_dim(k); j < dim; ++j) {
      change = std::max(change, std::abs(x_new[j] - x[j]));
      x[j] = x_new[j];
    }
    if (!frontal_changes.empty()) frontal_changes[k] = change;
    max_change = std::max(max_change, change);
  }
  return max_change;
}

void BackSubstitute(const BayesTree& tree, std::span<const int> var_offsets,
                    Eigen::VectorXd* delta) {
  SLAMD_CHECK(static_cast<int>(var_offsets.size()) > tree.NumVariables() ||
              tree.NumVariables() == 0)
      << "BackSubstitute: offsets for " << var_offsets.size() << " variables, tree has "
      << tree.NumVariables();
  if (tree.NumVariables() > 0) {
    SLAMD_CHECK(delta->size() >= var_offsets[tree.NumVariables()])
        << "BackSubstitute: delta too short";
  }
  std::vector<double> scratch;
  for (int id : tree.TopDownOrder()) SolveClique(tree.clique(id), var_offsets, delta, &scratch);
}

namespace {

constexpr char kSolved = 1;
constexpr char kSkipped = 2;

// The wildfire rule: a clique is re-solved when forced or when a separator variable changed.
bool NeedsSolve(const Clique& clique, int id, const WildfireWorkspace& ws) {
  if (ws.forced[id] != 0) return true;
  for (int v : clique.separator()) {
    if (ws.changed[v] != 0) return true;
  }
  return false;
}

// Solves the clique and marks its frontals that moved more than the threshold.
void SolveAndMark(const Clique& clique, std::span<const int> var_offsets, Eigen::VectorXd* delta,
                  WildfireWorkspace* ws) {
  ws->frontal_changes.resize(clique.num_frontals());
  SolveClique(clique, var_offsets, delta, &ws->scratch, ws->frontal_changes);
  for (int k = 0; k < clique.num_frontals(); ++k) {
    if (ws->frontal_changes[k] > ws->threshold) {
      ws->changed[clique.frontal(k)] = 1;
      ws->changed_vars.push_back(clique.frontal(k));
    }
  }
}

}  // namespace

int WildfireBegin(const BayesTree& tree, std::span<const int> forced, double threshold,
                  std::span<const int> first, std::span<const int> var_offsets,
                  Eigen::VectorXd* delta, WildfireWorkspace* ws) {
  SLAMD_CHECK(!ws->in_pass) << "WildfireBegin: the previous pass was not finished";
  if (static_cast<int>(ws->forced.size()) < tree.NumSlots()) {
    ws->forced.resize(tree.NumSlots(), 0);
    ws->visited.resize(tree.NumSlots(), 0);
  }
  if (static_cast<int>(ws->changed.size()) < tree.NumVariables()) {
    ws->changed.resize(tree.NumVariables(), 0);
  }
  ws->in_pass = true;
  ws->threshold = threshold;
  ws->forced_ids.assign(forced.begin(), forced.end());
  for (int id : forced) ws->forced[id] = 1;
  ws->changed_vars.clear();
  ws->visited_ids.clear();
  int solved = 0;
  for (int target : first) {
    ws->path.clear();
    for (int id = target; id != Clique::kNone && ws->visited[id] == 0;) {
      ws->path.push_back(id);
      id = tree.clique(id).parent();
    }
    // Top down; below a clique the rule skipped, the full pass would not have gone either.
    for (auto it = ws->path.rbegin(); it != ws->path.rend(); ++it) {
      const int id = *it;
      const Clique& clique = tree.clique(id);
      const int parent = clique.parent();
      const bool reached = parent == Clique::kNone || ws->visited[parent] == kSolved;
      const bool solve = reached && NeedsSolve(clique, id, *ws);
      if (solve) {
        SolveAndMark(clique, var_offsets, delta, ws);
        ++solved;
      }
      ws->visited[id] = solve ? kSolved : kSkipped;
      ws->visited_ids.push_back(id);
    }
  }
  return solved;
}

int WildfireFinish(const BayesTree& tree, std::span<const int> var_offsets, Eigen::VectorXd* delta,
                   WildfireWorkspace* ws) {
  SLAMD_CHECK(ws->in_pass) << "WildfireFinish without WildfireBegin";
  ws->stack.assign(tree.roots().begin(), tree.roots().end());
  int solved = 0;
  while (!ws->stack.empty()) {
    const int id = ws->stack.back();
    ws->stack.pop_back();
    const Clique& clique = tree.clique(id);
    // Prefetches (hints, no faults): the walk visits cliques scattered over the heap, and each
    // visit first reads the clique, then its separator ids; asking for them a visit ahead took
    // manhattan's summed solve time from 124.5 to 116.2 ms (medians of 8 interleaved runs of
    // `slamctl bench F --solver isam2 --step-times`, solve_ms summed), lower in 6 of 6 pairs
    // on victoriaPark.
    if (!ws->stack.empty()) __builtin_prefetch(tree.clique(ws->stack.back()).separator().data());
    if (ws->visited[id] == kSkipped) continue;  // decided by WildfireBegin
    if (ws->visited[id] == 0) {
      if (!NeedsSolve(clique, id, *ws)) continue;  // nothing above moved: the subtree stands
      SolveAndMark(clique, var_offsets, delta, ws);
      ++solved;
    }
    for (int child : clique.children()) __builtin_prefetch(&tree.clique(child));
    ws->stack.insert(ws->stack.end(), clique.children().begin(), clique.children().end());
  }
  // Leave the workspace clean for the next pass (O(touched), not O(n)).
  for (int id : ws->forced_ids) ws->forced[id] = 0;
  for (int id : ws->visited_ids) ws->visited[id] = 0;
  for (int v : ws->changed_vars) ws->changed[v] = 0;
  ws->in_pass = false;
  return solved;
}

int WildfireBackSubstitute(const BayesTree& tree, std::span<const int> forced, double threshold,
                           std::span<const int> var_offsets, Eigen::VectorXd* delta,
                           WildfireWorkspace* ws) {
  return WildfireBegin(tree, forced, threshold, {}, var_offsets, delta, ws) +
         WildfireFinish(tree, var_offsets, delta, ws);
}

}  // namespace slamd::core
