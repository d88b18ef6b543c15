#include "core/isam/isam2.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include "core/batch/batch_solver.h"
#include "core/batch/normal_equations.h"
#include "core/inference/consistency_check.h"
#include "tests/testing/example_graphs.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

using testing::ExampleProblem;


std::unique_ptr<Isam2> MakeIsam2(const Isam2Params& params = {}) {
  Result<std::unique_ptr<Isam2>> isam = Isam2::Create(params);
  EXPECT_TRUE(isam.ok()) << isam.status().ToString();
  return std::move(isam).value();
}

class Isam2ParityTest : public ::testing::TestWithParam<bool> {};

TEST_P(Isam2ParityTest, EveryStepEqualsTheBatchSolutionAtTheSameLinearizationPoint) {
  const bool planar = GetParam();
  const ExampleProblem p = planar ? testing::MakePlanarProblem(40, 8, 3) : testing::MakeSpatialProblem(30, 3);
  auto isam = MakeIsam2({.relinearization = {.skip = 1}});
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    const Isam2Result r = isam->Update(step.factors, step.values, {.force_full_solve = true});
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    ASSERT_TRUE(CheckConsistency(isam->tree()).ok()) << CheckConsistency(isam->tree()).ToString();
    const Values expected = testing::BatchStepAt(isam->Factors(), isam->linearization_point());
    EXPECT_LT(testing::MaxDifference(isam->CalculateEstimate(), expected), 1e-6) << r.Brief();
  }
}

TEST_P(Isam2ParityTest, SettlesToTheBatchOptimum) {
  const bool planar = GetParam();
  const ExampleProblem p = planar ? testing::MakePlanarProblem(40, 8, 5) : testing::MakeSpatialProblem(30, 5);
  auto isam = MakeIsam2();
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) ASSERT_TRUE(isam->Update(step.factors, step.values).status.ok());
  for (int k = 0; k < 10; ++k) {
    ASSERT_TRUE(isam->Update({}, {}, {.force_full = true}).status.ok());
  }
  const BatchResult batch = Optimize(p.graph, p.initial, {.relative_tolerance = 1e-12});
  ASSERT_TRUE(batch.status.ok());
  EXPECT_NEAR(isam->Chi2(), batch.summary.final_chi2, 1e-4 * batch.summary.final_chi2);
  EXPECT_LT(testing::MaxDifference(isam->CalculateEstimate(), batch.values), 1e-4);
}

INSTANTIATE_TEST_SUITE_P(PlanarAndSpatial, Isam2ParityTest, ::testing::Bool());

TEST(Isam2Test, RemovingAFactorEqualsNeverAddingIt) {
  const ExampleProblem p = testing::MakePlanarProblem(30, 0, 7);
  const std::vector<testing::ExampleStep> steps = testing::StreamByPose(p);
  auto with = MakeIsam2(), without = MakeIsam2();
  const Key a = MakeKey('x', 2), b = MakeKey('x', 25);
  const FactorPtr wrong = std::make_shared<BetweenFactor<Pose2>>(a, b, Pose2(5, 5, 1), NoiseModel::Unit(3));
  int wrong_index = -1;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    FactorGraph factors = steps[i].factors;
    if (i == 25) factors.Add(wrong);
    const Isam2Result r = with->Update(factors, steps[i].values);
    ASSERT_TRUE(r.status.ok());
    if (i == 25) wrong_index = r.new_factor_indices.back();
    ASSERT_TRUE(without->Update(steps[i].factors, steps[i].values).status.ok());
  }
  ASSERT_TRUE(with->Update({}, {}, {.remove_factors = {wrong_index}}).status.ok());
  EXPECT_TRUE(CheckConsistency(with->tree()).ok());
  for (int k = 0; k < 5; ++k) {
    ASSERT_TRUE(with->Update({}, {}, {.force_full = true}).status.ok());
    ASSERT_TRUE(without->Update({}, {}, {.force_full = true}).status.ok());
  }
  EXPECT_LT(testing::MaxDifference(with->CalculateEstimate(), without->CalculateEstimate()), 1e-6);
  EXPECT_EQ(with->Factors().size(), without->Factors().size());
}

TEST(Isam2Test, RobustKernelsSettleOnTheRobustBatchOptimum) {
  ExampleProblem p = testing::MakePlanarProblem(30, 0, 11);
  std::vector<testing::ExampleStep> steps = testing::StreamByPose(p);
  const Key a = MakeKey('x', 4), b = MakeKey('x', 22);
  const Pose2 wrong = p.truth.At<Pose2>(a).Between(p.truth.At<Pose2>(b)).Compose(Pose2(2.0, -1.5, 0.8));
  steps[22].factors.Emplace<BetweenFactor<Pose2>>(
      a, b, wrong, *NoiseModel::Diagonal(Vector3(0.05, 0.05, 0.02)),
      *RobustKernel::Create(RobustKernel::Kind::kCauchy, 1.0));
  auto isam = MakeIsam2();
  for (const testing::ExampleStep& step : steps) ASSERT_TRUE(isam->Update(step.factors, step.values).status.ok());
  ASSERT_TRUE(isam->Refine(5.0).converged);
  const FactorGraph graph = isam->Factors();
  const BatchResult batch = Optimize(graph, p.initial, {.relative_tolerance = 1e-12});
  ASSERT_TRUE(batch.status.ok());
  EXPECT_NEAR(graph.Cost(isam->CalculateEstimate()), batch.summary.final_cost, 1e-6 * batch.summary.final_cost);
  EXPECT_LT(testing::MaxDifference(isam->CalculateEstimate(), batch.values), 1e-5);
  EXPECT_LT(testing::MaxDifference(isam->CalculateEstimate(), p.truth), 0.5);  // the outlier lost
}

// Refine rounds relinearise at most refine_max_variables each (a bound on a round's time), and
// still settle on the batch optimum, in more rounds than unbounded ones.
TEST(Isam2Test, BoundedRefineRoundsStillSettleOnTheBatchOptimum) {
  const ExampleProblem p = testing::MakePlanarProblem(60, 10, 9);
  auto bounded = MakeIsam2({.refine_max_variables = 5});
  auto unbounded = MakeIsam2({.refine_max_variables = 0});
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    ASSERT_TRUE(bounded->Update(step.factors, step.values).status.ok());
    ASSERT_TRUE(unbounded->Update(step.factors, step.values).status.ok());
  }
  const Isam2::RefineResult first = bounded->Refine(5.0, 1);
  ASSERT_TRUE(first.status.ok());
  EXPECT_EQ(first.relinearized_variables, 5);
  const Isam2::RefineResult all = unbounded->Refine(5.0, 1);
  EXPECT_GT(all.relinearized_variables, 5);
  const Isam2::RefineResult rest = bounded->Refine(10.0);
  ASSERT_TRUE(rest.converged);
  const Isam2::RefineResult reference = unbounded->Refine(10.0);
  ASSERT_TRUE(reference.converged);
  EXPECT_GT(rest.rounds, reference.rounds);
  const BatchResult batch = Optimize(p.graph, p.initial, {.relative_tolerance = 1e-12});
  ASSERT_TRUE(batch.status.ok());
  EXPECT_NEAR(bounded->Chi2(), batch.summary.final_chi2, 1e-6 * batch.summary.final_chi2);
  EXPECT_LT(testing::MaxDifference(bounded->CalculateEstimate(), batch.values), 1e-4);
}

TEST(Isam2Test, IndeterminateUpdateNamesTheVariableAndChangesNothing) {
  const ExampleProblem p = testing::MakePlanarProblem(10, 0, 2);
  auto isam = MakeIsam2();
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) ASSERT_TRUE(isam->Update(step.factors, step.values).status.ok());
  const Values before = isam->CalculateEstimate();
  const std::size_t factors_before = isam->Factors().size();
  // A second robot's pose linked only to another new pose: nothing anchors them.
  FactorGraph g;
  const Key r0 = MakeKey('x', 0, 'b'), r1 = MakeKey('x', 1, 'b');
  g.Emplace<BetweenFactor<Pose2>>(r0, r1, Pose2(1, 0, 0), NoiseModel::Unit(3));
  Values v;
  ASSERT_TRUE(v.Insert(r0, Pose2()).ok());
  ASSERT_TRUE(v.Insert(r1, Pose2(1, 0, 0)).ok());
  const Isam2Result r = isam->Update(g, v);
  ASSERT_EQ(r.status.code(), StatusCode::kNumericalFailure) << r.status.ToString();
  EXPECT_NE(r.status.message().find("b:x"), std::string::npos) << r.status.message();
  EXPECT_TRUE(CheckConsistency(isam->tree()).ok()) << CheckConsistency(isam->tree()).ToString();
  EXPECT_EQ(isam->Factors().size(), factors_before);
  EXPECT_FALSE(isam->linearization_point().Contains(r0));
  EXPECT_LT(testing::MaxDifference(isam->CalculateEstimate(), before), 1e-12);
  // And it keeps working.
  const ExampleProblem q = testing::MakePlanarProblem(10, 0, 2);
  EXPECT_TRUE(isam->Update({}, {}, {.force_relinearize = true}).status.ok());
}

// A stiff position prior (sigma 0.01 m, folded into the residual) on a Pose2 that cannot be
// linearised (NaN Jacobian) once its variable has moved more than 0.5 m from where it started:
// it fails only when relinearised.
class TrapFactor : public Factor {
 public:
  TrapFactor(Key key, double start_x, double target_x)
      : Factor({key}, NoiseModel::Unit(1), RobustKernel()), start_x_(start_x), target_x_(target_x) {}
  const char* Name() const override { return "Trap"; }
  VariableType KeyType(int) const override { return kVariableType<Pose2>; }
  void EvaluateError(const Values& values, double* e) const override {
    e[0] = kWeight * (values.At<Pose2>(keys()[0]).x() - target_x_);
  }
  void Linearize(const Values& values, LinearizedFactor* out) const override {
    const Pose2& x = values.At<Pose2>(keys()[0]);
    const int dims[] = {3};
    out->Reset(1, dims);
    EvaluateError(values, out->b());
    Eigen::Map<Eigen::RowVector3d> A(out->A(0));
    // d x / d δ for the right perturbation x ⊕ δ: the rotated translation's first row.
    A << kWeight * std::cos(x.theta()), -kWeight * std::sin(x.theta()), 0.0;
    if (std::abs(x.x() - start_x_) > 0.5) A(0) = std::numeric_limits<double>::quiet_NaN();
  }
  void EncodeMeasured(std::vector<double>* out) const override { out->push_back(target_x_); }

 private:
  static constexpr double kWeight = 100.0;
  double start_x_, target_x_;
};

// A factor that fails to linearise at the new linearisation point: the update reports it and
// leaves everything as before, also when the relinearisation runs on threads (1200 factors:
// two threads share them while the top is ordered).
TEST(Isam2Test, AFactorFailingToRelinearizeChangesNothing) {
  for (int threads : {1, 2}) {
    const ExampleProblem p = testing::MakePlanarProblem(1200, 0, 3);
    auto isam = MakeIsam2({.threads = threads});
    for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
      ASSERT_TRUE(isam->Update(step.factors, step.values).status.ok());
    }
    // The trap pulls pose 600 by 2 m: the solve moves it, so relinearising it trips the trap.
    const Key key = isam->linearization_point().KeyAt(600);
    const double x0 = std::get<Pose2>(isam->CalculateEstimate(key)).x();
    FactorGraph trap;
    trap.Add(std::make_shared<TrapFactor>(key, isam->linearization_point().At<Pose2>(key).x(),
                                          x0 + 2.0));
    const Isam2Result added = isam->Update(trap, {}, {.force_full_solve = true});
    ASSERT_TRUE(added.status.ok()) << added.status.ToString();
    const int trap_index = added.new_factor_indices[0];
    const Values before = isam->CalculateEstimate();
    const std::size_t factors_before = isam->Factors().size();
    const Isam2Result r = isam->Update({}, {}, {.force_full = true});
    ASSERT_EQ(r.status.code(), StatusCode::kNumericalFailure) << r.status.ToString();
    EXPECT_NE(r.status.message().find("Trap"), std::string::npos) << r.status.message();
    EXPECT_TRUE(CheckConsistency(isam->tree()).ok()) << CheckConsistency(isam->tree()).ToString();
    EXPECT_EQ(isam->Factors().size(), factors_before);
    EXPECT_EQ(testing::MaxDifference(isam->CalculateEstimate(), before), 0.0);
    // Without the trap it goes on, and relinearises everything as asked.
    const Isam2Result removed = isam->Update({}, {}, {.remove_factors = {trap_index}});
    ASSERT_TRUE(removed.status.ok()) << removed.status.ToString();
    const Isam2Result full = isam->Update({}, {}, {.force_full = true});
    ASSERT_TRUE(full.status.ok()) << full.status.ToString();
    EXPECT_EQ(full.relinearized_variables, 1200);
  }
}

// The threads (relinearisation, elimination of subtrees) change nothing: the same stream with
// one and with two threads gives bitwise the same estimate after every update. The batch step
// every 50 updates makes whole-graph relinearisations and eliminations, large enough for both.
TEST(Isam2Test, ThreadsGiveBitwiseTheSameEstimates) {
  const ExampleProblem p = testing::MakeSpatialProblem(1200, 4);
  auto one = MakeIsam2({.threads = 1, .batch_every = 50});
  auto two = MakeIsam2({.threads = 2, .batch_every = 50});
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    const Isam2Result a = one->Update(step.factors, step.values);
    const Isam2Result b = two->Update(step.factors, step.values);
    ASSERT_TRUE(a.status.ok() && b.status.ok()) << a.status.ToString() << b.status.ToString();
    ASSERT_EQ(a.relinearized_variables, b.relinearized_variables);
    const Values x = one->CalculateEstimate(), y = two->CalculateEstimate();
    for (Key key : x.keys()) {
      ASSERT_TRUE(x.At<Pose3>(key).Equals(y.At<Pose3>(key), 0.0)) << KeyToString(key);  // exact
    }
  }
}

TEST(Isam2Test, EmptyUpdatesAreHarmless) {
  // (No relinearisation due: an empty update on a relinearisation step is a Gauss-Newton step.)
  auto isam = MakeIsam2({.relinearization = {.skip = 1000}});
  EXPECT_TRUE(isam->Update({}, {}).status.ok());  // nothing at all yet
  const ExampleProblem p = testing::MakePlanarProblem(8, 0, 3);
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) ASSERT_TRUE(isam->Update(step.factors, step.values).status.ok());
  const Values before = isam->CalculateEstimate();
  const Isam2Result r = isam->Update({}, {});
  EXPECT_TRUE(r.status.ok()) << r.status.ToString();
  EXPECT_EQ(r.reeliminated_variables, 0);
  EXPECT_LT(testing::MaxDifference(isam->CalculateEstimate(), before), 1e-12);
  EXPECT_TRUE(CheckConsistency(isam->tree()).ok());
}

TEST(Isam2Test, InvalidInputIsRejectedBeforeAnyChange) {
  auto isam = MakeIsam2();
  FactorGraph g;
  g.Emplace<BetweenFactor<Pose2>>(MakeKey('x', 0), MakeKey('x', 1), Pose2(), NoiseModel::Unit(3));
  Values v;
  ASSERT_TRUE(v.Insert(MakeKey('x', 0), Pose2()).ok());
  Isam2Result r = isam->Update(g, v);
  EXPECT_EQ(r.status.code(), StatusCode::kNotFound);
  EXPECT_NE(r.status.message().find("x1"), std::string::npos);
  EXPECT_EQ(isam->linearization_point().size(), 0u);
  r = isam->Update({}, {}, {.remove_factors = {3}});
  EXPECT_EQ(r.status.code(), StatusCode::kInvalidArgument);
  Values lonely;
  ASSERT_TRUE(lonely.Insert(MakeKey('x', 7), Pose2()).ok());
  r = isam->Update({}, lonely);
  EXPECT_EQ(r.status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(r.status.message().find("x7"), std::string::npos);
  EXPECT_FALSE(Isam2::Create({.relinearization = {.skip = 0}}).ok());
}

// Linearisation-error check (Isam2Params::Relinearization::error_threshold).

// Eight poses on a circle of radius 8 m (6 m apart), exact odometry, a loop closure 1 cm off,
// very stiff noise (sigma 1e-4: information 1e8; input_INTEL_g2o reaches 1e12) and an initial
// guess whose headings are off by 0.02-0.03 rad, far below the 0.1 rad relinearisation
// threshold. A Gauss-Newton step from there moves every heading by less than the threshold, so
// the δ thresholds never relinearise; but over 6 m lever arms the step leaves the linear model
// off by tens of sigmas, and chi2 at θ ⊕ δ stays far above the optimum.
struct StiffLoop {
  FactorGraph graph;
  Values initial;
};
StiffLoop MakeStiffLoop(bool robust) {
  StiffLoop p;
  const NoiseModel stiff = *NoiseModel::Isotropic(3, 1e-4);
  const RobustKernel kernel =
      robust ? *RobustKernel::Create(RobustKernel::Kind::kHuber, 1.0) : RobustKernel();
  std::vector<Pose2> truth;
  for (int i = 0; i < 8; ++i) {
    const double phi = i * M_PI / 4;
    truth.emplace_back(8 * std::cos(phi), 8 * std::sin(phi), phi + M_PI / 2);
    const double error = (i % 3 == 0 ? 0.03 : i % 3 == 1 ? -0.03 : 0.02);
    const Pose2 guess(truth[i].x(), truth[i].y(), phi + M_PI / 2 + error);
    EXPECT_TRUE(p.initial.Insert(MakeKey('x', i), guess).ok());
  }
  p.graph.Emplace<PriorFactor<Pose2>>(MakeKey('x', 0), truth[0], stiff);
  for (int i = 0; i < 8; ++i) {
    const int j = (i + 1) % 8;
    // The loop closure is 1 cm (100 sigma) off: the optimum has residuals of ~10 sigma, where
    // the Huber kernel (k = 1) weighs ~0.1.
    const Pose2 odometry = truth[i].Between(truth[j]).Compose(Pose2(j == 0 ? 1e-2 : 0.0, 0, 0));
    p.graph.Emplace<BetweenFactor<Pose2>>(MakeKey('x', i), MakeKey('x', j), odometry, stiff,
                                          kernel);
  }
  return p;
}

class Isam2StaleLinearizationTest : public ::testing::TestWithParam<bool> {};

TEST_P(Isam2StaleLinearizationTest, StiffFactorsAreRelinearizedBelowTheDeltaThresholds) {
  const StiffLoop p = MakeStiffLoop(GetParam());
  auto checked = MakeIsam2({.relinearization = {.skip = 1}});
  auto unchecked = MakeIsam2({.relinearization = {.error_threshold = 0.0, .skip = 1}});
  ASSERT_TRUE(checked->Update(p.graph, p.initial).status.ok());
  ASSERT_TRUE(unchecked->Update(p.graph, p.initial).status.ok());
  const double after_first_step = unchecked->Chi2();
  EXPECT_GT(after_first_step, 1e3);  // the stale Gauss-Newton step
  for (int k = 0; k < 8; ++k) {
    const Isam2Result off = unchecked->Update({}, {});
    ASSERT_TRUE(off.status.ok());
    EXPECT_EQ(off.relinearized_variables, 0);  // every |δ| stays under 0.1
    ASSERT_TRUE(checked->Update({}, {}).status.ok());
  }
  EXPECT_NEAR(unchecked->Chi2(), after_first_step, 1e-6 * after_first_step);  // stuck
  // Near the optimum: what is left comes from linearisation errors under the threshold, and
  // with the kernel from weights that only relinearisation renews (iSAM2's IRLS).
  const FactorGraph graph = checked->Factors();
  const BatchResult batch = Optimize(graph, p.initial, {.relative_tolerance = 1e-12});
  ASSERT_TRUE(batch.status.ok());
  const double optimum = batch.summary.final_cost;
  EXPECT_LT(graph.Cost(checked->CalculateEstimate()) - optimum,
            5e-2 * (graph.Cost(unchecked->CalculateEstimate()) - optimum));
  // Converged: the check finds nothing stale (with a kernel, once the IRLS weight of the cached
  // linearisation is undone), and relinearises nothing.
  const Isam2Result settled = checked->Update({}, {});
  ASSERT_TRUE(settled.status.ok());
  EXPECT_EQ(settled.relinearized_variables, 0);
}

INSTANTIATE_TEST_SUITE_P(PlainAndRobust, Isam2StaleLinearizationTest, ::testing::Bool());

// The linearisation-error check walks the factors of the variables over their δ budget. One
// whose factors all passed is not walked again while its δ stays exactly the same (an update
// that adds nothing and relinearises nothing moves no δ), and is walked again once it moves.
TEST(Isam2Test, TheCheckDoesNotWalkAgainWhatDidNotMove) {
  const ExampleProblem p = testing::MakePlanarProblem(40, 8, 3);
  auto isam = MakeIsam2({.relinearization = {.skip = 1}});
  int walked = 0;
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    const Isam2Result r = isam->Update(step.factors, step.values);
    ASSERT_TRUE(r.status.ok());
    walked += r.screened_variables;
  }
  EXPECT_GT(walked, 0);
  // Until nothing is relinearised any more (each relinearisation moves δ).
  Isam2Result r;
  for (int k = 0; k < 20; ++k) {
    r = isam->Update({}, {});
    ASSERT_TRUE(r.status.ok());
    if (r.relinearized_variables == 0) break;
  }
  ASSERT_EQ(r.relinearized_variables, 0);
  const Isam2Result again = isam->Update({}, {});
  ASSERT_TRUE(again.status.ok());
  EXPECT_EQ(again.screened_variables, 0);
  // A loop closure 0.5 m off what the estimate says moves δ along the loop.
  const Key a = MakeKey('x', 0), b = MakeKey('x', 39);
  const Pose2 xa = std::get<Pose2>(isam->CalculateEstimate(a));
  const Pose2 xb = std::get<Pose2>(isam->CalculateEstimate(b));
  const Pose2 between = xa.Between(xb.Compose(Pose2(0.5, 0.0, 0.0)));
  FactorGraph loop;
  loop.Emplace<BetweenFactor<Pose2>>(a, b, between, NoiseModel::Isotropic(3, 0.01).value());
  ASSERT_TRUE(isam->Update(loop, {}).status.ok());
  const Isam2Result moved = isam->Update({}, {});
  ASSERT_TRUE(moved.status.ok());
  EXPECT_GT(moved.screened_variables, 0);
}

TEST(Isam2Test, TheLinearizationErrorCheckHasNoSideEffects) {
  // The check evaluates factors at θ ⊕ δ by moving θ and restoring it: with a threshold no
  // factor reaches, every step must be bit-identical to a run without the check.
  const ExampleProblem p = testing::MakePlanarProblem(40, 8, 3);
  auto checked = MakeIsam2({.relinearization = {.error_threshold = 1e12}});
  auto unchecked = MakeIsam2({.relinearization = {.error_threshold = 0.0}});
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    const Isam2Result a = checked->Update(step.factors, step.values);
    const Isam2Result b = unchecked->Update(step.factors, step.values);
    ASSERT_TRUE(a.status.ok() && b.status.ok());
    EXPECT_EQ(a.relinearized_variables, b.relinearized_variables);
  }
  EXPECT_EQ(testing::MaxDifference(checked->CalculateEstimate(), unchecked->CalculateEstimate()),
            0.0);
  EXPECT_EQ(
      testing::MaxDifference(checked->linearization_point(), unchecked->linearization_point()),
      0.0);
}

// Isam2UpdateOptions::defer_relinearization_above: an update due to relinearise more variables
// than that relinearises none (θ of every old variable stays bit for bit), reports how many were
// due, and checks again at the next update; a limit above every due count changes nothing.
TEST(Isam2Test, DeferredRelinearizationLeavesTheLinearizationPointAndIsReported) {
  const ExampleProblem p = testing::MakePlanarProblem(60, 10, 7);
  auto deferring = MakeIsam2({.relinearization = {.skip = 3}});
  auto plain = MakeIsam2({.relinearization = {.skip = 3}});
  auto unlimited = MakeIsam2({.relinearization = {.skip = 3}});
  int deferred = 0, due_again = 0;
  bool previous_deferred = false;
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    const Values before = deferring->linearization_point();
    const Isam2Result r =
        deferring->Update(step.factors, step.values, {.defer_relinearization_above = 2});
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    ASSERT_TRUE(CheckConsistency(deferring->tree()).ok());
    if (r.relinearization_deferred > 0) {
      ++deferred;
      EXPECT_GT(r.relinearization_deferred, 2);
      EXPECT_EQ(r.relinearized_variables, 0);
      for (Key key : before.keys()) {
        const Variable& now = deferring->linearization_point().Get(key);
        ASSERT_EQ(LocalCoordinates(before.Get(key), now).lpNorm<Eigen::Infinity>(), 0.0)
            << KeyToString(key);
      }
    } else {
      EXPECT_LE(r.relinearized_variables, 2);
    }
    // Checked at every update after a deferral, not only every `skip`.
    if (previous_deferred && (r.relinearization_deferred > 0 || r.relinearized_variables > 0)) {
      ++due_again;
    }
    previous_deferred = r.relinearization_deferred > 0;

    const Isam2Result a = plain->Update(step.factors, step.values);
    const Isam2Result b =
        unlimited->Update(step.factors, step.values, {.defer_relinearization_above = 1 << 30});
    ASSERT_TRUE(a.status.ok() && b.status.ok());
    EXPECT_EQ(b.relinearization_deferred, 0);
    EXPECT_EQ(testing::MaxDifference(plain->CalculateEstimate(), unlimited->CalculateEstimate()),
              0.0);
  }
  EXPECT_GT(deferred, 0);
  EXPECT_GT(due_again, 0);
  EXPECT_GT(plain->Chi2(), 0.0);
}

// Isam2UpdateOptions::skip_relinearization: no check, nothing relinearised or deferred, even when
// the skip count makes the update a checking one; what was due is due at the next update.
TEST(Isam2Test, SkippedRelinearizationLeavesTheLinearizationPoint) {
  const ExampleProblem p = testing::MakePlanarProblem(60, 10, 7);
  auto isam = MakeIsam2({.relinearization = {.skip = 1}});
  int skipped_due = 0;
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    const Values before = isam->linearization_point();
    const Isam2Result r = isam->Update(step.factors, step.values, {.skip_relinearization = true});
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();
    EXPECT_EQ(r.relinearized_variables, 0);
    EXPECT_EQ(r.relinearization_deferred, 0);
    for (Key key : before.keys()) {
      const Variable& now = isam->linearization_point().Get(key);
      ASSERT_EQ(LocalCoordinates(before.Get(key), now).lpNorm<Eigen::Infinity>(), 0.0);
    }
    // The same update without the option would have relinearised: then the next one does.
    const Isam2Result next = isam->Update({}, {});
    ASSERT_TRUE(next.status.ok());
    skipped_due += next.relinearized_variables > 0;
  }
  EXPECT_GT(skipped_due, 0);
}

// The δ thresholds are per variable type and kind of entry: raising the landmarks' translation
// threshold keeps them at their linearisation point while the poses move.
TEST(Isam2Test, PerTypeThresholdsDecideWhichVariablesRelinearize) {
  const ExampleProblem p = testing::MakePlanarProblem(30, 6, 13);
  const Isam2Params::Relinearization base{.error_threshold = 0.0, .skip = 1};
  Isam2Params::Relinearization landmarks_fixed = base;
  landmarks_fixed.per_type = {
      {.type = "Point2", .kind = EntryKind::kTranslation, .threshold = 1e9}};
  auto plain = MakeIsam2({.relinearization = base});
  auto fixed = MakeIsam2({.relinearization = landmarks_fixed});
  ASSERT_TRUE(plain->Update(p.graph, p.initial).status.ok());
  ASSERT_TRUE(fixed->Update(p.graph, p.initial).status.ok());
  const Isam2Result a = plain->Update({}, {});
  const Isam2Result b = fixed->Update({}, {});
  ASSERT_TRUE(a.status.ok() && b.status.ok());
  int moved_landmarks = 0;
  for (Key key : p.initial.keys()) {
    const bool landmark = KeySymbol(key) == 'l';
    const double moved_plain =
        LocalCoordinates(p.initial.Get(key), plain->linearization_point().Get(key)).norm();
    const double moved_fixed =
        LocalCoordinates(p.initial.Get(key), fixed->linearization_point().Get(key)).norm();
    if (landmark) {
      EXPECT_EQ(moved_fixed, 0.0) << KeyToString(key);
      moved_landmarks += moved_plain > 0.0;
    } else {
      EXPECT_EQ(moved_fixed, moved_plain) << KeyToString(key);  // poses: the same decision
    }
  }
  ASSERT_GT(moved_landmarks, 0);
  EXPECT_EQ(a.relinearized_variables - b.relinearized_variables, moved_landmarks);
}

// Isam2UpdateOptions::order_last: a whole graph given in one update puts those variables in the
// root clique, and the solution does not depend on the order.
TEST(Isam2Test, OrderLastPutsTheVariablesInTheRootClique) {
  const ExampleProblem p = testing::MakePlanarProblem(80, 12, 9);
  const Key newest = MakeKey('x', 79);
  ASSERT_TRUE(p.initial.Contains(newest));
  auto constrained = MakeIsam2();
  auto free = MakeIsam2();
  Isam2Result r = constrained->Update(p.graph, p.initial, {.order_last = {newest}});
  ASSERT_TRUE(r.status.ok()) << r.status.ToString();
  ASSERT_TRUE(free->Update(p.graph, p.initial).status.ok());
  ASSERT_TRUE(CheckConsistency(constrained->tree()).ok());
  const BayesTree& tree = constrained->tree();
  const int root = tree.CliqueOf(constrained->linearization_point().SlotOf(newest));
  EXPECT_EQ(tree.clique(root).parent(), Clique::kNone);
  EXPECT_LT(testing::MaxDifference(constrained->CalculateEstimate(), free->CalculateEstimate()),
            1e-9);
  // An unknown key is refused before anything changes.
  r = constrained->Update({}, {}, {.order_last = {MakeKey('x', 500)}});
  EXPECT_EQ(r.status.code(), StatusCode::kNotFound);
  EXPECT_NE(r.status.message().find("x500"), std::string::npos);
}

TEST(Isam2Test, SolveFirstGivesItsKeysAtOnceAndTheRestAfterBitwiseTheSame) {
  const ExampleProblem p = testing::MakePlanarProblem(150, 20, 4);
  auto plain = MakeIsam2();
  auto split = MakeIsam2();
  int pose = 0, partial_updates = 0;
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    // The step's pose (StreamByPose: one per step) and, once there, x2: deep in the tree.
    const Key newest = MakeKey('x', pose++);
    std::vector<Key> first = {newest};
    if (pose > 3) first.push_back(MakeKey('x', 2));
    const Isam2Result a = plain->Update(step.factors, step.values);
    const Isam2Result b = split->Update(step.factors, step.values, {.solve_first = first});
    ASSERT_TRUE(a.status.ok() && b.status.ok()) << a.status.ToString() << b.status.ToString();
    ASSERT_TRUE(split->back_substitution_pending());
    // δ of a key in both solvers, bit for bit (their linearisation points stay the same: they
    // relinearise by the same δ).
    const auto same_delta = [&](Key key) {
      const int slot = plain->linearization_point().SlotOf(key);
      const int dim = plain->linearization_point().DimAt(slot);
      return std::equal(plain->Delta(slot), plain->Delta(slot) + dim, split->Delta(slot));
    };
    for (Key key : first) ASSERT_TRUE(same_delta(key)) << KeyToString(key);  // final already
    const int rest = split->FinishBackSubstitution();
    EXPECT_FALSE(split->back_substitution_pending());
    EXPECT_EQ(b.solved_cliques + rest, a.solved_cliques);
    if (rest > 0) ++partial_updates;
    ASSERT_EQ(a.relinearized_variables, b.relinearized_variables);
    for (Key key : plain->linearization_point().keys()) {
      ASSERT_TRUE(same_delta(key)) << KeyToString(key);
    }
    EXPECT_EQ(split->FinishBackSubstitution(), 0);  // nothing left: a no-op
  }
  EXPECT_GT(partial_updates, 10);  // the first part was not the whole pass
}

TEST(Isam2Test, ReadingWhatSolveFirstLeftUnsolvedAborts) {
  const ExampleProblem p = testing::MakePlanarProblem(40, 5, 2);
  auto isam = MakeIsam2();
  const Key newest = MakeKey('x', 39);
  ASSERT_TRUE(isam->Update(p.graph, p.initial, {.solve_first = {newest}}).status.ok());
  ASSERT_TRUE(isam->back_substitution_pending());
  (void)isam->CalculateEstimate(newest);  // allowed
  EXPECT_DEATH((void)isam->CalculateEstimate(MakeKey('x', 3)), "x3.*FinishBackSubstitution");
  EXPECT_DEATH((void)isam->CalculateEstimate(), "CalculateEstimate while a back-substitution");
  EXPECT_DEATH((void)isam->Chi2(), "FinishBackSubstitution");
  EXPECT_DEATH((void)isam->Update({}, {}), "Update while a back-substitution");
  EXPECT_DEATH((void)isam->Refine(1.0), "Update while a back-substitution");
  isam->FinishBackSubstitution();
  EXPECT_TRUE(std::isfinite(isam->Chi2()));
  // An unknown key is refused before anything changes.
  const Isam2Result r = isam->Update({}, {}, {.solve_first = {MakeKey('x', 500)}});
  EXPECT_EQ(r.status.code(), StatusCode::kNotFound);
  EXPECT_FALSE(isam->back_substitution_pending());
}

}  // namespace
}  // namespace slamd::core
