#include "core/inference/back_substitution.h"

#include <gtest/gtest.h>

#include <random>
#include <set>

#include "core/inference/consistency_check.h"
#include "tests/core/inference/random_linear_system.h"

namespace slamd::core {
namespace {

using testing::EliminateAll;
using testing::MakeRandomSystem;
using testing::RandomLinearSystem;

TEST(BackSubstitutionTest, StackedOffsets) {
  EXPECT_EQ(StackedOffsets(std::vector<int>{3, 2, 6}), (std::vector<int>{0, 3, 5, 11}));
  EXPECT_EQ(StackedOffsets(std::vector<int>{}), std::vector<int>{0});
}

TEST(BackSubstitutionTest, SolveCliqueByHand) {
  // Frontals {1 (dim 2)}, separator {0 (dim 1)}: R = [[2, 1], [0, 4]], S = [[1], [2]],
  // d = [3, 8]. With δ_0 = 1: R δ_1 = d − S δ_0 = [2, 6] → δ_1 = [(2 − 1.5) / 2, 1.5].
  Clique c;
  c.Reset(std::vector<int>{1}, std::vector<int>{2}, std::vector<int>{0}, std::vector<int>{1});
  c.mutable_conditional() << 2, 1, 1, 3,  //
      0, 4, 2, 8;
  const std::vector<int> offsets = {0, 1, 3};
  Eigen::VectorXd delta(3);
  delta << 1.0, 10.0, 1.5;
  std::vector<double> scratch;
  std::vector<double> changes(1);
  const double change = SolveClique(c, offsets, &delta, &scratch, changes);
  EXPECT_DOUBLE_EQ(delta(0), 1.0);
  EXPECT_DOUBLE_EQ(delta(1), 0.25);
  EXPECT_DOUBLE_EQ(delta(2), 1.5);
  EXPECT_DOUBLE_EQ(change, 9.75);
  EXPECT_DOUBLE_EQ(changes[0], 9.75);
}

TEST(BackSubstitutionTest, WildfireWithZeroThresholdEqualsFullSolve) {
  const RandomLinearSystem s = MakeRandomSystem(40, 30, false, 5);
  const std::vector<int> order = ColamdOrdering(s.NumVars(), s.Incidence()).value();
  BayesTree tree;
  EliminationResult result;
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, order, &tree, &result));
  const std::vector<int> offsets = StackedOffsets(s.dims);
  Eigen::VectorXd full = Eigen::VectorXd::Zero(offsets.back());
  BackSubstitute(tree, offsets, &full);
  EXPECT_LT((full - s.DenseSolve()).cwiseAbs().maxCoeff(), 1e-9);

  // From zero, forcing only the roots: every variable moves, so everything is re-solved.
  WildfireWorkspace ws;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(offsets.back());
  const int solved = WildfireBackSubstitute(tree, tree.roots(), 0.0, offsets, &x, &ws);
  EXPECT_EQ(solved, tree.NumCliques());
  EXPECT_LT((x - full).cwiseAbs().maxCoeff(), 1e-12);
  // Again from the solution: only the forced roots are solved, nothing moved.
  EXPECT_EQ(WildfireBackSubstitute(tree, tree.roots(), 0.0, offsets, &x, &ws),
            static_cast<int>(tree.roots().size()));
  // The workspace was left clean: the same call gives the same count.
  EXPECT_EQ(WildfireBackSubstitute(tree, tree.roots(), 0.0, offsets, &x, &ws),
            static_cast<int>(tree.roots().size()));
}

TEST(BackSubstitutionTest, WildfireStopsWhereChangesAreSmall) {
  const RandomLinearSystem s = MakeRandomSystem(40, 30, false, 6);
  BayesTree tree;
  EliminationResult result;
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, testing::NaturalOrder(s.NumVars()), &tree, &result));
  const std::vector<int> offsets = StackedOffsets(s.dims);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(offsets.back());
  BackSubstitute(tree, offsets, &x);
  const Eigen::VectorXd exact = x;
  // Perturb every variable a little; a huge threshold re-solves only the forced root, which
  // restores the root's variables, and leaves the rest perturbed.
  Eigen::VectorXd perturbed = exact + Eigen::VectorXd::Constant(exact.size(), 1e-6);
  WildfireWorkspace ws;
  ASSERT_EQ(tree.roots().size(), 1u);
  const int root = tree.roots()[0];
  EXPECT_EQ(WildfireBackSubstitute(tree, tree.roots(), 1.0, offsets, &perturbed, &ws), 1);
  for (int v : tree.clique(root).frontals()) {
    EXPECT_LT((perturbed - exact).segment(offsets[v], s.dims[v]).cwiseAbs().maxCoeff(), 1e-12);
  }
  EXPECT_GT((perturbed - exact).cwiseAbs().maxCoeff(), 5e-7);
  // From the same perturbed start, a zero threshold spreads the correction down the whole tree
  // (every separator moved).
  perturbed = exact + Eigen::VectorXd::Constant(exact.size(), 1e-6);
  EXPECT_EQ(WildfireBackSubstitute(tree, tree.roots(), 0.0, offsets, &perturbed, &ws),
            tree.NumCliques());
  EXPECT_LT((perturbed - exact).cwiseAbs().maxCoeff(), 1e-12);
}

// The pass in two parts (WildfireBegin, then WildfireFinish) against the one-part pass and the
// dense solution: the same cliques solved to the same values, and the paths' frontals final
// after the first part.
TEST(BackSubstitutionTest, WildfireInTwoPartsSolvesThePathsFirstAndEndsTheSame) {
  const RandomLinearSystem s = MakeRandomSystem(60, 45, false, 7);
  const std::vector<int> order = ColamdOrdering(s.NumVars(), s.Incidence()).value();
  BayesTree tree;
  EliminationResult result;
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, order, &tree, &result));
  ASSERT_EQ(tree.roots().size(), 1u);
  const std::vector<int> offsets = StackedOffsets(s.dims);
  const Eigen::VectorXd exact = s.DenseSolve();
  // Targets: the cliques of three variables eliminated early (deep in the tree), twice one.
  const std::vector<int> first = {tree.CliqueOf(order[0]), tree.CliqueOf(order[5]),
                                  tree.CliqueOf(order[0]), tree.CliqueOf(order[20])};
  std::set<int> on_paths;
  for (int c : first) {
    for (int id = c; id != Clique::kNone; id = tree.clique(id).parent()) on_paths.insert(id);
  }
  ASSERT_LT(on_paths.size(), static_cast<size_t>(tree.NumCliques()));

  // From zero with threshold 0: the first part solves exactly the paths, and their frontals are
  // already the solution.
  WildfireWorkspace ws;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(offsets.back());
  const int begun = WildfireBegin(tree, tree.roots(), 0.0, first, offsets, &x, &ws);
  EXPECT_EQ(begun, static_cast<int>(on_paths.size()));
  for (int id : on_paths) {
    for (int v : tree.clique(id).frontals()) {
      EXPECT_LT((x - exact).segment(offsets[v], s.dims[v]).cwiseAbs().maxCoeff(), 1e-9) << v;
    }
  }
  EXPECT_EQ(begun + WildfireFinish(tree, offsets, &x, &ws), tree.NumCliques());
  EXPECT_LT((x - exact).cwiseAbs().maxCoeff(), 1e-9);

  // From a start perturbed unevenly, with a threshold that stops part of the way: the same count
  // and bit for bit the same δ as the one-part pass.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd start = exact;
  for (int i = 0; i < start.size(); ++i) start[i] += 1e-3 * u(rng) * (i % 3 == 0 ? 10.0 : 0.01);
  Eigen::VectorXd one = start, two = start;
  const int solved_one = WildfireBackSubstitute(tree, tree.roots(), 1e-4, offsets, &one, &ws);
  EXPECT_GT(solved_one, 1);
  EXPECT_LT(solved_one, tree.NumCliques());
  const int solved_first = WildfireBegin(tree, tree.roots(), 1e-4, first, offsets, &two, &ws);
  for (int c : first) {
    for (int v : tree.clique(c).frontals()) {
      for (int j = 0; j < s.dims[v]; ++j) EXPECT_EQ(two[offsets[v] + j], one[offsets[v] + j]);
    }
  }
  EXPECT_EQ(solved_first + WildfireFinish(tree, offsets, &two, &ws), solved_one);
  for (int i = 0; i < one.size(); ++i) EXPECT_EQ(two[i], one[i]) << i;
  // The workspace is clean again: a one-part pass from the same start gives the same count.
  two = start;
  EXPECT_EQ(WildfireBackSubstitute(tree, tree.roots(), 1e-4, offsets, &two, &ws), solved_one);
}

}  // namespace
}  // namespace slamd::core
