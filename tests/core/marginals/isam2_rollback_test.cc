// Isam2's rollback of an update that fails to eliminate after the tree's top was released (its
// storage goes to the new cliques; the rollback eliminates the old top again in the order that
// built it, isam2_steps.cc): the estimate is restored exactly, every variable's marginal equals
// that of a solver that never saw the update (1e-9), and the two carry on alike.
#include <gtest/gtest.h>

#include "core/factors/between_factor.h"
#include "core/inference/consistency_check.h"
#include "core/isam/isam2.h"
#include "core/marginals/marginals.h"
#include "tests/testing/example_graphs.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

Eigen::MatrixXd MarginalAt(Isam2* isam, Key key) {
  Isam2Marginals marginals(isam);
  Eigen::MatrixXd c;
  const Status s = marginals.Marginal(key, Isam2Marginals::Frame::kLinearizationPoint, &c);
  EXPECT_TRUE(s.ok()) << s.ToString();
  return c;
}

// A second robot's two poses tied only to each other: nothing anchors them, so eliminating them
// fails.
void AddUnanchoredPair(FactorGraph* g, Values* v) {
  const Key r0 = MakeKey('x', 0, 'b'), r1 = MakeKey('x', 1, 'b');
  g->Emplace<BetweenFactor<Pose2>>(r0, r1, Pose2(1, 0, 0), NoiseModel::Unit(3));
  ASSERT_TRUE(v->Insert(r0, Pose2()).ok());
  ASSERT_TRUE(v->Insert(r1, Pose2(1, 0, 0)).ok());
}

TEST(Isam2RollbackTest, AFailedUpdateRebuildsTheTopItReleased) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(300, 30, 11);
  const std::vector<testing::ExampleStep> steps = testing::StreamByPose(p);
  const std::size_t held_back = 20;
  // Re-eliminating the whole tree (a batch step) and a small top (the newest poses' cliques).
  for (const bool full : {true, false}) {
    for (const int threads : {1, 2}) {
      SCOPED_TRACE(::testing::Message() << "full " << full << ", threads " << threads);
      auto failed = Isam2::Create({.threads = threads}).value();
      auto clean = Isam2::Create({.threads = threads}).value();
      for (std::size_t i = 0; i + held_back < steps.size(); ++i) {
        ASSERT_TRUE(failed->Update(steps[i].factors, steps[i].values).status.ok());
        ASSERT_TRUE(clean->Update(steps[i].factors, steps[i].values).status.ok());
      }
      FactorGraph g;
      Values v;
      AddUnanchoredPair(&g, &v);
      // With `full` every variable is relinearised and the whole tree re-eliminated.
      const Isam2Result r = failed->Update(g, v, {.force_full = full});
      ASSERT_EQ(r.status.code(), StatusCode::kNumericalFailure) << r.status.ToString();
      const Status consistent = CheckConsistency(failed->tree());
      ASSERT_TRUE(consistent.ok()) << consistent.ToString();
      EXPECT_EQ(testing::MaxDifference(failed->CalculateEstimate(), clean->CalculateEstimate()),
                0.0);
      // The rebuilt tree holds the same system: every marginal as the clean solver's.
      for (Key key : clean->linearization_point().keys()) {
        const Eigen::MatrixXd expected = MarginalAt(clean.get(), key);
        const Eigen::MatrixXd got = MarginalAt(failed.get(), key);
        ASSERT_LE((got - expected).norm(), 1e-9 * expected.norm()) << KeyToString(key);
      }
      for (std::size_t i = steps.size() - held_back; i < steps.size(); ++i) {
        ASSERT_TRUE(failed->Update(steps[i].factors, steps[i].values).status.ok());
        ASSERT_TRUE(clean->Update(steps[i].factors, steps[i].values).status.ok());
        EXPECT_LT(testing::MaxDifference(failed->CalculateEstimate(), clean->CalculateEstimate()),
                  1e-9)
            << "step " << i;
      }
    }
  }
}

}  // namespace
}  // namespace slamd::core
