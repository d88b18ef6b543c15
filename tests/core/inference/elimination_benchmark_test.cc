// Timing of the elimination on the M3500 pose graph (3500 Pose2, 5453 between factors, 3x3
// blocks), linearised at the dataset's initial guess: full elimination under COLAMD, and an
// iSAM2-like stream (one pose per update: remove the top, re-eliminate it with the orphans'
// cached factors under a constrained COLAMD order, wildfire back-substitution). The numbers are
// printed, not asserted; the solution is checked through the gradient AᵀA x + Aᵀb = 0.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include "core/base/timing.h"
#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "core/inference/back_substitution.h"
#include "core/inference/consistency_check.h"
#include "core/inference/elimination.h"
#include "core/linear/ordering.h"
#include "tests/testing/datasets.h"

namespace slamd::core {
namespace {

struct Graph {
  std::vector<int> dims;
  std::vector<JacobianFactor> factors;
};

// Reads VERTEX_SE2 / EDGE_SE2 and linearises every edge (and a prior on pose 0) at the initial
// guess. Poses are ids 0..n-1.
bool LoadM3500(const std::string& path, Graph* graph) {
  std::ifstream in(path);
  if (!in) return false;
  std::vector<Pose2> poses;
  struct Edge {
    int i, j;
    Pose2 z;
    Eigen::Matrix3d info;
  };
  std::vector<Edge> edges;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "VERTEX_SE2") {
      int id;
      double x, y, t;
      ls >> id >> x >> y >> t;
      if (id != static_cast<int>(poses.size())) return false;
      poses.emplace_back(x, y, t);
    } else if (tag == "EDGE_SE2") {
      Edge e;
      double x, y, t, i11, i12, i13, i22, i23, i33;
      ls >> e.i >> e.j >> x >> y >> t >> i11 >> i12 >> i13 >> i22 >> i23 >> i33;
      e.z = Pose2(x, y, t);
      e.info << i11, i12, i13, i12, i22, i23, i13, i23, i33;
      edges.push_back(e);
    }
  }
  Values values;
  for (size_t i = 0; i < poses.size(); ++i) {
    if (!values.Insert(MakeKey('x', i), poses[i]).ok()) return false;
  }
  graph->dims.assign(poses.size(), 3);
  LinearizedFactor lf;
  JacobianFactor jf;
  const PriorFactor<Pose2> prior(MakeKey('x', 0), poses[0], *NoiseModel::Isotropic(3, 1e-3));
  prior.Linearize(values, &lf);
  const int zero = 0;
  if (!jf.Assign(lf, std::span<const int>(&zero, 1)).ok()) return false;
  graph->factors.push_back(jf);
  for (const Edge& e : edges) {
    auto noise = NoiseModel::FromInformation(e.info);
    if (!noise.ok()) return false;
    const BetweenFactor<Pose2> f(MakeKey('x', e.i), MakeKey('x', e.j), e.z, noise.value());
    f.Linearize(values, &lf);
    const int ids[2] = {e.i, e.j};
    if (!jf.Assign(lf, ids).ok()) return false;
    graph->factors.push_back(jf);
  }
  return true;
}

// max |Σ_f A_fᵀ (A_f x + b_f)| relative to max |Σ_f A_fᵀ b_f|.
double RelativeGradient(const Graph& g, const std::vector<int>& offsets, const Eigen::VectorXd& x) {
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(x.size()), grad0 = grad;
  for (const JacobianFactor& f : g.factors) {
    Eigen::VectorXd r = f.b();
    for (int k = 0; k < f.num_vars(); ++k) r += f.A(k) * x.segment(offsets[f.var(k)], 3);
    for (int k = 0; k < f.num_vars(); ++k) {
      grad.segment(offsets[f.var(k)], 3) += f.A(k).transpose() * r;
      grad0.segment(offsets[f.var(k)], 3) += f.A(k).transpose() * f.b();
    }
  }
  return grad.cwiseAbs().maxCoeff() / grad0.cwiseAbs().maxCoeff();
}

TEST(EliminationBenchmark, M3500FullElimination) {
  const std::string path = slamd::testing::SharedDatasetPath("input_M3500_g2o.g2o");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  Graph g;
  ASSERT_TRUE(LoadM3500(path, &g));
  const int n = static_cast<int>(g.dims.size());
  std::vector<const JacobianFactor*> factors;
  FactorIncidence incidence;
  for (const JacobianFactor& f : g.factors) {
    factors.push_back(&f);
    incidence.AddFactor({f.vars().begin(), f.vars().end()});
  }
  Stopwatch watch;
  const std::vector<int> order = ColamdOrdering(n, incidence).value();
  const double t_order = watch.Lap();

  BayesTree tree;
  EliminationResult result;
  Eliminator eliminator;
  const EliminationProblem problem{.var_dims = g.dims, .factors = factors, .ordering = order};
  // First run: cold (allocates the tree); then warm runs into a cleared tree.
  watch.Restart();
  ASSERT_TRUE(eliminator.Eliminate(problem, &tree, &result).ok());
  const double t_cold = watch.Lap();
  const int reps = 20;
  double t_warm = 1e9;
  for (int r = 0; r < reps; ++r) {
    tree.Clear();
    watch.Restart();
    ASSERT_TRUE(eliminator.Eliminate(problem, &tree, &result).ok());
    t_warm = std::min(t_warm, watch.Lap());
  }
  double t_fresh = 1e9;
  for (int r = 0; r < 5; ++r) {
    BayesTree fresh;
    watch.Restart();
    ASSERT_TRUE(Eliminate(problem, &fresh, &result).ok());
    t_fresh = std::min(t_fresh, watch.Lap());
  }
  ASSERT_TRUE(CheckConsistency(tree).ok()) << CheckConsistency(tree).ToString();
  const std::vector<int> offsets = StackedOffsets(g.dims);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(offsets.back());
  watch.Restart();
  BackSubstitute(tree, offsets, &x);
  const double t_solve = watch.Lap();
  EXPECT_LT(RelativeGradient(g, offsets, x), 1e-8);

  int max_frontal = 0, max_dim = 0;
  double flops = 0.0;
  for (int id : result.cliques) {
    const double nf = tree.clique(id).FrontalDim(), ns = tree.clique(id).SeparatorDim() + 1;
    flops += nf * nf * nf / 3 + nf * nf * ns + nf * ns * ns;  // Cholesky, solve, Schur update
    max_frontal = std::max(max_frontal, tree.clique(id).num_frontals());
    max_dim = std::max(max_dim, tree.clique(id).FrontalDim() + tree.clique(id).SeparatorDim());
  }
  std::printf(
      "M3500: %d vars, %zu factors, %d cliques (max %d frontals, max clique dim %d), %.1f Mflop\n"
      "  COLAMD %.2f ms; eliminate: cold %.2f ms, fresh tree %.2f ms, warm (reused tree) %.2f ms;"
      " back-substitution %.2f ms\n",
      n, g.factors.size(), tree.NumCliques(), max_frontal, max_dim, flops * 1e-6, 1e3 * t_order,
      1e3 * t_cold, 1e3 * t_fresh, 1e3 * t_warm, 1e3 * t_solve);
}

// An iSAM2-shaped stream without relinearisation: pose i arrives with its factors to earlier
// poses; the cliques of the touched variables and their ancestors are removed and re-eliminated
// (touched variables last, CCOLAMD), orphans re-attached, wildfire back-substitution.
TEST(EliminationBenchmark, M3500StreamOnePosePerUpdate) {
  const std::string path = slamd::testing::SharedDatasetPath("input_M3500_g2o.g2o");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  Graph g;
  ASSERT_TRUE(LoadM3500(path, &g));
  const int n = static_cast<int>(g.dims.size());
  std::vector<std::vector<int>> arriving(n);  // factors by the pose that completes them
  for (size_t f = 0; f < g.factors.size(); ++f) {
    const auto vars = g.factors[f].vars();
    arriving[*std::max_element(vars.begin(), vars.end())].push_back(static_cast<int>(f));
  }
  std::vector<std::vector<int>> factors_of(n);  // variable index
  BayesTree tree;
  Eliminator eliminator;
  WildfireWorkspace wildfire;
  const std::vector<int> offsets = StackedOffsets(g.dims);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(offsets.back());
  std::vector<int> touched, removed, orphans, order, local, group, slot(n, -1);
  std::vector<const JacobianFactor*> factors;
  std::vector<const HessianFactor*> cached;
  std::vector<char> in_top(n, 0);
  std::vector<int> seen_factor(g.factors.size(), -1);
  EliminationResult result;
  long total_removed = 0, total_solved = 0;
  Stopwatch watch;
  double max_step = 0.0;
  for (int step = 0; step < n; ++step) {
    Stopwatch step_watch;
    touched.assign(1, step);
    for (int f : arriving[step]) {
      for (int v : g.factors[f].vars()) {
        touched.push_back(v);
        factors_of[v].push_back(f);
      }
    }
    removed.clear();
    orphans.clear();
    tree.RemoveTop(touched, &removed, &orphans);
    removed.push_back(step);
    for (int v : removed) in_top[v] = 1;
    // Factors entirely inside the top; the ordering problem on local ids.
    factors.clear();
    FactorIncidence incidence;
    for (size_t i = 0; i < removed.size(); ++i) slot[removed[i]] = static_cast<int>(i);
    for (int v : removed) {
      for (int f : factors_of[v]) {
        if (seen_factor[f] == step) continue;
        seen_factor[f] = step;
        bool inside = true;
        for (int u : g.factors[f].vars()) inside = inside && in_top[u];
        if (!inside) continue;
        factors.push_back(&g.factors[f]);
        local.clear();
        for (int u : g.factors[f].vars()) local.push_back(slot[u]);
        incidence.AddFactor(local);
      }
    }
    cached.clear();
    for (int o : orphans) {
      cached.push_back(&tree.clique(o).cached_factor());
      local.clear();
      for (int u : cached.back()->vars()) local.push_back(slot[u]);
      incidence.AddFactor(local);
    }
    group.assign(removed.size(), 0);
    for (int v : touched) group[slot[v]] = 1;
    const std::vector<int> local_order =
        ConstrainedColamdOrdering(static_cast<int>(removed.size()), incidence, group).value();
    order.clear();
    for (int p : local_order) order.push_back(removed[p]);
    const std::span<const int> dims(g.dims.data(), step + 1);
    ASSERT_TRUE(
        eliminator
            .Eliminate(
                {.var_dims = dims, .factors = factors, .hessians = cached, .ordering = order},
                &tree, &result)
            .ok());
    for (size_t i = 0; i < orphans.size(); ++i) tree.Attach(orphans[i], result.hessian_cliques[i]);
    total_solved += WildfireBackSubstitute(tree, result.cliques, 1e-3, offsets, &x, &wildfire);
    for (int v : removed) in_top[v] = 0;
    total_removed += static_cast<long>(removed.size());
    max_step = std::max(max_step, step_watch.Seconds());
  }
  const double total = watch.Seconds();
  ASSERT_TRUE(CheckConsistency(tree).ok()) << CheckConsistency(tree).ToString();
  BackSubstitute(tree, offsets, &x);
  EXPECT_LT(RelativeGradient(g, offsets, x), 1e-8);
  std::printf(
      "M3500 stream: %d updates in %.1f ms (%.3f ms/update avg, max %.2f ms); %.1f variables "
      "re-eliminated and %.1f cliques back-substituted per update\n",
      n, 1e3 * total, 1e3 * total / n, 1e3 * max_step, double(total_removed) / n,
      double(total_solved) / n);
}

}  // namespace
}  // namespace slamd::core
