// The dog leg on the Bayes tree (core/isam/dogleg.h) against the dense system it summarises, and
// Isam2 with its trust region (Isam2Params::trust_region).
#include "core/isam/dogleg.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "core/batch/batch_solver.h"
#include "core/isam/isam2.h"
#include "tests/testing/example_graphs.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

std::unique_ptr<Isam2> MakeTrustRegionIsam2(bool enabled) {
  Isam2Params params;
  params.trust_region.enabled = enabled;
  Result<std::unique_ptr<Isam2>> isam = Isam2::Create(params);
  EXPECT_TRUE(isam.ok()) << isam.status().ToString();
  return std::move(isam).value();
}

// The whitened Jacobian of every factor at the solver's linearisation point, with the columns in
// the solver's δ layout (variables by slot).
Eigen::MatrixXd DenseJacobian(const Isam2& isam, std::vector<int>* offsets) {
  const Values& theta = isam.linearization_point();
  offsets->assign(1, 0);
  for (int v = 0; v < static_cast<int>(theta.size()); ++v) {
    offsets->push_back(offsets->back() + TangentDim(theta.TypeAt(v)));
  }
  std::vector<JacobianFactor> rows;
  int num_rows = 0;
  for (const FactorPtr& f : isam.Factors()) {
    std::vector<int> ids;
    for (Key key : f->keys()) ids.push_back(theta.SlotOf(key));
    JacobianFactor& jf = rows.emplace_back();
    EXPECT_TRUE(jf.Linearize(*f, theta, ids).ok());
    num_rows += jf.rows();
  }
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(num_rows, offsets->back());
  int row = 0;
  for (const JacobianFactor& jf : rows) {
    for (int k = 0; k < jf.num_vars(); ++k) {
      a.block(row, (*offsets)[jf.var(k)], jf.rows(), jf.dim(k)) = jf.A(k);
    }
    row += jf.rows();
  }
  return a;
}

// A planar problem streamed pose by pose with full solves: the solver's tree, the dense Jacobian
// A at its linearisation point and its Gauss-Newton step δ, in the solver's δ layout.
struct SolvedProblem {
  std::unique_ptr<Isam2> isam;
  std::vector<int> offsets;
  Eigen::MatrixXd a;
  Eigen::VectorXd delta;
};

SolvedProblem SolvePlanarProblem(unsigned seed) {
  SolvedProblem out;
  const testing::ExampleProblem p = testing::MakePlanarProblem(25, 5, seed);
  out.isam = MakeTrustRegionIsam2(false);
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    EXPECT_TRUE(
        out.isam->Update(step.factors, step.values, {.force_full_solve = true}).status.ok());
  }
  out.a = DenseJacobian(*out.isam, &out.offsets);
  out.delta.resize(out.offsets.back());
  for (int v = 0; v + 1 < static_cast<int>(out.offsets.size()); ++v) {
    for (int j = out.offsets[v]; j < out.offsets[v + 1]; ++j) {
      out.delta[j] = out.isam->Delta(v)[j - out.offsets[v]];
    }
  }
  return out;
}

TEST(DoglegTest, GradientAndModelTermsAreThoseOfTheDenseSystem) {
  const SolvedProblem s = SolvePlanarProblem(11);
  const Isam2* isam = s.isam.get();
  const std::vector<int>& offsets = s.offsets;
  const Eigen::MatrixXd& a = s.a;
  const Eigen::VectorXd& delta = s.delta;
  const int n = offsets.back();
  // The Gauss-Newton step δ solves RᵀR δ = Rᵀd with RᵀR = AᵀA: so Rᵀd = AᵀA δ, and for any v
  // dᵀRv = δᵀAᵀA v, |Rv|² = |Av|², whatever the sign convention of b.
  std::vector<double> scratch;
  Eigen::VectorXd g;
  const TopDownCliques cliques(isam->tree());
  TreeGradient(cliques, offsets, nullptr, &g, &scratch);
  const Eigen::VectorXd expected_g = a.transpose() * (a * delta);
  EXPECT_LT((g - expected_g).norm(), 1e-8 * expected_g.norm());

  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  Eigen::VectorXd v(n);
  for (int j = 0; j < n; ++j) v[j] = normal(rng);
  // The terms of one vector: those of the pair (v, v) at (1, 0).
  const auto terms_of = [&](const Eigen::VectorXd& x) {
    return ModelTermsOfPair(cliques, offsets, nullptr, x, x, &scratch).Of(1.0, 0.0);
  };
  const TreeModelTerms terms = terms_of(v);
  EXPECT_NEAR(terms.quadratic, (a * v).squaredNorm(), 1e-8 * terms.quadratic);
  const double linear = (a * delta).dot(a * v);
  EXPECT_NEAR(terms.linear, linear, 1e-8 * std::abs(linear) + 1e-9);
  // The model's decrease is largest at the Gauss-Newton step, where it is |Rδ|².
  const TreeModelTerms at_gn = terms_of(delta);
  EXPECT_NEAR(at_gn.Decrease(), (a * delta).squaredNorm(), 1e-8 * at_gn.quadratic);
  EXPECT_GT(at_gn.Decrease(), terms_of(0.5 * delta).Decrease());
  // The pair's terms give those of any combination as its own pass does.
  const TreeModelPair pair = ModelTermsOfPair(cliques, offsets, nullptr, delta, v, &scratch);
  for (const auto& [alpha, beta] : {std::pair{1.0, 0.0}, {0.0, 1.0}, {0.3, -2.0}, {1.5, 0.7}}) {
    const TreeModelTerms direct = terms_of(alpha * delta + beta * v);
    const TreeModelTerms combined = pair.Of(alpha, beta);
    EXPECT_NEAR(combined.quadratic, direct.quadratic, 1e-10 * direct.quadratic) << alpha;
    EXPECT_NEAR(combined.linear, direct.linear, 1e-10 * (std::abs(direct.linear) + 1.0)) << alpha;
  }
}

// Around a start p (the estimate before an update): the gradient Rᵀ(d − R p) and the terms
// (d − R p)ᵀ R v against the dense system: Rᵀd = AᵀA δ for the Gauss-Newton step δ, so these are
// AᵀA (δ − p) and (A (δ − p))ᵀ A v.
TEST(DoglegTest, AroundAStartTheGradientAndTermsAreThoseOfTheDenseSystem) {
  const SolvedProblem s = SolvePlanarProblem(13);
  const std::vector<int>& offsets = s.offsets;
  const Eigen::MatrixXd& a = s.a;
  const Eigen::VectorXd& delta = s.delta;
  const int n = offsets.back();
  std::mt19937 rng(5);
  std::normal_distribution<double> normal;
  Eigen::VectorXd start(n), v(n);
  for (int j = 0; j < n; ++j) {
    start[j] = 0.1 * normal(rng);
    v[j] = normal(rng);
  }
  std::vector<double> scratch;
  Eigen::VectorXd g;
  const TopDownCliques cliques(s.isam->tree());
  TreeGradient(cliques, offsets, &start, &g, &scratch);
  const Eigen::VectorXd expected_g = a.transpose() * (a * (delta - start));
  EXPECT_LT((g - expected_g).norm(), 1e-8 * expected_g.norm());
  const TreeModelPair pair = ModelTermsOfPair(cliques, offsets, &start, delta - start, v, &scratch);
  EXPECT_NEAR(pair.bb, (a * v).squaredNorm(), 1e-8 * pair.bb);
  const double linear = (a * (delta - start)).dot(a * v);
  EXPECT_NEAR(pair.db, linear, 1e-8 * std::abs(linear) + 1e-9);
  // From the start, the Gauss-Newton step's decrease is the model's whole decrease to its
  // minimum: |A (δ − p)|².
  const double to_minimum = (a * (delta - start)).squaredNorm();
  EXPECT_NEAR(pair.Of(1.0, 0.0).Decrease(), to_minimum, 1e-8 * to_minimum);
}

// Which slots the cliques take depends on the free list's history (trimmed at rest or not); the
// dog leg's sums over cliques must not, or a replay that trimmed at other times would differ.
TEST(DoglegTest, TheStepDoesNotDependOnWhichSlotsTheCliquesTook) {
  const testing::ExampleProblem p = testing::MakePlanarProblem(40, 8, 5);
  std::unique_ptr<Isam2> plain = MakeTrustRegionIsam2(true), trimmed = MakeTrustRegionIsam2(true);
  bool slots_differ = false;
  for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
    // Every update re-eliminates the whole tree into freed slots.
    ASSERT_TRUE(plain->Update(step.factors, step.values, {.force_full = true}).status.ok());
    ASSERT_TRUE(trimmed->Update(step.factors, step.values, {.force_full = true}).status.ok());
    trimmed->TrimMemory();  // its freed slots hold nothing: the next cliques take others
    for (int v = 0; v < plain->tree().NumVariables(); ++v) {
      slots_differ = slots_differ || plain->tree().CliqueOf(v) != trimmed->tree().CliqueOf(v);
    }
    // The gradient and the model's terms, summed over cliques, bitwise the same.
    std::vector<int> offsets;
    DenseJacobian(*plain, &offsets);  // for the offsets
    std::vector<double> scratch;
    Eigen::VectorXd g_plain, g_trimmed;
    TreeGradient(TopDownCliques(plain->tree()), offsets, nullptr, &g_plain, &scratch);
    TreeGradient(TopDownCliques(trimmed->tree()), offsets, nullptr, &g_trimmed, &scratch);
    ASSERT_EQ((g_plain - g_trimmed).cwiseAbs().maxCoeff(), 0.0) << plain->num_updates();
    const TreeModelPair m_plain = ModelTermsOfPair(TopDownCliques(plain->tree()), offsets, nullptr,
                                                   g_plain, g_trimmed, &scratch);
    const TreeModelPair m_trimmed = ModelTermsOfPair(TopDownCliques(trimmed->tree()), offsets,
                                                     nullptr, g_plain, g_trimmed, &scratch);
    ASSERT_EQ(m_plain.aa, m_trimmed.aa);
    ASSERT_EQ(m_plain.ab, m_trimmed.ab);
    ASSERT_EQ(m_plain.da, m_trimmed.da);
    const Values a = plain->CalculateEstimate(), b = trimmed->CalculateEstimate();
    ASSERT_EQ(a.size(), b.size());
    for (int v = 0; v < static_cast<int>(a.size()); ++v) {
      ASSERT_EQ(LocalCoordinates(a.VariableAt(v), b.VariableAt(v)).cwiseAbs().maxCoeff(), 0.0)
          << "variable " << v << " after " << plain->num_updates() << " updates";
    }
  }
  EXPECT_TRUE(slots_differ) << "the test did not exercise different slots";
}

TEST(DoglegTest, PointsLieOnThePathAtTheRadius) {
  const Eigen::Vector3d gn(4.0, 0.0, 0.0), cauchy(1.0, 1.0, 0.0);
  Eigen::VectorXd step;
  DoglegPoint(gn, cauchy, 10.0, &step);  // the Gauss-Newton step within the radius
  EXPECT_EQ(step, Eigen::VectorXd(gn));
  EXPECT_EQ(DoglegPoint(gn, cauchy, 0.5, &step).on_gauss_newton, 0.0);  // along the gradient
  EXPECT_NEAR(step.norm(), 0.5, 1e-12);
  EXPECT_NEAR(step[0], step[1], 1e-12);
  const DoglegWeights w = DoglegPoint(gn, cauchy, 3.0, &step);  // on the second leg, at the radius
  EXPECT_LT((step - (w.on_gauss_newton * gn + w.on_cauchy * cauchy)).norm(), 1e-12);
  EXPECT_NEAR(step.norm(), 3.0, 1e-12);
  const Eigen::Vector3d leg = gn - cauchy;
  const double tau = (step - cauchy).dot(leg) / leg.squaredNorm();
  EXPECT_GT(tau, 0.0);
  EXPECT_LT(tau, 1.0);
  EXPECT_LT((step - cauchy - tau * leg).norm(), 1e-12);
}

TEST(Isam2TrustRegionTest, SettlesToTheBatchOptimumLikeGaussNewton) {
  for (const bool planar : {true, false}) {
    const testing::ExampleProblem p =
        planar ? testing::MakePlanarProblem(40, 8, 5) : testing::MakeSpatialProblem(30, 5);
    std::unique_ptr<Isam2> isam = MakeTrustRegionIsam2(true);
    for (const testing::ExampleStep& step : testing::StreamByPose(p)) {
      const Isam2Result r = isam->Update(step.factors, step.values);
      ASSERT_TRUE(r.status.ok()) << r.status.ToString();
      EXPECT_GE(r.trust_region.attempts, 1);
      EXPECT_GT(r.trust_region.radius, 0.0);
    }
    for (int k = 0; k < 20; ++k)
      ASSERT_TRUE(isam->Update({}, {}, {.force_full = true}).status.ok());
    const BatchResult batch = Optimize(p.graph, p.initial, {.relative_tolerance = 1e-12});
    ASSERT_TRUE(batch.status.ok());
    EXPECT_NEAR(isam->Chi2(), batch.summary.final_chi2, 1e-4 * batch.summary.final_chi2);
    EXPECT_LT(testing::MaxDifference(isam->CalculateEstimate(), batch.values), 1e-4);
  }
}

}  // namespace
}  // namespace slamd::core
