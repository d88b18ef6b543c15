#include "core/factors/linear_container_factor.h"

#include <gtest/gtest.h>

#include <random>

#include "core/factors/factor_registry.h"
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

// The root-relative form: each variable taken in the root's frame, so one rigid motion of all of
// them leaves the error as it was, however large; Jacobians against finite differences away from
// x₀ (the root's columns from every other variable's), and refusals of what it cannot relate.
template <typename Pose, typename Point>
void ExpectRootRelativeForm(std::mt19937& rng, const Pose& motion) {
  const Key root = MakeKey('x', 9);
  const std::vector<Variable> x0 = {
      testing::RandomValue<Pose>(rng), testing::RandomValue<Point>(rng),
      testing::RandomValue<Cal3Bundler>(rng), testing::RandomValue<Pose>(rng)};
  const int columns = Pose::kDim + static_cast<int>(Point::RowsAtCompileTime) + 3;
  const Eigen::MatrixXd A = Eigen::MatrixXd::Random(7, columns);
  const Eigen::VectorXd b = Eigen::VectorXd::Random(7);
  const FactorPtr f =
      LinearContainerFactor::CreateRootRelative({kX, kL, kC, root}, x0, A, b).value();
  Values at_x0, x, moved;
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(at_x0.Insert(f->keys()[k], x0[k]).ok());
  EXPECT_LT((f->Error(at_x0) - b).norm(), 1e-12);
  const Pose p = testing::RandomValue<Pose>(rng), r = testing::RandomValue<Pose>(rng);
  const Point l = testing::RandomValue<Point>(rng);
  const Cal3Bundler c = testing::RandomValue<Cal3Bundler>(rng);
  ASSERT_TRUE(x.Insert(kX, p).ok() && x.Insert(kL, l).ok() && x.Insert(kC, c).ok() &&
              x.Insert(root, r).ok());
  ASSERT_TRUE(moved.Insert(kX, motion * p).ok() && moved.Insert(kL, motion.TransformFrom(l)).ok() &&
              moved.Insert(kC, c).ok() && moved.Insert(root, motion * r).ok());
  EXPECT_LT((f->Error(moved) - f->Error(x)).norm(), 1e-9 * (1.0 + f->Error(x).norm()));
  testing::ExpectJacobiansMatchNumerical(*f, x, 1e-6);
  // At x₀ the coordinates are the plain ones: A on the other variables.
  LinearizedFactor lf;
  f->Linearize(at_x0, &lf);
  EXPECT_LT((lf.Ab().leftCols(columns) - A).norm(), 1e-9);
  // A record round trip keeps the form (told apart by A's width).
  const FactorPtr again = DecodeFactor(EncodeFactor(*f)).value();
  EXPECT_TRUE(static_cast<const LinearContainerFactor&>(*again).root_relative());
  EXPECT_LT((again->Error(x) - f->Error(x)).norm(), 1e-12);
}

TEST(LinearContainerFactorTest, RootRelativeFormFollowsRigidMotions) {
  std::mt19937 rng(5);
  ExpectRootRelativeForm<Pose2, Point2>(rng, Pose2(30.0, -12.0, 2.1));
  Vector6 xi;
  xi << 20.0, -5.0, 8.0, 0.4, -1.1, 0.7;
  ExpectRootRelativeForm<Pose3, Point3>(rng, Pose3::Exp(xi));
}

TEST(LinearContainerFactorTest, RootRelativeFormRefusesWhatItCannotRelate) {
  std::mt19937 rng(6);
  const Eigen::MatrixXd A = Eigen::MatrixXd::Random(4, 3);
  const Eigen::VectorXd b = Eigen::VectorXd::Random(4);
  const auto refused = [&](std::vector<Variable> x0, const std::string& says) {
    const Status s = LinearContainerFactor::CreateRootRelative({kX, kL}, x0, A, b).status();
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(s.message().find(says), std::string::npos) << s.message();
  };
  refused({testing::RandomValue<Pose2>(rng), testing::RandomValue<Point2>(rng)},
          "a Pose2 or Pose3, not a Point2");
  refused({testing::RandomValue<Point3>(rng), testing::RandomValue<Pose2>(rng)},
          "a Point3 relative to a Pose2 root");
  // A with columns for the root too is the plain form's width, not this one's.
  EXPECT_FALSE(LinearContainerFactor::CreateRootRelative(
                   {kX, kL}, {testing::RandomValue<Pose2>(rng), testing::RandomValue<Pose2>(rng)},
                   Eigen::MatrixXd::Random(4, 6), b)
                   .ok());
}

}  // namespace
}  // namespace slamd::core
