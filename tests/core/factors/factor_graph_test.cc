#include "core/factors/factor_graph.h"

#include <gtest/gtest.h>

#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"

namespace slamd::core {
namespace {

TEST(FactorGraphTest, Chi2IsTheSumOfSquaredWhitenedResiduals) {
  const Key a = MakeKey('x', 0), b = MakeKey('x', 1);
  FactorGraph g;
  g.Emplace<PriorFactor<Pose2>>(a, Pose2(), *NoiseModel::Isotropic(3, 0.5));
  g.Emplace<BetweenFactor<Pose2>>(a, b, Pose2(1, 0, 0), *NoiseModel::Isotropic(3, 0.1));
  Values v;
  ASSERT_TRUE(v.Insert(a, Pose2(0.5, 0, 0)).ok());
  ASSERT_TRUE(v.Insert(b, Pose2(1.5, 0.1, 0)).ok());
  ASSERT_TRUE(g.CheckAgainst(v).ok());
  // Prior: (0.5/0.5)² = 1. Between: relative (1, 0.1, 0) vs (1, 0, 0): (0.1/0.1)² = 1.
  EXPECT_NEAR(g.Chi2(v), 2.0, 1e-12);
  EXPECT_NEAR(g.Cost(v), 2.0, 1e-12);
}

TEST(FactorGraphTest, CheckAgainstNamesMissingKeyAndWrongType) {
  const Key a = MakeKey('x', 0), b = MakeKey('x', 1);
  FactorGraph g;
  g.Emplace<BetweenFactor<Pose2>>(a, b, Pose2(1, 0, 0), NoiseModel::Unit(3));
  Values v;
  ASSERT_TRUE(v.Insert(a, Pose2()).ok());
  Status s = g.CheckAgainst(v);
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_NE(s.message().find("x1"), std::string::npos);
  ASSERT_TRUE(v.Insert(b, Point2(0, 0)).ok());
  s = g.CheckAgainst(v);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("Point2"), std::string::npos);
  EXPECT_NE(s.message().find("BetweenPose2"), std::string::npos);
}

}  // namespace
}  // namespace slamd::core
