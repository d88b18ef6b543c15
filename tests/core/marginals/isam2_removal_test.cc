// Isam2::RemoveVariables: after removing variables anywhere in the Bayes tree, every remaining
// variable's marginal at the linearisation point equals the full graph's (1e-9), the estimate
// does not move, and the solver carries on: new updates and refinement reach the batch optimum of
// the graph that is left (the kept factors and the container).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "core/factors/factor_registry.h"
#include "core/factors/linear_container_factor.h"
#include "core/inference/consistency_check.h"
#include "core/isam/isam2.h"
#include "core/marginals/marginals.h"
#include "tests/testing/example_graphs.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

std::unique_ptr<Isam2> Streamed(const testing::ExampleProblem& p, int steps = -1) {
  Isam2Params params;
  params.wildfire_threshold = 0.0;  // δ exact, so "the estimate does not move" is exact too
  auto isam = Isam2::Create(params).value();
  const std::vector<testing::ExampleStep> all = testing::StreamByPose(p);
  const int n = steps < 0 ? static_cast<int>(all.size()) : steps;
  for (int i = 0; i < n; ++i) {
    const Isam2Result r = isam->Update(all[i].factors, all[i].values);
    EXPECT_TRUE(r.status.ok()) << r.status.ToString();
  }
  return isam;
}

std::map<Key, Eigen::MatrixXd> Marginals(Isam2* isam) {
  std::map<Key, Eigen::MatrixXd> out;
  Isam2Marginals m(isam);
  for (Key key : isam->linearization_point().keys()) {
    Eigen::MatrixXd c;
    EXPECT_TRUE(m.Marginal(key, Isam2Marginals::Frame::kLinearizationPoint, &c).ok());
    out[key] = c;
  }
  return out;
}

void ExpectExactRemoval(Isam2* isam, const KeyVector& removed) {
  const std::map<Key, Eigen::MatrixXd> before = Marginals(isam);
  const Values estimate = isam->CalculateEstimate();
  const int variables = static_cast<int>(isam->linearization_point().size());
  const Isam2RemovalResult r = isam->RemoveVariables(removed);
  ASSERT_TRUE(r.status.ok()) << r.status.ToString();
  EXPECT_EQ(static_cast<int>(isam->linearization_point().size()),
            variables - static_cast<int>(removed.size()));
  for (Key key : removed) EXPECT_FALSE(isam->linearization_point().Contains(key));
  const Status consistent = CheckConsistency(isam->tree());
  EXPECT_TRUE(consistent.ok()) << consistent.ToString();
  EXPECT_EQ(isam->tree().NumVariables(), variables - static_cast<int>(removed.size()));
  for (int f : r.removed_factors) EXPECT_EQ(isam->factor_slots()[f], nullptr);
  // No container when the removed factors say nothing about the blanket (the newest pose with
  // only its odometry).
  ASSERT_LE(r.summary_factors.size(), 1u);  // dense
  if (!r.summary_factors.empty()) {
    EXPECT_EQ(ToKeyVector(isam->factor_slots()[r.summary_factors[0]]->keys()), r.blanket);
  }
  const std::map<Key, Eigen::MatrixXd> after = Marginals(isam);
  ASSERT_EQ(after.size(), before.size() - removed.size());
  for (const auto& [key, cov] : after) {
    const Eigen::MatrixXd& full = before.at(key);
    EXPECT_LT((cov - full).cwiseAbs().maxCoeff(), 1e-9 * full.cwiseAbs().maxCoeff())
        << KeyToString(key);
  }
  const Values now = isam->CalculateEstimate();
  for (Key key : now.keys()) {
    EXPECT_LT(LocalCoordinates(estimate.Get(key), now.Get(key)).norm(), 1e-9) << KeyToString(key);
  }
}

// Old poses, a landmark, scattered poses and the newest pose, one after another from the same
// solver: each removal re-eliminates only where its factors were and leaves the rest exact.
TEST(Isam2RemovalTest, RemovalAnywhereKeepsMarginalsAndEstimate) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(40, 5, 11);
  auto isam = Streamed(p);
  ExpectExactRemoval(isam.get(), {MakeKey('x', 2), MakeKey('x', 3), MakeKey('x', 4)});
  ExpectExactRemoval(isam.get(), {MakeKey('l', 2)});
  ExpectExactRemoval(isam.get(), {MakeKey('x', 17), MakeKey('x', 30), MakeKey('x', 8)});
  ExpectExactRemoval(isam.get(), {MakeKey('x', 39)});  // its odometry alone: no container
  ExpectExactRemoval(isam.get(), {MakeKey('x', 0)});   // the anchored one: its prior moves on
}

TEST(Isam2RemovalTest, RandomRemovalsIn3D) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE(seed);
    const testing::ExampleProblem p = testing::MakeSpatialProblem(30, seed);
    auto isam = Streamed(p);
    std::mt19937 rng(seed);
    for (int round = 0; round < 3; ++round) {
      KeyVector keys = isam->linearization_point().keys();
      std::shuffle(keys.begin(), keys.end(), rng);
      keys.resize(1 + rng() % 4);
      ExpectExactRemoval(isam.get(), keys);
    }
  }
}

// After a removal the solver takes new poses and factors (the blanket's container is a factor
// like any other) and settles at the batch optimum of what it holds.
// With the Chow-Liu summary too (relative measurements only: one factor per blanket variable
// but the root, each on at most two of them and the root).
TEST(Isam2RemovalTest, UpdatesAfterRemovalReachTheBatchOptimum) {
  for (const NodeRemovalParams::Form form :
       {NodeRemovalParams::Form::kDense, NodeRemovalParams::Form::kChowLiu}) {
    SCOPED_TRACE(form == NodeRemovalParams::Form::kDense ? "dense" : "chow-liu");
    const testing::ExampleProblem p = testing::MakePlanarProblem(40, 4, 12);
    const std::vector<testing::ExampleStep> steps = testing::StreamByPose(p);
    auto isam = Streamed(p, 25);
    KeyVector old;
    for (int i = 1; i < 10; ++i) old.push_back(MakeKey('x', i));
    const Isam2RemovalResult r = isam->RemoveVariables(old, {.form = form});
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    if (form == NodeRemovalParams::Form::kChowLiu) {
      ASSERT_GE(r.blanket.size(), 3u);
      EXPECT_EQ(r.summary_factors.size(), r.blanket.size() - 1);
      for (int f : r.summary_factors) EXPECT_LE(isam->factor_slots()[f]->keys().size(), 3u);
    }
    const Status consistent = CheckConsistency(isam->tree());
    ASSERT_TRUE(consistent.ok()) << consistent.ToString();
    for (std::size_t i = 25; i < steps.size(); ++i) {
      // Factors on removed poses (loop closures to them) are left out, as a server would refuse
      // them.
      FactorGraph factors;
      for (const FactorPtr& f : steps[i].factors) {
        bool on_removed = false;
        for (Key k : f->keys()) on_removed |= std::find(old.begin(), old.end(), k) != old.end();
        if (!on_removed) factors.Add(f);
      }
      Values values;
      for (Key k : steps[i].values.keys()) {
        if (std::find(old.begin(), old.end(), k) == old.end()) {
          ASSERT_TRUE(values.Insert(k, steps[i].values.Get(k)).ok());
        }
      }
      const Isam2Result u = isam->Update(factors, values);
      ASSERT_TRUE(u.status.ok()) << "step " << i << ": " << u.status.ToString();
    }
    ASSERT_TRUE(isam->Refine(10.0).converged);
    // The batch optimum of the same factors: Gauss-Newton from the estimate moves nothing.
    const Values estimate = isam->CalculateEstimate();
    EXPECT_LT(testing::MaxDifference(estimate, testing::BatchStepAt(isam->Factors(), estimate)),
              1e-6);
  }
}

// Chow-Liu summaries take in the summaries already on their blanket (as it ends, roots taken in
// with them included): removing the poses next to an earlier removal's replaces that removal's
// tree factors on the shared variables instead of adding a second tree beside them, and the
// solver still reaches the batch optimum of what it holds.
TEST(Isam2RemovalTest, ChowLiuSummariesTakeInTheSummariesOnTheirBlanket) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(40, 4, 12);
  auto isam = Streamed(p);
  const NodeRemovalParams tree{.form = NodeRemovalParams::Form::kChowLiu};
  KeyVector first, second;
  for (int i = 5; i < 9; ++i) first.push_back(MakeKey('x', i));
  for (int i = 9; i < 13; ++i) second.push_back(MakeKey('x', i));
  const Isam2RemovalResult a = isam->RemoveVariables(first, tree);
  ASSERT_TRUE(a.status.ok()) << a.status.ToString();
  ASSERT_GE(a.summary_factors.size(), 2u);
  // The first tree's factors the second removal's blanket holds wholly.
  std::vector<FactorPtr> first_tree;
  for (int f : a.summary_factors) first_tree.push_back(isam->factor_slots()[f]);
  const Isam2RemovalResult b = isam->RemoveVariables(second, tree);
  ASSERT_TRUE(b.status.ok()) << b.status.ToString();
  int taken = 0;
  for (std::size_t i = 0; i < a.summary_factors.size(); ++i) {
    const std::span<const Key> keys = first_tree[i]->keys();
    const bool on_blanket = std::all_of(keys.begin(), keys.end(), [&](Key k) {
      return std::find(b.blanket.begin(), b.blanket.end(), k) != b.blanket.end();
    });
    const bool gone = std::find(b.removed_factors.begin(), b.removed_factors.end(),
                                a.summary_factors[i]) != b.removed_factors.end();
    // Touching a removed pose or wholly on the blanket: taken in either way.
    const bool touches_removed = std::any_of(keys.begin(), keys.end(), [&](Key k) {
      return std::find(second.begin(), second.end(), k) != second.end();
    });
    EXPECT_EQ(gone, on_blanket || touches_removed) << i;
    taken += on_blanket;
  }
  EXPECT_GT(taken, 0);
  // No container is left wholly on the second blanket but the second tree's own.
  for (int f = 0; f < static_cast<int>(isam->factor_slots().size()); ++f) {
    const FactorPtr& factor = isam->factor_slots()[f];
    if (!factor || !dynamic_cast<const LinearContainerFactor*>(factor.get())) continue;
    const bool on_blanket = std::all_of(factor->keys().begin(), factor->keys().end(), [&](Key k) {
      return std::find(b.blanket.begin(), b.blanket.end(), k) != b.blanket.end();
    });
    if (on_blanket) {
      EXPECT_NE(std::find(b.summary_factors.begin(), b.summary_factors.end(), f),
                b.summary_factors.end());
    }
  }
  ASSERT_TRUE(isam->Refine(10.0).converged);
  const Values estimate = isam->CalculateEstimate();
  EXPECT_LT(testing::MaxDifference(estimate, testing::BatchStepAt(isam->Factors(), estimate)),
            1e-6);
}

TEST(Isam2RemovalTest, RefusalsChangeNothing) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(12, 2, 3);
  auto isam = Streamed(p);
  const Values before = isam->CalculateEstimate();
  const int factors = static_cast<int>(isam->Factors().size());
  const Isam2RemovalResult unknown = isam->RemoveVariables(KeyVector{MakeKey('x', 99)});
  EXPECT_EQ(unknown.status.code(), StatusCode::kInvalidArgument);
  const Isam2RemovalResult twice =
      isam->RemoveVariables(KeyVector{MakeKey('x', 3), MakeKey('x', 3)});
  EXPECT_EQ(twice.status.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(isam->linearization_point().size(), before.size());
  EXPECT_EQ(static_cast<int>(isam->Factors().size()), factors);
  EXPECT_EQ(testing::MaxDifference(isam->CalculateEstimate(), before), 0.0);
  // And it still works.
  EXPECT_TRUE(isam->RemoveVariables(KeyVector{MakeKey('x', 3)}).status.ok());
}

// The summary factors of a removal, as numbers: measured, R and carried values (x0).
std::vector<double> SummaryNumbers(const Isam2& isam, const Isam2RemovalResult& r) {
  std::vector<double> out;
  for (int f : r.summary_factors) {
    const FactorRecord record = EncodeFactor(*isam.factor_slots()[f]);
    out.insert(out.end(), record.measured.begin(), record.measured.end());
    const Eigen::MatrixXd& info = record.sqrt_information;
    out.insert(out.end(), info.data(), info.data() + info.size());
    for (const Variable& v : record.values) EncodeVariable(v, &out);
  }
  return out;
}

// A removal at given values (a journal replay repeating a removal where its own θ drifted)
// makes exactly the summary the removal at those values made; at its own θ it would not. A
// value missing or of another type is refused before anything changes.
TEST(Isam2RemovalTest, RemovalAtGivenValuesRepeatsThatRemoval) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(12, 2, 3);
  const KeyVector removed{MakeKey('x', 3), MakeKey('x', 4)};
  auto live = Streamed(p);
  const Isam2RemovalResult made = live->RemoveVariables(removed);
  ASSERT_TRUE(made.status.ok()) << made.status.ToString();
  ASSERT_FALSE(made.blanket.empty());
  EXPECT_EQ(made.marginalized_at.size(), removed.size() + made.blanket.size());
  for (Key key : made.blanket) EXPECT_TRUE(made.marginalized_at.Contains(key));
  const std::vector<double> summary = SummaryNumbers(*live, made);

  // Two solvers of the same graph whose θ moved on (relinearised at the optimum).
  auto drifted = Streamed(p);
  auto replay = Streamed(p);
  for (Isam2* isam : {drifted.get(), replay.get()}) ASSERT_TRUE(isam->Refine(10.0).converged);
  const Isam2RemovalResult own = drifted->RemoveVariables(removed);
  ASSERT_TRUE(own.status.ok());
  EXPECT_NE(SummaryNumbers(*drifted, own), summary);

  const Key blanket = made.blanket[0];
  Values missing = made.marginalized_at;
  ASSERT_TRUE(missing.Erase(blanket).ok());
  Values retyped = missing;
  const bool pose = std::holds_alternative<Pose2>(made.marginalized_at.Get(blanket));
  ASSERT_TRUE(retyped.Insert(blanket, pose ? Variable(Point2(0, 0)) : Variable(Pose2())).ok());
  for (const Values* at : {&missing, &retyped}) {
    EXPECT_EQ(replay->RemoveVariables(removed, {}, at).status.code(), StatusCode::kInvalidArgument);
  }
  EXPECT_EQ(replay->linearization_point().size(), drifted->linearization_point().size() + 2);

  const Isam2RemovalResult repeated = replay->RemoveVariables(removed, {}, &made.marginalized_at);
  ASSERT_TRUE(repeated.status.ok()) << repeated.status.ToString();
  EXPECT_EQ(SummaryNumbers(*replay, repeated), summary);
}

}  // namespace
}  // namespace slamd::core
