#include "core/factors/position_prior_factor.h"

#include <gtest/gtest.h>

#include "tests/testing/factor_testing.h"

namespace slamd::core {
namespace {

using testing::kX;

TEST(PositionPriorFactorTest, IgnoresOrientation) {
  PositionPriorFactor<Pose2> f(kX, Point2(1, 2), NoiseModel::Unit(2));
  Values v;
  ASSERT_TRUE(v.Insert(kX, Pose2(1, 2, 2.5)).ok());
  EXPECT_NEAR(f.Chi2(v), 0.0, 1e-20);
  ASSERT_TRUE(v.Update(kX, Pose2(2, 2, -1.0)).ok());
  EXPECT_NEAR(f.Chi2(v), 1.0, 1e-12);
}

TEST(PositionPriorFactorTest, JacobiansMatchNumerical) {
  std::mt19937 rng(41);
  for (int trial = 0; trial < 30; ++trial) {
    PositionPriorFactor<Pose2> f2(kX, Point2(1, -1), *NoiseModel::FromCovariance(testing::RandomSpd(rng, 2)));
    Values v2;
    ASSERT_TRUE(v2.Insert(kX, testing::RandomPose2(rng)).ok());
    testing::ExpectJacobiansMatchNumerical(f2, v2);
    PositionPriorFactor<Pose3> f3(kX, Point3(1, -1, 2), *NoiseModel::FromCovariance(testing::RandomSpd(rng, 3)));
    Values v3;
    ASSERT_TRUE(v3.Insert(kX, testing::RandomPose3(rng)).ok());
    testing::ExpectJacobiansMatchNumerical(f3, v3, 1e-6);
  }
}

}  // namespace
}  // namespace slamd::core
