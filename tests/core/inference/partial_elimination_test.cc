// iSAM2's partial re-elimination at the level of the elimination: the top of a tree removed and
// eliminated again from its factors and the orphans' cached factors, alone or with new variables.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <tuple>

#include "core/inference/consistency_check.h"
#include "core/inference/elimination.h"
#include "tests/core/inference/random_linear_system.h"

namespace slamd::core {
namespace {

using testing::EliminateAll;
using testing::MakeOrder;
using testing::MakeRandomSystem;
using testing::OrderKind;
using testing::RandomLinearSystem;
using testing::Solve;

// iSAM2's use: remove the top of a fully eliminated tree (the cliques of the last k variables
// and their ancestors), re-eliminate it from its original factors plus the cached factors of the
// orphaned subtrees, attach the orphans. The new cliques must equal the full elimination's.
class PartialEliminationTest : public ::testing::TestWithParam<std::tuple<unsigned, int, bool>> {};

TEST_P(PartialEliminationTest, ReproducesTheFullElimination) {
  const auto [seed, k, colamd] = GetParam();
  const RandomLinearSystem s = MakeRandomSystem(40, 30, false, seed);
  const std::vector<int> order =
      MakeOrder(s, colamd ? OrderKind::kColamd : OrderKind::kNatural, seed);
  BayesTree full;
  EliminationResult full_result;
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, order, &full, &full_result));

  BayesTree tree = full;  // deep copy
  const std::vector<int> top(order.end() - k, order.end());
  std::vector<int> removed, orphans;
  tree.RemoveTop(top, &removed, &orphans);
  EXPECT_GE(static_cast<int>(removed.size()), k);
  EXPECT_FALSE(CheckConsistency(tree).ok() && !orphans.empty());  // orphans are loose roots

  // Re-eliminate the removed variables in their original relative order.
  std::vector<int> position(s.NumVars());
  for (int p = 0; p < s.NumVars(); ++p) position[order[p]] = p;
  std::vector<int> sub_order = removed;
  std::sort(sub_order.begin(), sub_order.end(),
            [&](int a, int b) { return position[a] < position[b]; });
  const std::set<int> removed_set(removed.begin(), removed.end());
  std::vector<const JacobianFactor*> factors;
  for (const JacobianFactor& f : s.factors) {
    bool inside = true;
    for (int v : f.vars()) inside = inside && removed_set.count(v) > 0;
    if (inside) factors.push_back(&f);
  }
  std::vector<const HessianFactor*> cached;
  for (int o : orphans) cached.push_back(&tree.clique(o).cached_factor());
  EliminationResult result;
  const Status status =
      Eliminate({.var_dims = s.dims, .factors = factors, .hessians = cached, .ordering = sub_order},
                &tree, &result);
  ASSERT_TRUE(status.ok()) << status.ToString();
  for (size_t i = 0; i < orphans.size(); ++i) tree.Attach(orphans[i], result.hessian_cliques[i]);
  ASSERT_TRUE(CheckConsistency(tree).ok()) << CheckConsistency(tree).ToString();
  EXPECT_EQ(tree.NumCliques(), full.NumCliques());

  // Same cliques (frontals, separators, conditionals, cached factors) as the full elimination.
  for (int id : result.cliques) {
    const Clique& c = tree.clique(id);
    const Clique& ref = full.clique(full.CliqueOf(c.frontal(0)));
    ASSERT_TRUE(std::ranges::equal(c.frontals(), ref.frontals()));
    ASSERT_TRUE(std::ranges::equal(c.separator(), ref.separator()));
    EXPECT_LT((c.conditional() - ref.conditional()).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((c.cached_factor().Info() - ref.cached_factor().Info()).cwiseAbs().maxCoeff(),
              1e-9 * std::max(1.0, ref.cached_factor().Info().cwiseAbs().maxCoeff()));
    const int parent = c.parent() == BayesTree::kNone ? -1 : tree.clique(c.parent()).frontal(0);
    const int ref_parent =
        ref.parent() == BayesTree::kNone ? -1 : full.clique(ref.parent()).frontal(0);
    EXPECT_EQ(parent, ref_parent);
  }
  EXPECT_LT((Solve(tree, s) - s.DenseSolve()).cwiseAbs().maxCoeff(), 1e-9);
}

INSTANTIATE_TEST_SUITE_P(TopSizes, PartialEliminationTest,
                         ::testing::Combine(::testing::Values(1u, 2u, 3u, 4u),
                                            ::testing::Values(1, 3, 10, 40), ::testing::Bool()));

// iSAM2's incremental step: new variables and factors join the re-eliminated top.
TEST(EliminationTest, IncrementalStepsMatchBatch) {
  const RandomLinearSystem all = MakeRandomSystem(60, 40, false, 21);
  // Factors become available once all their variables exist (streaming variables in id order).
  std::vector<int> ready(all.factors.size());
  for (size_t f = 0; f < all.factors.size(); ++f) {
    ready[f] = *std::max_element(all.factors[f].vars().begin(), all.factors[f].vars().end());
  }
  BayesTree tree;
  Eliminator eliminator;
  std::vector<int> dims;
  for (int step = 0; step < all.NumVars(); ++step) {
    dims.push_back(all.dims[step]);
    // Variables touched by the new factors (all involve `step`).
    std::vector<int> touched = {step};
    for (size_t f = 0; f < all.factors.size(); ++f) {
      if (ready[f] != step) continue;
      for (int v : all.factors[f].vars()) touched.push_back(v);
    }
    std::vector<int> removed, orphans;
    tree.RemoveTop(touched, &removed, &orphans);
    removed.push_back(step);
    const std::set<int> top(removed.begin(), removed.end());
    std::vector<const JacobianFactor*> factors;
    for (size_t f = 0; f < all.factors.size(); ++f) {
      if (ready[f] > step) continue;
      bool inside = true;
      for (int v : all.factors[f].vars()) inside = inside && top.count(v) > 0;
      if (inside) factors.push_back(&all.factors[f]);
    }
    std::vector<const HessianFactor*> cached;
    for (int o : orphans) cached.push_back(&tree.clique(o).cached_factor());
    // Constrained order: the touched variables last (as CCOLAMD would place them).
    std::vector<int> order(top.begin(), top.end());
    std::stable_partition(order.begin(), order.end(), [&](int v) {
      return std::find(touched.begin(), touched.end(), v) == touched.end();
    });
    EliminationResult result;
    const Status status = eliminator.Eliminate(
        {.var_dims = dims, .factors = factors, .hessians = cached, .ordering = order}, &tree,
        &result);
    ASSERT_TRUE(status.ok()) << "step " << step << ": " << status.ToString();
    for (size_t i = 0; i < orphans.size(); ++i) tree.Attach(orphans[i], result.hessian_cliques[i]);
    ASSERT_TRUE(CheckConsistency(tree).ok())
        << "step " << step << ": " << CheckConsistency(tree).ToString();
  }
  EXPECT_LT((Solve(tree, all) - all.DenseSolve()).cwiseAbs().maxCoeff(), 1e-9);
}

}  // namespace
}  // namespace slamd::core
