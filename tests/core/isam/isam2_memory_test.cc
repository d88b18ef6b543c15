// Isam2::MemoryUse and Isam2::TrimMemory (core/isam/isam2_memory.cc).
#include <gtest/gtest.h>

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

// A batch step (every clique removed and made again) builds the new cliques in the storage of
// those it replaces, released before the elimination: it does not hold the tree twice (the
// free list's bound after large tops: BayesTreeTest.FreeStorageFollowsTheTopsReleasedLately).
TEST(Isam2MemoryTest, ABatchStepReusesTheStorageOfTheTreeItReplaces) {
  const testing::ExampleProblem p = testing::MakeSpatialProblem(1500, 5);
  auto isam = Isam2::Create().value();
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    ASSERT_TRUE(isam->Update(step.factors, step.values).status.ok());
  }
  ASSERT_TRUE(isam->Update({}, {}, {.force_full = true}).status.ok());
  const Isam2Memory batch = isam->MemoryUse();
  EXPECT_LT(batch.tree_free, batch.tree / 4);  // kept beside the new tree, it was more than half
  const Status consistent = CheckConsistency(isam->tree());
  ASSERT_TRUE(consistent.ok()) << consistent.ToString();
}

// The undo record of an update that relinearises the whole graph (its old θ and δ, 5000 poses:
// ~280 KB) is given back once the update stands, not kept as long as the solver.
TEST(Isam2MemoryTest, TheRecordOfAWholeGraphRelinearisationIsGivenBack) {
  constexpr int kPoses = 5000;
  const testing::ExampleProblem p = testing::MakePlanarProblem(kPoses, 0, 4);
  auto isam = Isam2::Create({.relinearization = {.rotation_threshold = 1e-6,
                                                 .translation_threshold = 1e-6,
                                                 .skip = 1}})
                  .value();
  ASSERT_TRUE(isam->Update(p.graph, p.initial).status.ok());  // δ everywhere
  const std::size_t before = isam->MemoryUse().scratch;
  const Isam2Result whole = isam->Update({}, {});
  ASSERT_TRUE(whole.status.ok());
  ASSERT_GE(whole.relinearized_variables, kPoses - 100);
  // Kept, the record's old θ alone would be kPoses x 4 doubles more; the update's other scratch
  // (orders, marks, the record's lists of ids) stays.
  EXPECT_LT(isam->MemoryUse().scratch,
            before + kPoses * EncodedSize(kVariableType<Pose2>) * sizeof(double));
}

}  // namespace
}  // namespace slamd::core
