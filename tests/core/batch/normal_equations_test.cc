#include "core/batch/normal_equations.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include "tests/testing/example_graphs.h"

namespace slamd::core::internal {
namespace {

// Dense H and b assembled independently from each factor's linearisation, in slot order.
void DenseSystem(const FactorGraph& graph, const Values& values, Eigen::MatrixXd* H, Eigen::VectorXd* b) {
  std::vector<int> offset(values.size() + 1, 0);
  for (std::size_t s = 0; s < values.size(); ++s) offset[s + 1] = offset[s] + values.DimAt(s);
  const int n = offset.back();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(0, n);
  Eigen::VectorXd r(0);
  for (const FactorPtr& f : graph) {
    LinearizedFactor lf;
    f->Linearize(values, &lf);
    Eigen::MatrixXd rows = Eigen::MatrixXd::Zero(lf.rows(), n);
    for (int k = 0; k < lf.num_keys(); ++k) {
      const int s = values.SlotOf(f->keys()[k]);
      rows.middleCols(offset[s], values.DimAt(s)) = lf.Block(k);
    }
    A.conservativeResize(A.rows() + lf.rows(), n);
    A.bottomRows(lf.rows()) = rows;
    r.conservativeResize(r.size() + lf.rows());
    r.tail(lf.rows()) = lf.Rhs();
  }
  *H = A.transpose() * A;
  *b = -A.transpose() * r;
}

TEST(NormalEquationsTest, StepEqualsDenseSolveOfTheSameNormalEquations) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const testing::ExampleProblem p = testing::MakePlanarProblem(30, 6, seed);
    Result<std::unique_ptr<NormalEquations>> eq = NormalEquations::Create(p.graph, p.initial);
    ASSERT_TRUE(eq.ok()) << eq.status().ToString();
    (*eq)->Linearize(p.initial);
    Eigen::VectorXd delta;
    ASSERT_TRUE((*eq)->Solve(&delta).ok());
    Eigen::VectorXd delta_original;
    (*eq)->system().ToOriginalOrder(delta, &delta_original);

    Eigen::MatrixXd H;
    Eigen::VectorXd b;
    DenseSystem(p.graph, p.initial, &H, &b);
    const Eigen::VectorXd expected = H.llt().solve(b);
    EXPECT_LT((delta_original - expected).norm(), 1e-9 * std::max(1.0, expected.norm()));
  }
}

TEST(NormalEquationsTest, DampedStepEqualsDenseDampedSolve) {
  const testing::ExampleProblem p = testing::MakeSpatialProblem(20, 4);
  Result<std::unique_ptr<NormalEquations>> eq = NormalEquations::Create(p.graph, p.initial);
  ASSERT_TRUE(eq.ok());
  (*eq)->Linearize(p.initial);
  (*eq)->SaveUndamped();
  Eigen::MatrixXd H;
  Eigen::VectorXd b;
  DenseSystem(p.graph, p.initial, &H, &b);
  for (bool diagonal : {false, true}) {
    (*eq)->Damp(0.5, diagonal);
    Eigen::VectorXd delta, delta_original;
    ASSERT_TRUE((*eq)->Solve(&delta).ok());
    (*eq)->system().ToOriginalOrder(delta, &delta_original);
    Eigen::MatrixXd D = Eigen::MatrixXd::Identity(H.rows(), H.cols());
    if (diagonal) D.diagonal() = H.diagonal().cwiseMax(1e-6);
    const Eigen::VectorXd expected = (H + 0.5 * D).llt().solve(b);
    EXPECT_LT((delta_original - expected).norm(), 1e-9 * std::max(1.0, expected.norm()));
    EXPECT_NEAR((*eq)->DampingNorm(delta, diagonal), expected.dot(D * expected), 1e-9 * expected.squaredNorm() * D.diagonal().maxCoeff());
  }
}

TEST(NormalEquationsTest, IndeterminateSystemNamesAVariable) {
  testing::ExampleProblem p = testing::MakePlanarProblem(10, 0, 5);
  FactorGraph no_prior;
  for (std::size_t f = 1; f < p.graph.size(); ++f) no_prior.Add(p.graph[f]);  // drop the anchor
  Result<std::unique_ptr<NormalEquations>> eq = NormalEquations::Create(no_prior, p.initial);
  ASSERT_TRUE(eq.ok());
  (*eq)->Linearize(p.initial);
  Eigen::VectorXd delta;
  const Status s = (*eq)->Solve(&delta);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kNumericalFailure);
  EXPECT_NE(s.message().find("near variable x"), std::string::npos) << s.message();
}

TEST(NormalEquationsTest, RejectsUnconstrainedVariable) {
  testing::ExampleProblem p = testing::MakePlanarProblem(5, 0, 6);
  ASSERT_TRUE(p.initial.Insert(MakeKey('z', 1), Point2(0, 0)).ok());
  Result<std::unique_ptr<NormalEquations>> eq = NormalEquations::Create(p.graph, p.initial);
  ASSERT_FALSE(eq.ok());
  EXPECT_NE(eq.status().message().find("z1"), std::string::npos);
}

}  // namespace
}  // namespace slamd::core::internal
