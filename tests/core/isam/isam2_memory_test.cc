// Isam2::MemoryUse and Isam2::TrimMemory (core/isam/isam2_memory.cc).
#include <gtest/gtest.h>

#include <algorithm>

#include "core/factors/prior_factor.h"
#include "core/inference/consistency_check.h"
#include "core/isam/isam2.h"
#include "tests/testing/example_graphs.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

// TrimMemory gives back what the tree keeps for reuse and changes no number: a solver trimmed
// every few steps gives bit for bit the estimates of one never trimmed, and holds less.
TEST(Isam2MemoryTest, TrimMemoryChangesNothingButTheBytes) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(60, 6, 21);
  auto plain = Isam2::Create().value();
  auto trimmed = Isam2::Create().value();
  const std::vector<testing::ExampleStep> steps = testing::StreamByPose(p);
  for (std::size_t i = 0; i < steps.size(); ++i) {
    ASSERT_TRUE(plain->Update(steps[i].factors, steps[i].values).status.ok());
    ASSERT_TRUE(trimmed->Update(steps[i].factors, steps[i].values).status.ok());
    if (i % 7 == 3) {
      const Isam2Memory before = trimmed->MemoryUse();
      trimmed->TrimMemory();
      const Isam2Memory after = trimmed->MemoryUse();
      // A freed clique keeps its empty lists' few bytes (index {0}, cached factor {0}).
      EXPECT_LE(after.tree_free, 16u * static_cast<std::size_t>(trimmed->tree().NumSlots()));
      EXPECT_LE(after.tree, before.tree);
      const Status consistent = CheckConsistency(trimmed->tree());
      ASSERT_TRUE(consistent.ok()) << consistent.ToString();
    }
    EXPECT_EQ(testing::MaxDifference(plain->CalculateEstimate(), trimmed->CalculateEstimate()), 0.0)
        << "step " << i;
  }
  ASSERT_TRUE(plain->Refine(1.0).converged);
  ASSERT_TRUE(trimmed->Refine(1.0).converged);
  EXPECT_EQ(testing::MaxDifference(plain->CalculateEstimate(), trimmed->CalculateEstimate()), 0.0);
  trimmed->TrimMemory();
  EXPECT_LT(trimmed->MemoryUse().Total(), plain->MemoryUse().Total());
}

// What the tree keeps for reuse after a batch step (every clique removed and made again) goes
// back as the updates after it stay small: it does not stay at the whole tree's size for good.
TEST(Isam2MemoryTest, StorageKeptForReuseFollowsRecentUpdates) {
  const testing::ExampleProblem p = testing::MakeSpatialProblem(1500, 5);
  auto isam = Isam2::Create().value();
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    ASSERT_TRUE(isam->Update(step.factors, step.values).status.ok());
  }
  ASSERT_TRUE(isam->Update({}, {}, {.force_full = true}).status.ok());
  const Isam2Memory batch = isam->MemoryUse();
  EXPECT_GT(batch.tree_free, batch.tree / 2);  // the whole tree was replaced
  // Small updates, which leave the tree as it is: a prior on the last pose, replaced again and
  // again (the storage they need is the last clique's). Without the bound the free list kept
  // what the batch step freed.
  const Key last = MakeKey('x', 1499);
  const Pose3 at = isam->CalculateEstimate().At<Pose3>(last);
  int prior = -1;
  std::size_t least = batch.tree_free;
  for (int k = 0; k < 2500; ++k) {
    FactorGraph g;
    g.Emplace<PriorFactor<Pose3>>(last, at, *NoiseModel::Isotropic(6, 1.0));
    Isam2UpdateOptions options;
    if (prior >= 0) options.remove_factors = {prior};
    const Isam2Result r = isam->Update(g, {}, options);
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    prior = r.new_factor_indices[0];
    least = std::min(least, isam->MemoryUse().tree_free);
  }
  // The bound: twice the largest recent top (decayed to 0.999^2500 = 8% of the batch's) plus a
  // floor of 256 KiB, here about a quarter of what the batch step freed.
  EXPECT_LT(least, batch.tree_free / 3);
  const Status consistent = CheckConsistency(isam->tree());
  ASSERT_TRUE(consistent.ok()) << consistent.ToString();
}

}  // namespace
}  // namespace slamd::core
