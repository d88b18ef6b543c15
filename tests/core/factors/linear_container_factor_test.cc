#include "core/factors/linear_container_factor.h"

#include <gtest/gtest.h>

#include <random>

#include "tests/testing/factor_testing.h"
#include "tests/testing/random_values.h"

namespace slamd::core {
namespace {

using testing::kL;
using testing::kX;
const Key kC = MakeKey('c', 0);

struct Made {
  std::vector<Variable> x0;
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
};

Made Make(std::mt19937& rng) {
  Made m{{testing::RandomValue<Pose2>(rng), testing::RandomValue<Point3>(rng),
          testing::RandomValue<Cal3Bundler>(rng)},
         Eigen::MatrixXd::Random(5, 3 + 3 + 3),
         Eigen::VectorXd::Random(5)};
  return m;
}

TEST(LinearContainerFactorTest, FirstOrderRuleAwayFromTheLinearisationPoint) {
  std::mt19937 rng(3);
  const Made m = Make(rng);
  const FactorPtr f = LinearContainerFactor::Create({kX, kL, kC}, m.x0, m.A, m.b).value();
  EXPECT_EQ(f->dim(), 5);
  EXPECT_EQ(f->KeyType(0), kVariableType<Pose2>);
  EXPECT_EQ(f->KeyType(2), kVariableType<Cal3Bundler>);
  Values at_x0;
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(at_x0.Insert(f->keys()[k], m.x0[k]).ok());
  EXPECT_LT((f->Error(at_x0) - m.b).norm(), 1e-15);
  // Elsewhere: e(x) = A·(x₀ ⊖ x) + b, with that error's Jacobians (A only at x₀).
  Values x;
  Eigen::VectorXd stacked(9);
  for (int k = 0; k < 3; ++k) {
    const Variable v = k == 0   ? Variable(testing::RandomValue<Pose2>(rng))
                       : k == 1 ? Variable(testing::RandomValue<Point3>(rng))
                                : Variable(testing::RandomValue<Cal3Bundler>(rng));
    ASSERT_TRUE(x.Insert(f->keys()[k], v).ok());
    stacked.segment(3 * k, 3) = LocalCoordinates(m.x0[k], v);
  }
  EXPECT_LT((f->Error(x) - (m.A * stacked + m.b)).norm(), 1e-12);
  LinearizedFactor lf;
  f->Linearize(x, &lf);
  EXPECT_LT((lf.Rhs() - (m.A * stacked + m.b)).norm(), 1e-12);
  testing::ExpectJacobiansMatchNumerical(*f, x, 1e-6);
  f->Linearize(at_x0, &lf);
  EXPECT_LT((lf.Ab().leftCols(9) - m.A).norm(), 1e-12);
  EXPECT_NEAR(f->Chi2(x), (m.A * stacked + m.b).squaredNorm(), 1e-9);
}

TEST(LinearContainerFactorTest, CreateRefusesWhatDoesNotFit) {
  std::mt19937 rng(4);
  const Made m = Make(rng);
  auto refused = [&](KeyVector keys, std::vector<Variable> x0, Eigen::MatrixXd A, Eigen::VectorXd b,
                     const std::string& says) {
    const Status s = LinearContainerFactor::Create(keys, x0, A, b).status();
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(s.message().find(says), std::string::npos) << s.message();
  };
  refused({}, {}, m.A, m.b, "no keys");
  refused({kX, kX, kC}, m.x0, m.A, m.b, "twice");
  refused({kX, kL}, m.x0, m.A, m.b, "3 linearisation values");
  refused({kX, kL, kC}, m.x0, m.A.leftCols(8), m.b, "expected m x 9");
  refused({kX, kL, kC}, m.x0, m.A, Eigen::VectorXd::Zero(4), "expected m x 9");
  Eigen::MatrixXd nan = m.A;
  nan(2, 2) = std::numeric_limits<double>::quiet_NaN();
  refused({kX, kL, kC}, m.x0, nan, m.b, "NaN");
}

}  // namespace
}  // namespace slamd::core
