// Node removal (core/inference/node_removal.h) against dense references: after marginalising a
// set of variables out at θ, the remaining variables' covariance (the inverse of the dense
// information matrix) and Gauss-Newton step equal the full graph's to 1e-9, and the minimum of
// the linearised chi2 differs by exactly the constant it reports; wherever the removed set lies.
#include "core/inference/node_removal.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>
#include <set>

#include "core/factors/linear_container_factor.h"
#include "tests/core/inference/dense_system.h"
#include "tests/testing/example_graphs.h"

namespace slamd::core {
namespace {

using testing::Dense;
using testing::DenseSystem;

double Chi2At(const std::vector<FactorPtr>& factors, const Values& theta) {
  FactorGraph g;
  for (const FactorPtr& f : factors) g.Add(f);
  return g.Chi2(theta);
}

// Removes `removed` from `all` at θ and checks the remaining variables' covariance, step and
// chi2 against the full graph's (the exact summary, whatever the form); the removal in *out.
void ExpectExactRemoval(const std::vector<FactorPtr>& all, const Values& theta,
                        const KeyVector& removed, const NodeRemovalParams& params = {},
                        NodeRemoval* out = nullptr) {
  const Result<NodeRemoval> r = MarginalizeOut(all, theta, removed, params);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  if (out) *out = *r;
  std::vector<FactorPtr> kept;
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (std::find(r->removed_factors.begin(), r->removed_factors.end(), static_cast<int>(i)) ==
        r->removed_factors.end()) {
      kept.push_back(all[i]);
    }
  }
  ASSERT_FALSE(r->removed_factors.empty());
  if (r->marginal) kept.push_back(r->marginal);

  KeyVector remaining;
  for (Key k : theta.keys()) {
    if (std::find(removed.begin(), removed.end(), k) == removed.end()) remaining.push_back(k);
  }
  KeyVector everything = remaining;
  everything.insert(everything.end(), removed.begin(), removed.end());
  const DenseSystem full = Dense(all, theta, everything);
  const DenseSystem reduced = Dense(kept, theta, remaining);
  const int n = reduced.column.back();
  const Eigen::MatrixXd full_cov = full.H.inverse().topLeftCorner(n, n);
  const Eigen::MatrixXd reduced_cov = reduced.H.inverse();
  EXPECT_LT((full_cov - reduced_cov).cwiseAbs().maxCoeff(), 1e-9 * full_cov.cwiseAbs().maxCoeff());
  const Eigen::VectorXd full_step = full.H.ldlt().solve(-full.g).head(n);
  const Eigen::VectorXd reduced_step = reduced.H.ldlt().solve(-reduced.g);
  EXPECT_LT((full_step - reduced_step).cwiseAbs().maxCoeff(),
            1e-9 * (1.0 + full_step.cwiseAbs().maxCoeff()));
  // Minimum of the linear model: |b|² − gᵀH⁻¹g, with |b|² the chi2 at θ.
  const double full_min = Chi2At(all, theta) + full.g.dot(full.H.ldlt().solve(-full.g));
  const double reduced_min = Chi2At(kept, theta) + reduced.g.dot(reduced_step);
  EXPECT_NEAR(reduced_min + r->constant_chi2, full_min, 1e-9 * Chi2At(all, theta));
  // The blanket is exactly the removed factors' other variables.
  std::set<Key> blanket;
  for (int i : r->removed_factors) {
    for (Key k : all[i]->keys()) {
      if (std::find(removed.begin(), removed.end(), k) == removed.end()) blanket.insert(k);
    }
  }
  EXPECT_EQ(std::set<Key>(r->blanket.begin(), r->blanket.end()), blanket);
}

// The same for `p`'s graph at its initial guess.
void ExpectExactRemoval(const ::slamd::testing::ExampleProblem& p, const KeyVector& removed) {
  ExpectExactRemoval(p.graph.factors(), p.initial, removed);
}

TEST(NodeRemovalTest, ConsecutivePosesAndALandmark) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(16, 3, 5);
  ExpectExactRemoval(p, {MakeKey('x', 3), MakeKey('x', 4), MakeKey('l', 1)});
}

TEST(NodeRemovalTest, TheAnchoredFirstPose) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(16, 3, 6);
  ExpectExactRemoval(p, {MakeKey('x', 0)});
}

// Random sets anywhere in the graph: scattered poses (several blankets in one container),
// landmarks, the newest pose, in 2D and 3D.
TEST(NodeRemovalTest, RandomSetsAnywhere) {
  for (unsigned seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE(seed);
    const ::slamd::testing::ExampleProblem p =
        seed % 2 ? ::slamd::testing::MakePlanarProblem(20, 4, seed)
                 : ::slamd::testing::MakeSpatialProblem(14, seed);
    std::mt19937 rng(seed);
    KeyVector keys = p.initial.keys();
    std::shuffle(keys.begin(), keys.end(), rng);
    keys.resize(1 + rng() % 5);
    ExpectExactRemoval(p, keys);
  }
}

// Removing a second set from what the first left (the container re-enters as a factor) is the
// same as removing both at once.
TEST(NodeRemovalTest, RepeatedRemovalComposes) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(16, 2, 9);
  const Values& theta = p.initial;
  const KeyVector first = {MakeKey('x', 5), MakeKey('x', 6)}, second = {MakeKey('x', 7)};
  const NodeRemoval a = MarginalizeOut(p.graph.factors(), theta, first).value();
  std::vector<FactorPtr> left;
  for (std::size_t i = 0; i < p.graph.size(); ++i) {
    if (std::find(a.removed_factors.begin(), a.removed_factors.end(), static_cast<int>(i)) ==
        a.removed_factors.end()) {
      left.push_back(p.graph.factors()[i]);
    }
  }
  left.push_back(a.marginal);
  const NodeRemoval b = MarginalizeOut(left, theta, second).value();
  const NodeRemoval both =
      MarginalizeOut(p.graph.factors(), theta, KeyVector{first[0], first[1], second[0]}).value();
  ASSERT_TRUE(b.marginal && both.marginal);
  EXPECT_NEAR(a.constant_chi2 + b.constant_chi2, both.constant_chi2,
              1e-9 * (1.0 + both.constant_chi2));
  const KeyVector& keys = both.blanket;
  const DenseSystem x = Dense({b.marginal}, theta, keys), y = Dense({both.marginal}, theta, keys);
  EXPECT_LT((x.H - y.H).cwiseAbs().maxCoeff(), 1e-9 * y.H.cwiseAbs().maxCoeff());
  EXPECT_LT((x.g - y.g).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + y.g.cwiseAbs().maxCoeff()));
}

// A Chow-Liu removal takes in an earlier tree's root-relative summary whose other variables are
// on its blanket though its root is not (the root joins the blanket), and leaves one with a
// variable off the blanket; its exact summary stays exact.
TEST(NodeRemovalTest, ChowLiuTakesInRootRelativeSummariesOnItsBlanket) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(16, 2, 4);
  const Values& theta = p.initial;
  const Key removed = MakeKey('x', 5), a = MakeKey('x', 4), b = MakeKey('x', 6);
  // Poses no factor of x5 reaches: the summaries' root, and a variable off the blanket.
  KeyVector off;
  for (int i = 9; i < 16; ++i) {
    const Key k = MakeKey('x', i);
    const bool adjacent =
        std::any_of(p.graph.factors().begin(), p.graph.factors().end(), [&](const FactorPtr& f) {
          const std::span<const Key> fk = f->keys();
          return std::count(fk.begin(), fk.end(), removed) > 0 &&
                 std::count(fk.begin(), fk.end(), k) > 0;
        });
    if (!adjacent) off.push_back(k);
  }
  ASSERT_GE(off.size(), 2u);
  const Key root = off[0], far = off[1];
  std::mt19937 rng(4);
  std::normal_distribution<double> n01(0.0, 1.0);
  const auto summary = [&](Key m0, Key m1) {
    const Eigen::MatrixXd A = 2.0 * Eigen::MatrixXd::Identity(6, 6) +
                              0.3 * Eigen::MatrixXd::NullaryExpr(6, 6, [&] { return n01(rng); });
    const Eigen::VectorXd rhs = Eigen::VectorXd::NullaryExpr(6, [&] { return 0.1 * n01(rng); });
    return LinearContainerFactor::CreateRootRelative(
               {m0, m1, root}, {theta.Get(m0), theta.Get(m1), theta.Get(root)}, A, rhs)
        .value();
  };
  std::vector<FactorPtr> all = p.graph.factors();
  const int on = static_cast<int>(all.size());
  all.push_back(summary(a, b));
  all.push_back(summary(a, far));
  NodeRemoval r;
  ExpectExactRemoval(all, theta, {removed}, {.form = NodeRemovalParams::Form::kChowLiu}, &r);
  const auto taken = [&](int f) {
    return std::count(r.removed_factors.begin(), r.removed_factors.end(), f) > 0;
  };
  EXPECT_TRUE(taken(on));
  EXPECT_FALSE(taken(on + 1));
  EXPECT_EQ(std::count(r.blanket.begin(), r.blanket.end(), root), 1);
  EXPECT_EQ(std::count(r.blanket.begin(), r.blanket.end(), far), 0);
  // The dense form takes in nothing it does not have to.
  NodeRemoval dense;
  ExpectExactRemoval(all, theta, {removed}, {}, &dense);
  EXPECT_EQ(std::count(dense.blanket.begin(), dense.blanket.end(), root), 0);
}

// The summary does not depend on where the factors are held (a recovery's solver holds them in
// other slots than the live one did): shuffled, the same blanket and bit for bit the same tree.
TEST(NodeRemovalTest, SummaryIsTheSameWhateverTheFactorOrder) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(30, 6, 12);
  const KeyVector removed = {MakeKey('x', 7), MakeKey('x', 8), MakeKey('x', 9), MakeKey('x', 10)};
  const NodeRemovalParams tree{.form = NodeRemovalParams::Form::kChowLiu,
                               .edge_frame = TreeEdgeFrame::kParent};
  std::vector<FactorPtr> factors = p.graph.factors();
  const NodeRemoval a = MarginalizeOut(factors, p.initial, removed, tree).value();
  std::mt19937 rng(12);
  std::shuffle(factors.begin(), factors.end(), rng);
  const NodeRemoval b = MarginalizeOut(factors, p.initial, removed, tree).value();
  EXPECT_EQ(a.blanket, b.blanket);
  ASSERT_EQ(a.summary.size(), b.summary.size());
  ASSERT_GE(a.summary.size(), 3u);
  for (std::size_t i = 0; i < a.summary.size(); ++i) {
    const auto& fa = static_cast<const LinearContainerFactor&>(*a.summary[i]);
    const auto& fb = static_cast<const LinearContainerFactor&>(*b.summary[i]);
    EXPECT_TRUE(std::equal(fa.keys().begin(), fa.keys().end(), fb.keys().begin(), fb.keys().end()));
    EXPECT_EQ(fa.A(), fb.A()) << i;
    EXPECT_EQ(fa.b(), fb.b()) << i;
  }
}

TEST(NodeRemovalTest, BadRequestsAreRefusedByName) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(8, 1, 3);
  const std::vector<FactorPtr> f = p.graph.factors();
  EXPECT_EQ(MarginalizeOut(f, p.initial, KeyVector{}).status().code(),
            StatusCode::kInvalidArgument);
  const Status unknown = MarginalizeOut(f, p.initial, KeyVector{MakeKey('x', 99)}).status();
  EXPECT_EQ(unknown.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(unknown.message().find("x99"), std::string::npos) << unknown.message();
  const Status twice =
      MarginalizeOut(f, p.initial, KeyVector{MakeKey('x', 2), MakeKey('x', 2)}).status();
  EXPECT_NE(twice.message().find("twice"), std::string::npos) << twice.message();
  const Status parents =
      MarginalizeOut(f, p.initial, KeyVector{MakeKey('x', 2)},
                     {.form = NodeRemovalParams::Form::kChowLiu, .tree_parents = 3})
          .status();
  EXPECT_EQ(parents.message(), "MarginalizeOut: tree_parents = 3; must be 1 or 2");

  // A variable no factor constrains, and one its factors leave undetermined (one row of
  // information on a 3-dof pose): a marginal over them does not exist.
  Values theta = p.initial;
  ASSERT_TRUE(theta.Insert(MakeKey('y', 0), Pose2(1, 2, 0.3)).ok());
  const Status lonely = MarginalizeOut(f, theta, KeyVector{MakeKey('y', 0)}).status();
  EXPECT_EQ(lonely.code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(lonely.message().find("y0"), std::string::npos) << lonely.message();
  std::vector<FactorPtr> g = f;
  g.push_back(LinearContainerFactor::Create({MakeKey('y', 0)}, {theta.Get(MakeKey('y', 0))},
                                            Eigen::MatrixXd::Identity(1, 3),
                                            Eigen::VectorXd::Zero(1))
                  .value());
  const Status weak = MarginalizeOut(g, theta, KeyVector{MakeKey('y', 0)}).status();
  EXPECT_EQ(weak.code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(weak.message().find("not determined"), std::string::npos) << weak.message();
}

}  // namespace
}  // namespace slamd::core
