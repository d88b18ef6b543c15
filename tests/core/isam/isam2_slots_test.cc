// Isam2's factor slots: a removed factor's index goes to a later factor with as many keys, once
// the update that removed it stands; a failed update gives back the slots it took.
#include <gtest/gtest.h>

#include <memory>
#include <utility>

#include "core/factors/between_factor.h"
#include "core/factors/position_prior_factor.h"
#include "core/inference/consistency_check.h"
#include "core/isam/isam2.h"
#include "tests/testing/example_graphs.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

std::unique_ptr<Isam2> Streamed(const testing::ExampleProblem& p) {
  auto isam = Isam2::Create({.relinearization = {.skip = 1}}).value();
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    EXPECT_TRUE(isam->Update(step.factors, step.values).status.ok());
  }
  return isam;
}

FactorPtr Closure(int a, int b, const testing::ExampleProblem& p, double off) {
  const Key ka = MakeKey('x', a), kb = MakeKey('x', b);
  const Pose2 z = p.truth.At<Pose2>(ka).Between(p.truth.At<Pose2>(kb)).Compose(Pose2(off, 0, 0));
  return std::make_shared<BetweenFactor<Pose2>>(ka, kb, z, *NoiseModel::Isotropic(3, 0.1));
}

// A lifelong pattern: a measurement replaced by a refined one, again and again (the reduced
// pose graph's fused factors). The slots stay as many as the live factors, and every step
// equals the batch solution at the same linearisation point.
TEST(Isam2SlotsTest, ReplacedFactorsReuseTheirSlots) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(30, 0, 7);
  auto isam = Streamed(p);
  FactorGraph first;
  first.Add(Closure(3, 27, p, 0.0));
  Isam2Result r = isam->Update(first, {});
  ASSERT_TRUE(r.status.ok());
  int live = r.new_factor_indices[0];
  int freed = -1;  // the slot the previous update freed
  const std::size_t slots = isam->factor_slots().size();
  for (int k = 1; k <= 20; ++k) {
    // Removed and replaced in one update: the new factor cannot take the slot freed in it.
    FactorGraph next;
    next.Add(Closure(3 + k % 5, 27 - k % 4, p, 0.01 * k));
    r = isam->Update(next, {}, {.remove_factors = {live}, .force_full_solve = true});
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    EXPECT_NE(r.new_factor_indices[0], live);
    EXPECT_EQ(isam->factor_slots()[live], nullptr);
    if (freed >= 0) EXPECT_EQ(r.new_factor_indices[0], freed);
    freed = std::exchange(live, r.new_factor_indices[0]);
    EXPECT_EQ(isam->factor_slots()[live].get(), next[0].get());
    ASSERT_TRUE(CheckConsistency(isam->tree()).ok()) << CheckConsistency(isam->tree()).ToString();
    const Values expected = testing::BatchStepAt(isam->Factors(), isam->linearization_point());
    EXPECT_LT(testing::MaxDifference(isam->CalculateEstimate(), expected), 1e-6);
  }
  EXPECT_LE(isam->factor_slots().size(), slots + 1);
  EXPECT_EQ(isam->Factors().size(), p.graph.size() + 1);
}

// A slot of the wrong size is not taken; one the failed update took is free again after it,
// and the solver goes on as if the update had never been tried.
TEST(Isam2SlotsTest, FailedUpdatesGiveTheirSlotsBack) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(12, 0, 3);
  auto isam = Streamed(p);
  const Key x5 = MakeKey('x', 5);
  FactorGraph unary;
  unary.Add(std::make_shared<PositionPriorFactor<Pose2>>(x5, p.truth.At<Pose2>(x5).translation(),
                                                         *NoiseModel::Isotropic(2, 1.0)));
  Isam2Result r = isam->Update(unary, {});
  ASSERT_TRUE(r.status.ok());
  const int freed = r.new_factor_indices[0];
  ASSERT_TRUE(isam->Update({}, {}, {.remove_factors = {freed}}).status.ok());
  // A binary factor does not fit the unary slot.
  FactorGraph binary;
  binary.Add(Closure(2, 9, p, 0.0));
  r = isam->Update(binary, {});
  ASSERT_TRUE(r.status.ok());
  EXPECT_NE(r.new_factor_indices[0], freed);
  // A new pose with only a position prior is indeterminate: the update fails and is undone.
  const Key lonely = MakeKey('y', 0);
  Values guess;
  ASSERT_TRUE(guess.Insert(lonely, Pose2(1, 2, 0.3)).ok());
  FactorGraph indeterminate;
  indeterminate.Add(std::make_shared<PositionPriorFactor<Pose2>>(lonely, Point2(1, 2),
                                                                 *NoiseModel::Isotropic(2, 1.0)));
  const Values before = isam->CalculateEstimate();
  const std::size_t live_before = isam->Factors().size();
  r = isam->Update(indeterminate, guess);
  ASSERT_EQ(r.status.code(), StatusCode::kNumericalFailure) << r.status.ToString();
  EXPECT_EQ(isam->factor_slots()[freed], nullptr);
  EXPECT_EQ(isam->Factors().size(), live_before);
  EXPECT_EQ(testing::MaxDifference(isam->CalculateEstimate(), before), 0.0);
  ASSERT_TRUE(CheckConsistency(isam->tree()).ok());
  // The slot is free again: the next unary factor takes it.
  r = isam->Update(unary, {}, {.force_full_solve = true});
  ASSERT_TRUE(r.status.ok()) << r.status.ToString();
  EXPECT_EQ(r.new_factor_indices[0], freed);
  const Values expected = testing::BatchStepAt(isam->Factors(), isam->linearization_point());
  EXPECT_LT(testing::MaxDifference(isam->CalculateEstimate(), expected), 1e-6);
}

}  // namespace
}  // namespace slamd::core
