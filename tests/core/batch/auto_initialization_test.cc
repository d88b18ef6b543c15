#include "core/batch/auto_initialization.h"

#include <gtest/gtest.h>

#include <random>

#include "tests/testing/example_graphs.h"

namespace slamd::core {
namespace {

std::vector<Key> AutoInitPoseKeys(const Values& v) {
  std::vector<Key> poses;
  for (Key k : v.keys()) {
    if (KeySymbol(k) == 'x') poses.push_back(k);
  }
  return poses;
}

// A start whose orientations are scrambled (all but the root's) holds the solver far from the
// optimum; the automatic choice reaches the optimum the truth leads to, and says where from.
TEST(AutoInitializationTest, AvoidsThePoorStartAndReachesTheOptimum) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(60, 10, 5);
  const std::vector<Key> poses = AutoInitPoseKeys(p.initial);
  Values scrambled = p.initial;
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  for (size_t i = 1; i < poses.size(); ++i) {
    const Pose2 x = scrambled.At<Pose2>(poses[i]);
    ASSERT_TRUE(scrambled.Update(poses[i], Pose2(x.x() + 3.0, x.y() - 2.0, angle(rng))).ok());
  }
  const BatchResult from_scrambled = Optimize(p.graph, scrambled);
  const BatchResult from_truth = Optimize(p.graph, p.truth);
  ASSERT_TRUE(from_truth.status.ok());
  ASSERT_GT(from_scrambled.summary.final_cost, 1.5 * from_truth.summary.final_cost)
      << "the scrambled start must be a poor one for this test to mean anything";
  const Result<AutoInitialization> a =
      OptimizeWithAutoInitialization(p.graph, scrambled, poses, {});
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_NE(a->chosen, InitialGuess::kAsGiven);
  EXPECT_NEAR(a->result.summary.final_cost, from_truth.summary.final_cost,
              1e-6 * from_truth.summary.final_cost);
  ASSERT_GE(a->tried.size(), 2u);
  EXPECT_EQ(a->tried.front().first, InitialGuess::kAsGiven);
  EXPECT_NEAR(a->tried.front().second, from_scrambled.summary.final_cost,
              1e-9 * from_scrambled.summary.final_cost);
}

// A good start is kept: the other starts reach no lower cost.
TEST(AutoInitializationTest, KeepsAGoodStart) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(40, 6, 7);
  const Result<AutoInitialization> a =
      OptimizeWithAutoInitialization(p.graph, p.truth, AutoInitPoseKeys(p.truth), {});
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_EQ(a->chosen, InitialGuess::kAsGiven);
  EXPECT_EQ(a->tried.size(), 2u);  // no incremental start: the cost per dimension is about 1
}

}  // namespace
}  // namespace slamd::core
