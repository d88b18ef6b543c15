#include "core/factors/between_factor.h"

#include <gtest/gtest.h>

#include "tests/testing/factor_testing.h"

namespace slamd::core {
namespace {

const Key kX1 = MakeKey('x', 1), kX2 = MakeKey('x', 2);

TEST(BetweenFactorTest, Pose2ErrorIsChartOfRelativeError) {
  const Pose2 z(1.0, 0.5, 0.2);
  BetweenFactor<Pose2> f(kX1, kX2, z, NoiseModel::Unit(3));
  Values v;
  ASSERT_TRUE(v.Insert(kX1, Pose2(0.3, -0.1, 0.4)).ok());
  ASSERT_TRUE(v.Insert(kX2, Pose2(0.3, -0.1, 0.4).Compose(z)).ok());
  EXPECT_TRUE(Eigen::VectorXd(f.Error(v)).isZero(1e-12));
  // Perturbing x2 on the right by (dx, dy, dθ) gives error (dx, dy, dθ) (GTSAM/g2o chart).
  ASSERT_TRUE(v.Update(kX2, v.At<Pose2>(kX2).Compose(Pose2(0.1, 0.2, 0.3))).ok());
  EXPECT_TRUE(Eigen::VectorXd(f.Error(v)).isApprox(Eigen::Vector3d(0.1, 0.2, 0.3), 1e-12));
}

// A factor's one or two keys are kept inside the factor object: no heap block of their own
// for each of the graph's factors (32 bytes a factor with glibc's allocator).
TEST(BetweenFactorTest, KeysAreInsideTheFactor) {
  const BetweenFactor<Pose2> f(kX1, kX2, Pose2(1.0, 0.0, 0.0), NoiseModel::Unit(3));
  ASSERT_EQ(ToKeyVector(f.keys()), (KeyVector{kX1, kX2}));
  const auto* begin = reinterpret_cast<const char*>(&f);
  const auto* keys = reinterpret_cast<const char*>(f.keys().data());
  EXPECT_TRUE(keys >= begin && keys < begin + sizeof(f));
}

TEST(BetweenFactorTest, Pose2JacobiansMatchNumerical) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    const NoiseModel noise = *NoiseModel::FromCovariance(testing::RandomSpd(rng, 3));
    BetweenFactor<Pose2> f(kX1, kX2, testing::RandomPose2(rng), noise);
    Values v;
    ASSERT_TRUE(v.Insert(kX1, testing::RandomPose2(rng)).ok());
    ASSERT_TRUE(v.Insert(kX2, testing::RandomPose2(rng)).ok());
    // Stay away from the θ = ±π wrap of the error, where finite differences straddle the cut.
    if (std::abs(f.Error(v)[2]) > 3.0) continue;
    testing::ExpectJacobiansMatchNumerical(f, v);
  }
}

TEST(BetweenFactorTest, Pose3JacobiansMatchNumerical) {
  std::mt19937 rng(12);
  for (int trial = 0; trial < 50; ++trial) {
    const NoiseModel noise = *NoiseModel::FromCovariance(testing::RandomSpd(rng, 6));
    BetweenFactor<Pose3> f(kX1, kX2, testing::RandomPose3(rng), noise);
    Values v;
    ASSERT_TRUE(v.Insert(kX1, testing::RandomPose3(rng)).ok());
    ASSERT_TRUE(v.Insert(kX2, testing::RandomPose3(rng)).ok());
    testing::ExpectJacobiansMatchNumerical(f, v, 1e-6);
  }
}

TEST(BetweenFactorTest, Pose3ErrorIsLogOfRelativeError) {
  std::mt19937 rng(13);
  const Pose3 a = testing::RandomPose3(rng), z = testing::RandomPose3(rng);
  BetweenFactor<Pose3> f(kX1, kX2, z, NoiseModel::Unit(6));
  Values v;
  ASSERT_TRUE(v.Insert(kX1, a).ok());
  Vector6 xi;
  xi << 0.1, -0.2, 0.05, 0.02, 0.03, -0.04;
  ASSERT_TRUE(v.Insert(kX2, a.Compose(z).Compose(Pose3::Exp(xi))).ok());
  EXPECT_TRUE(Eigen::VectorXd(f.Error(v)).isApprox(xi, 1e-10));
  EXPECT_NEAR(f.Chi2(v), xi.squaredNorm(), 1e-12);
}

TEST(BetweenFactorTest, RobustKernelScalesResidualAndJacobians) {
  const RobustKernel cauchy = *RobustKernel::Create(RobustKernel::Kind::kCauchy, 0.5);
  BetweenFactor<Pose2> plain(kX1, kX2, Pose2(1, 0, 0), NoiseModel::Unit(3));
  BetweenFactor<Pose2> robust(kX1, kX2, Pose2(1, 0, 0), NoiseModel::Unit(3), cauchy);
  Values v;
  ASSERT_TRUE(v.Insert(kX1, Pose2()).ok());
  ASSERT_TRUE(v.Insert(kX2, Pose2(3, 1, 0.5)).ok());
  LinearizedFactor a, b;
  plain.Linearize(v, &a);
  robust.Linearize(v, &b);
  const double s = plain.Chi2(v);
  const double sqrt_w = std::sqrt(cauchy.Weight(s));
  EXPECT_TRUE((Eigen::VectorXd(b.Rhs()) - sqrt_w * Eigen::VectorXd(a.Rhs())).isZero(1e-12));
  EXPECT_TRUE((Eigen::MatrixXd(b.Block(1)) - sqrt_w * Eigen::MatrixXd(a.Block(1))).isZero(1e-12));
  EXPECT_NEAR(robust.Cost(v), cauchy.Cost(s), 1e-12);
  EXPECT_NEAR(robust.Chi2(v), s, 1e-12);
}

}  // namespace
}  // namespace slamd::core
