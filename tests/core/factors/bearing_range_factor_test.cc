#include "core/factors/bearing_range_factor.h"

#include <gtest/gtest.h>

#include "tests/testing/factor_testing.h"

namespace slamd::core {
namespace {

using testing::kL;
using testing::kX;

TEST(BearingRangeFactorTest, ZeroErrorForConsistentMeasurement) {
  // A pose at the origin facing +y sees (−1, 1) at 45° to its left... i.e. bearing +π/4, range √2.
  BearingRangeFactor f(kX, kL, M_PI / 4, std::sqrt(2.0), NoiseModel::Unit(2));
  Values v;
  ASSERT_TRUE(v.Insert(kX, Pose2(0, 0, M_PI / 2)).ok());
  ASSERT_TRUE(v.Insert(kL, Point2(-1, 1)).ok());
  EXPECT_TRUE(Eigen::VectorXd(f.Error(v)).isZero(1e-12));
}

TEST(BearingRangeFactorTest, BearingErrorIsWrapped) {
  BearingRangeFactor f(kX, kL, M_PI - 0.01, 1.0, NoiseModel::Unit(2));
  Values v;
  ASSERT_TRUE(v.Insert(kX, Pose2()).ok());
  ASSERT_TRUE(v.Insert(kL, Point2(std::cos(-M_PI + 0.01), std::sin(-M_PI + 0.01))).ok());
  EXPECT_NEAR(f.Error(v)[0], 0.02, 1e-9);
}

TEST(BearingRangeFactorTest, JacobiansMatchNumerical) {
  std::mt19937 rng(51);
  std::uniform_real_distribution<double> u(-5, 5);
  for (int trial = 0; trial < 40; ++trial) {
    BearingRangeFactor f(kX, kL, u(rng) * 0.3, std::abs(u(rng)),
                         *NoiseModel::FromCovariance(testing::RandomSpd(rng, 2)));
    Values v;
    ASSERT_TRUE(v.Insert(kX, testing::RandomPose2(rng)).ok());
    ASSERT_TRUE(v.Insert(kL, Point2(u(rng), u(rng))).ok());
    if (std::abs(f.Error(v)[0]) > 3.0) continue;  // away from the wrap
    testing::ExpectJacobiansMatchNumerical(f, v);
  }
}

TEST(BearingRangeFactorTest, ZeroRangeGivesFiniteLinearization) {
  BearingRangeFactor f(kX, kL, 0.0, 1.0, NoiseModel::Unit(2));
  Values v;
  ASSERT_TRUE(v.Insert(kX, Pose2(1, 1, 0)).ok());
  ASSERT_TRUE(v.Insert(kL, Point2(1, 1)).ok());
  LinearizedFactor lf;
  f.Linearize(v, &lf);
  EXPECT_TRUE(Eigen::VectorXd(lf.Rhs()).allFinite());
  EXPECT_TRUE(Eigen::MatrixXd(lf.Block(0)).allFinite());
}

}  // namespace
}  // namespace slamd::core
