// A LinearContainerFactor made of factors' linearisations at θ stands in for them exactly at θ:
// chi2, the batch Gauss-Newton step, Isam2's estimate (also after relinearising, against the
// batch step of the same graph) and the marginals all agree with the original graph's.
#include <gtest/gtest.h>

#include <set>

#include "core/factors/linear_container_factor.h"
#include "core/isam/isam2.h"
#include "core/marginals/marginals.h"
#include "tests/testing/example_graphs.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

// The factors of `graph` that touch any of `removed`, replaced by one container factor of their
// linearisations at `theta`.
FactorGraph WithContainer(const FactorGraph& graph, const Values& theta,
                          const std::set<Key>& removed, int* replaced) {
  FactorGraph kept;
  std::vector<FactorPtr> inside;
  for (const FactorPtr& f : graph) {
    const bool touches = std::any_of(f->keys().begin(), f->keys().end(),
                                     [&](Key k) { return removed.count(k) > 0; });
    if (touches) {
      inside.push_back(f);
    } else {
      kept.Add(f);
    }
  }
  KeyVector keys;
  std::vector<Variable> x0;
  std::vector<int> column;  // of each key in A
  int columns = 0, rows = 0;
  for (const FactorPtr& f : inside) {
    rows += f->dim();
    for (Key k : f->keys()) {
      if (std::find(keys.begin(), keys.end(), k) != keys.end()) continue;
      keys.push_back(k);
      x0.push_back(theta.Get(k));
      column.push_back(columns);
      columns += TangentDim(TypeOf(x0.back()));
    }
  }
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(rows, columns);
  Eigen::VectorXd b(rows);
  int row = 0;
  for (const FactorPtr& f : inside) {
    LinearizedFactor lf;
    f->Linearize(theta, &lf);
    for (int k = 0; k < lf.num_keys(); ++k) {
      const int at =
          static_cast<int>(std::find(keys.begin(), keys.end(), f->keys()[k]) - keys.begin());
      A.block(row, column[at], lf.rows(), lf.dim(k)) = lf.Block(k);
    }
    b.segment(row, lf.rows()) = lf.Rhs();
    row += lf.rows();
  }
  kept.Add(LinearContainerFactor::Create(keys, x0, A, b).value());
  *replaced = static_cast<int>(inside.size());
  return kept;
}

TEST(LinearContainerSolversTest, StandsInForItsFactorsAtTheLinearisationPoint) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(12, 3, 5);
  const Values& theta = p.initial;
  int replaced = 0;
  const FactorGraph with =
      WithContainer(p.graph, theta, {MakeKey('x', 3), MakeKey('x', 4), MakeKey('l', 1)}, &replaced);
  ASSERT_GE(replaced, 5);
  // More variables than elimination's fixed-size scatter takes: its general path runs too.
  ASSERT_GT(with.factors().back()->keys().size(), 4u);
  EXPECT_NEAR(with.Chi2(theta), p.graph.Chi2(theta), 1e-9 * p.graph.Chi2(theta));

  // Batch: the same Gauss-Newton step.
  const Values step = testing::BatchStepAt(p.graph, theta);
  EXPECT_LT(testing::MaxDifference(testing::BatchStepAt(with, theta), step), 1e-9);

  // Isam2 on each graph: the same estimate, the same marginals.
  auto original = Isam2::Create().value();
  auto contained = Isam2::Create().value();
  ASSERT_TRUE(original->Update(p.graph, theta).status.ok());
  const Isam2Result r = contained->Update(with, theta);
  ASSERT_TRUE(r.status.ok()) << r.status.ToString();
  EXPECT_LT(testing::MaxDifference(contained->CalculateEstimate(), step), 1e-9);
  Isam2Marginals a(original.get()), b(contained.get());
  for (Key key : theta.keys()) {
    Eigen::MatrixXd ca, cb;
    ASSERT_TRUE(a.Marginal(key, Isam2Marginals::Frame::kLinearizationPoint, &ca).ok());
    ASSERT_TRUE(b.Marginal(key, Isam2Marginals::Frame::kLinearizationPoint, &cb).ok());
    EXPECT_LT((ca - cb).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + ca.cwiseAbs().maxCoeff()))
        << KeyToString(key);
  }

  // Relinearised by the first-order rule, it still matches the batch step of its own graph.
  ASSERT_TRUE(contained->Update({}, {}, {.force_relinearize = true}).status.ok());
  const Values relinearised = contained->linearization_point();
  EXPECT_LT(testing::MaxDifference(contained->CalculateEstimate(),
                                   testing::BatchStepAt(with, relinearised)),
            1e-9);
}

}  // namespace
}  // namespace slamd::core
