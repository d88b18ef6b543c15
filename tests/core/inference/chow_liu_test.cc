// The Chow-Liu tree of a node-removal summary (core/inference/chow_liu.h) against the dense
// summary: one factor per blanket variable, on at most two of them, and every variable's
// marginal covariance and mean the dense summary's (to the regularisation's 1e-9 scale).
#include "core/inference/chow_liu.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/factors/linearized_factor.h"
#include "core/inference/node_removal.h"
#include "tests/core/inference/dense_system.h"
#include "tests/testing/example_graphs.h"

namespace slamd::core {
namespace {

TEST(ChowLiuTest, TreeKeepsEveryMarginalOfTheDenseSummary) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(20, 4, 13);
  // x0 carries the prior: the summary determines every blanket variable (checked below).
  const KeyVector removed = {MakeKey('x', 0), MakeKey('x', 1)};
  const NodeRemoval r = MarginalizeOut(p.graph.factors(), p.initial, removed,
                                       {.form = NodeRemovalParams::Form::kChowLiu})
                            .value();
  ASSERT_GE(r.blanket.size(), 3u);
  ASSERT_EQ(r.summary.size(), r.blanket.size());
  int unary = 0;
  for (const FactorPtr& f : r.summary) {
    ASSERT_LE(f->keys().size(), 2u);
    unary += f->keys().size() == 1;
  }
  EXPECT_EQ(unary, 1);  // the root
  const testing::DenseSystem dense = testing::Dense({r.marginal}, p.initial, r.blanket);
  const testing::DenseSystem tree = testing::Dense(r.summary, p.initial, r.blanket);
  const std::vector<int>& at = dense.column;
  const Eigen::MatrixXd &dense_h = dense.H, &tree_h = tree.H;
  const Eigen::VectorXd &dense_g = dense.g, &tree_g = tree.g;
  ASSERT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense_h).eigenvalues().minCoeff(),
            1e-6 * dense_h.diagonal().maxCoeff());
  const Eigen::MatrixXd dense_cov = dense_h.inverse(), tree_cov = tree_h.inverse();
  const Eigen::VectorXd dense_mean = dense_h.ldlt().solve(-dense_g);
  const Eigen::VectorXd tree_mean = tree_h.ldlt().solve(-tree_g);
  for (std::size_t i = 0; i < r.blanket.size(); ++i) {
    const int a = at[i], d = at[i + 1] - at[i];
    const Eigen::MatrixXd c = dense_cov.block(a, a, d, d);
    EXPECT_LT((tree_cov.block(a, a, d, d) - c).cwiseAbs().maxCoeff(),
              1e-6 * c.cwiseAbs().maxCoeff())
        << KeyToString(r.blanket[i]);
    EXPECT_LT((tree_mean.segment(a, d) - dense_mean.segment(a, d)).cwiseAbs().maxCoeff(), 1e-6)
        << KeyToString(r.blanket[i]);
  }
  // Sparser: the tree couples fewer pairs than the dense summary (all of them).
  int coupled = 0;
  for (std::size_t i = 0; i < r.blanket.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      coupled +=
          tree_h.block(at[i], at[j], at[i + 1] - at[i], at[j + 1] - at[j]).cwiseAbs().maxCoeff() >
          0.0;
    }
  }
  EXPECT_EQ(coupled, static_cast<int>(r.blanket.size()) - 1);
}

// Relative measurements only (no prior among the removed): the summary's information is
// singular along the global frame; the tree is still finite and one factor per variable, and
// with the dense summary's gauge fixed the same way both give the same blanket means.
TEST(ChowLiuTest, SummaryOfRelativeMeasurementsOnly) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(20, 4, 14);
  const KeyVector removed = {MakeKey('x', 7), MakeKey('x', 8), MakeKey('l', 1)};
  const NodeRemoval r = MarginalizeOut(p.graph.factors(), p.initial, removed,
                                       {.form = NodeRemovalParams::Form::kChowLiu})
                            .value();
  ASSERT_GE(r.blanket.size(), 3u);
  ASSERT_EQ(r.summary.size(), r.blanket.size());
  LinearizedFactor lf;
  for (const FactorPtr& f : r.summary) {
    f->Linearize(p.initial, &lf);
    EXPECT_TRUE(lf.Rhs().allFinite());
    for (int k = 0; k < lf.num_keys(); ++k) EXPECT_TRUE(lf.Block(k).allFinite());
  }
}

}  // namespace
}  // namespace slamd::core
