#include "core/factors/relative_point_factor.h"

#include <gtest/gtest.h>

#include "tests/testing/factor_testing.h"

namespace slamd::core {
namespace {

using testing::kL;
using testing::kX;

TEST(RelativePointFactorTest, ErrorIsLandmarkInPoseFrameMinusMeasurement) {
  RelativePointFactor<Pose2, Point2> f(kX, kL, Point2(1, 0), NoiseModel::Unit(2));
  Values v;
  ASSERT_TRUE(v.Insert(kX, Pose2(0, 0, M_PI / 2)).ok());
  ASSERT_TRUE(v.Insert(kL, Point2(0, 1)).ok());  // straight ahead of a pose facing +y
  EXPECT_TRUE(Eigen::VectorXd(f.Error(v)).isZero(1e-12));
}

TEST(RelativePointFactorTest, JacobiansMatchNumerical) {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> u(-5, 5);
  for (int trial = 0; trial < 30; ++trial) {
    RelativePointFactor<Pose2, Point2> f2(kX, kL, Point2(u(rng), u(rng)),
                                          *NoiseModel::FromCovariance(testing::RandomSpd(rng, 2)));
    Values v2;
    ASSERT_TRUE(v2.Insert(kX, testing::RandomPose2(rng)).ok());
    ASSERT_TRUE(v2.Insert(kL, Point2(u(rng), u(rng))).ok());
    testing::ExpectJacobiansMatchNumerical(f2, v2);

    RelativePointFactor<Pose3, Point3> f3(kX, kL, Point3(u(rng), u(rng), u(rng)),
                                          *NoiseModel::FromCovariance(testing::RandomSpd(rng, 3)));
    Values v3;
    ASSERT_TRUE(v3.Insert(kX, testing::RandomPose3(rng)).ok());
    ASSERT_TRUE(v3.Insert(kL, Point3(u(rng), u(rng), u(rng))).ok());
    testing::ExpectJacobiansMatchNumerical(f3, v3, 1e-6);
  }
}

}  // namespace
}  // namespace slamd::core
