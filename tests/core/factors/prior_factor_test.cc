#include "core/factors/prior_factor.h"

#include <gtest/gtest.h>

#include "tests/testing/factor_testing.h"

namespace slamd::core {
namespace {

using testing::kX;

TEST(PriorFactorTest, JacobiansMatchNumericalForEveryType) {
  std::mt19937 rng(21);
  for (int trial = 0; trial < 30; ++trial) {
    {
      PriorFactor<Pose2> f(kX, testing::RandomPose2(rng),
                           *NoiseModel::FromCovariance(testing::RandomSpd(rng, 3)));
      Values v;
      ASSERT_TRUE(v.Insert(kX, testing::RandomPose2(rng)).ok());
      if (std::abs(f.Error(v)[2]) < 3.0) testing::ExpectJacobiansMatchNumerical(f, v);
    }
    {
      PriorFactor<Pose3> f(kX, testing::RandomPose3(rng),
                           *NoiseModel::FromCovariance(testing::RandomSpd(rng, 6)));
      Values v;
      ASSERT_TRUE(v.Insert(kX, testing::RandomPose3(rng)).ok());
      testing::ExpectJacobiansMatchNumerical(f, v, 1e-6);
    }
    {
      PriorFactor<Point2> f(kX, Point2(1, 2), *NoiseModel::FromCovariance(testing::RandomSpd(rng, 2)));
      Values v;
      ASSERT_TRUE(v.Insert(kX, Point2(-1, 0.5)).ok());
      testing::ExpectJacobiansMatchNumerical(f, v);
    }
    {
      PriorFactor<Point3> f(kX, Point3(1, 2, 3), *NoiseModel::FromCovariance(testing::RandomSpd(rng, 3)));
      Values v;
      ASSERT_TRUE(v.Insert(kX, Point3(-1, 0.5, 2)).ok());
      testing::ExpectJacobiansMatchNumerical(f, v);
    }
  }
}

TEST(PriorFactorTest, ZeroAtTheMeasurementAndChi2IsMahalanobis) {
  const NoiseModel noise = *NoiseModel::Diagonal(Eigen::Vector3d(0.1, 0.1, 0.01));
  PriorFactor<Pose2> f(kX, Pose2(1, 2, 0.5), noise);
  Values v;
  ASSERT_TRUE(v.Insert(kX, Pose2(1, 2, 0.5)).ok());
  EXPECT_NEAR(f.Chi2(v), 0.0, 1e-20);
  ASSERT_TRUE(v.Update(kX, Pose2(1, 2, 0.5).Compose(Pose2(0.1, 0, 0.01))).ok());
  EXPECT_NEAR(f.Chi2(v), 1.0 + 1.0, 1e-9);
}

}  // namespace
}  // namespace slamd::core
