#include "core/batch/batch_solver.h"

#include <gtest/gtest.h>

#include "tests/testing/example_graphs.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

using testing::ExampleProblem;

// Dense gradient Σ Aᵀb of the objective (half of it, up to the factor 2) at `values`.
double GradientNorm(const FactorGraph& graph, const Values& values) {
  std::vector<int> offset(values.size() + 1, 0);
  for (std::size_t s = 0; s < values.size(); ++s) offset[s + 1] = offset[s] + values.DimAt(s);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(offset.back());
  for (const FactorPtr& f : graph) {
    LinearizedFactor lf;
    f->Linearize(values, &lf);
    for (int k = 0; k < lf.num_keys(); ++k) {
      const int s = values.SlotOf(f->keys()[k]);
      g.segment(offset[s], values.DimAt(s)) +=
          Eigen::MatrixXd(lf.Block(k)).transpose() * Eigen::VectorXd(lf.Rhs());
    }
  }
  return g.norm();
}

const BatchParams kTight{.relative_tolerance = 1e-14, .absolute_tolerance = 1e-14};

TEST(BatchSolverTest, GaussNewtonAndLevenbergMarquardtReachTheSameOptimum) {
  for (unsigned seed : {1u, 2u}) {
    for (bool planar : {true, false}) {
      const ExampleProblem p = planar ? testing::MakePlanarProblem(40, 8, seed)
                                      : testing::MakeSpatialProblem(24, seed);
      BatchParams gn = kTight;
      gn.algorithm = BatchParams::Algorithm::kGaussNewton;
      const BatchResult a = Optimize(p.graph, p.initial, gn);
      const BatchResult b = Optimize(p.graph, p.initial, kTight);
      BatchParams marquardt = kTight;
      marquardt.damping = BatchParams::Damping::kDiagonal;
      const BatchResult c = Optimize(p.graph, p.initial, marquardt);
      ASSERT_TRUE(a.status.ok() && b.status.ok() && c.status.ok()) << b.status.ToString();
      EXPECT_LT(testing::MaxDifference(a.values, b.values), 1e-7);
      EXPECT_LT(testing::MaxDifference(a.values, c.values), 1e-7);
      EXPECT_NEAR(a.summary.final_chi2, b.summary.final_chi2, 1e-9 * a.summary.final_chi2);
      EXPECT_LT(b.summary.final_chi2, b.summary.initial_chi2);
      // At the optimum the gradient vanishes (relative to where it started; the last digits are
      // round-off in the cost, which no step can improve).
      const double g0 = GradientNorm(p.graph, p.initial);
      EXPECT_GT(g0, 100.0);
      EXPECT_LT(GradientNorm(p.graph, a.values), 1e-8 * g0) << a.summary.Brief();
      EXPECT_LT(GradientNorm(p.graph, b.values), 1e-8 * g0) << b.summary.Brief();
      EXPECT_LT(GradientNorm(p.graph, c.values), 1e-8 * g0) << c.summary.Brief();
    }
  }
}

TEST(BatchSolverTest, SummaryIsConsistent) {
  const ExampleProblem p = testing::MakePlanarProblem(30, 4, 9);
  const BatchResult r = Optimize(p.graph, p.initial);
  ASSERT_TRUE(r.status.ok());
  const BatchSummary& s = r.summary;
  EXPECT_EQ(s.termination, BatchTermination::kConverged);
  EXPECT_GE(s.linear_solves, s.iterations);
  EXPECT_NEAR(s.initial_chi2, p.graph.Chi2(p.initial), 1e-9 * s.initial_chi2);
  EXPECT_NEAR(s.final_chi2, p.graph.Chi2(r.values), 1e-12);
  EXPECT_GT(s.total_s, 0.0);
  EXPECT_GE(s.total_s, s.linearize_s + s.factorize_s);
  EXPECT_GT(s.order_s, 0.0);
  EXPECT_GE(s.setup_s, s.order_s);
  EXPECT_NE(s.Brief().find("converged"), std::string::npos);
}

TEST(BatchSolverTest, RobustKernelDownweightsAnOutlier) {
  ExampleProblem p = testing::MakePlanarProblem(30, 0, 4);
  const Key a = MakeKey('x', 3), b = MakeKey('x', 20);
  const Pose2 wrong = p.truth.At<Pose2>(a).Between(p.truth.At<Pose2>(b)).Compose(Pose2(3.0, -2.0, 1.0));
  const NoiseModel noise = *NoiseModel::Diagonal(Vector3(0.05, 0.05, 0.02));
  FactorGraph plain = p.graph, robust = p.graph;
  plain.Emplace<BetweenFactor<Pose2>>(a, b, wrong, noise);
  robust.Emplace<BetweenFactor<Pose2>>(a, b, wrong, noise,
                                       *RobustKernel::Create(RobustKernel::Kind::kCauchy, 1.0));
  const BatchResult rp = Optimize(plain, p.initial);
  const BatchResult rr = Optimize(robust, p.initial);
  ASSERT_TRUE(rp.status.ok() && rr.status.ok());
  EXPECT_LT(testing::MaxDifference(rr.values, p.truth), 0.5);
  EXPECT_GT(testing::MaxDifference(rp.values, p.truth), 2.0 * testing::MaxDifference(rr.values, p.truth));
  EXPECT_LT(rr.summary.final_cost, rr.summary.final_chi2);  // the outlier's cost is capped
}

TEST(BatchSolverTest, InvalidParamsAndInputAreReportedNotAborted) {
  const ExampleProblem p = testing::MakePlanarProblem(5, 0, 1);
  BatchParams bad;
  bad.max_iterations = 0;
  BatchResult r = Optimize(p.graph, p.initial, bad);
  EXPECT_EQ(r.status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(r.status.message().find("BatchParams::max_iterations"), std::string::npos);

  Values missing = p.initial;
  ASSERT_TRUE(missing.Erase(MakeKey('x', 2)).ok());
  r = Optimize(p.graph, missing);
  EXPECT_EQ(r.status.code(), StatusCode::kNotFound);
  EXPECT_NE(r.status.message().find("x2"), std::string::npos);
}

TEST(BatchSolverTest, GaussNewtonOnAnUnanchoredGraphNamesAVariable) {
  const ExampleProblem p = testing::MakePlanarProblem(8, 0, 2);
  FactorGraph free_gauge;
  for (std::size_t f = 1; f < p.graph.size(); ++f) free_gauge.Add(p.graph[f]);
  const BatchResult r =
      Optimize(free_gauge, p.initial, {.algorithm = BatchParams::Algorithm::kGaussNewton});
  EXPECT_EQ(r.status.code(), StatusCode::kNumericalFailure);
  EXPECT_EQ(r.summary.termination, BatchTermination::kNumericalFailure);
  EXPECT_NE(r.status.message().find("near variable x"), std::string::npos);
  // Levenberg-Marquardt's damping copes with the free gauge.
  const BatchResult lm = Optimize(free_gauge, p.initial);
  EXPECT_TRUE(lm.status.ok()) << lm.status.ToString();
}

}  // namespace
}  // namespace slamd::core
