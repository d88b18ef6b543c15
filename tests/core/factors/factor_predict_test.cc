#include <gtest/gtest.h>

#include <cmath>

#include "core/factors/bearing_range_factor.h"
#include "core/factors/between_factor.h"
#include "core/factors/factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/relative_point_factor.h"
#include "tests/testing/factor_testing.h"

namespace slamd::core {
namespace {

using testing::kL;
using testing::kX;
const Key kY = MakeKey('x', 1);

// A prediction is where the factor's error vanishes.
void ExpectZeroError(const Factor& f, const Variable& a, const Variable& b) {
  Values v;
  ASSERT_TRUE(v.Insert(f.keys()[0], a).ok());
  ASSERT_TRUE(v.Insert(f.keys()[1], b).ok());
  EXPECT_LT(Eigen::VectorXd(f.Error(v)).norm(), 1e-12) << f.Name();
}

TEST(PredictTest, BetweenFactorsPredictEitherEnd) {
  std::mt19937 rng(5);
  const Pose2 x2 = testing::RandomPose2(rng);
  BetweenFactor<Pose2> f2(kX, kY, testing::RandomPose2(rng), NoiseModel::Unit(3));
  ExpectZeroError(f2, x2, *f2.Predict(0, x2));
  ExpectZeroError(f2, *f2.Predict(1, x2), x2);
  const Pose3 x3 = testing::RandomPose3(rng);
  BetweenFactor<Pose3> f3(kX, kY, testing::RandomPose3(rng), NoiseModel::Unit(6));
  ExpectZeroError(f3, x3, *f3.Predict(0, x3));
  ExpectZeroError(f3, *f3.Predict(1, x3), x3);
}

TEST(PredictTest, ObservationsPlaceTheLandmarkButNotThePose) {
  const Pose2 pose(1, 2, 0.7);
  RelativePointFactor<Pose2, Point2> rp(kX, kL, Point2(3, -1), NoiseModel::Unit(2));
  ExpectZeroError(rp, pose, *rp.Predict(0, pose));
  EXPECT_FALSE(rp.Predict(1, Point2(0, 0)).has_value());
  BearingRangeFactor br(kX, kL, 0.4, 5.0, NoiseModel::Unit(2));
  ExpectZeroError(br, pose, *br.Predict(0, pose));
  const Pose3 pose3(Rot3::FromRollPitchYaw(0.1, 0.2, 0.3), Point3(1, 2, 3));
  RelativePointFactor<Pose3, Point3> rp3(kX, kL, Point3(1, 0, 2), NoiseModel::Unit(3));
  ExpectZeroError(rp3, pose3, *rp3.Predict(0, pose3));
}

TEST(PredictTest, OtherFactorsPredictNothing) {
  PriorFactor<Pose2> prior(kX, Pose2(), NoiseModel::Unit(3));
  EXPECT_FALSE(prior.Predict(0, Pose2()).has_value());
}

}  // namespace
}  // namespace slamd::core
