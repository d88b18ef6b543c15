#include "core/inference/back_substitution.h"

#include <gtest/gtest.h>

#include <random>

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

}  // namespace
}  // namespace slamd::core
