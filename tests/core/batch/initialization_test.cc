#include "core/batch/initialization.h"

#include <gtest/gtest.h>

#include "core/batch/batch_solver.h"
#include "tests/testing/example_graphs.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

using testing::ExampleProblem;

// The same graph with every measurement replaced by its exact value under `truth`.
FactorGraph Noiseless(const FactorGraph& graph, const Values& truth) {
  FactorGraph out;
  for (const FactorPtr& f : graph) {
    if (const auto* b = dynamic_cast<const BetweenFactor<Pose2>*>(f.get())) {
      const Pose2 z = truth.At<Pose2>(b->keys()[0]).Between(truth.At<Pose2>(b->keys()[1]));
      out.Emplace<BetweenFactor<Pose2>>(b->keys()[0], b->keys()[1], z, b->noise_model());
    } else if (const auto* r = dynamic_cast<const RelativePointFactor<Pose2, Point2>*>(f.get())) {
      const Point2 z = truth.At<Pose2>(r->keys()[0]).TransformTo(truth.At<Point2>(r->keys()[1]));
      out.Emplace<RelativePointFactor<Pose2, Point2>>(r->keys()[0], r->keys()[1], z, r->noise_model());
    } else {
      out.Add(f);
    }
  }
  return out;
}

std::vector<Key> PoseKeys(const Values& v) {
  std::vector<Key> poses;
  for (Key k : v.keys()) {
    if (KeySymbol(k) == 'x') poses.push_back(k);
  }
  return poses;
}

class InitializationTest : public ::testing::TestWithParam<InitialGuess> {};

TEST_P(InitializationTest, RecoversTheTruthFromNoiselessMeasurements) {
  ExampleProblem p = testing::MakePlanarProblem(40, 6, 3);
  const FactorGraph exact = Noiseless(p.graph, p.truth);
  Values start = p.initial;
  ASSERT_TRUE(start.Update(MakeKey('x', 0), p.truth.Get(MakeKey('x', 0))).ok());  // the gauge
  const Result<Values> r = MakeInitialGuess(GetParam(), exact, start, PoseKeys(start), 7);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_LT(testing::MaxDifference(*r, p.truth), 1e-6);
}

TEST_P(InitializationTest, LeadsToTheSameOptimumAsTheTruth) {
  const ExampleProblem p = testing::MakePlanarProblem(60, 10, 4);
  const Result<Values> r = MakeInitialGuess(GetParam(), p.graph, p.initial, PoseKeys(p.initial), 10);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const BatchResult from_guess = Optimize(p.graph, *r);
  const BatchResult from_truth = Optimize(p.graph, p.truth);
  ASSERT_TRUE(from_guess.status.ok() && from_truth.status.ok());
  EXPECT_NEAR(from_guess.summary.final_chi2, from_truth.summary.final_chi2,
              1e-6 * from_truth.summary.final_chi2);
  EXPECT_LT(p.graph.Chi2(*r), p.graph.Chi2(p.initial));
}

INSTANTIATE_TEST_SUITE_P(Methods, InitializationTest,
                         ::testing::Values(InitialGuess::kSpanningTree, InitialGuess::kLago,
                                           InitialGuess::kIncremental));

TEST(InitializationTest, LagoUnwrapsAnglesAroundALoop) {
  // Poses around a circle turn by 2π in total; measured relative angles wrap at ±π.
  ExampleProblem p = testing::MakePlanarProblem(12, 0, 8);
  const FactorGraph exact = Noiseless(p.graph, p.truth);
  Values start = p.initial;
  ASSERT_TRUE(start.Update(MakeKey('x', 0), p.truth.Get(MakeKey('x', 0))).ok());
  const Result<Values> r = InitializeLago(exact, start, MakeKey('x', 0));
  ASSERT_TRUE(r.ok());
  EXPECT_LT(testing::MaxDifference(*r, p.truth), 1e-6);
}

TEST(InitializationTest, DisconnectedPoseIsNamed) {
  ExampleProblem p = testing::MakePlanarProblem(10, 0, 1);
  ASSERT_TRUE(p.initial.Insert(MakeKey('x', 99), Pose2()).ok());
  const Result<Values> r = InitializeSpanningTree(p.graph, p.initial, MakeKey('x', 0));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("x99"), std::string::npos);
}

TEST(InitializationTest, RejectsSpatialGraphsAndUnknownNames) {
  const ExampleProblem p = testing::MakeSpatialProblem(6, 1);
  const Result<Values> r = MakeInitialGuess(InitialGuess::kLago, p.graph, p.initial, {MakeKey('x', 0)});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("Pose2"), std::string::npos);
  EXPECT_FALSE(ParseInitialGuess("chordal").ok());
  EXPECT_EQ(*ParseInitialGuess("lago"), InitialGuess::kLago);
}

}  // namespace
}  // namespace slamd::core
