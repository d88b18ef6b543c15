// RobustifyLoopClosures: which factors are loop closures, that exactly they get the kernel, and
// the KERNEL[:PARAM] parser.
#include "clients/slamctl/robustify.h"

#include <gtest/gtest.h>

#include "core/factors/between_factor.h"
#include "core/factors/relative_point_factor.h"

namespace slamd::clients {
namespace {

using core::MakeKey;
using core::NoiseModel;
using core::Pose2;
using core::Pose3;
using core::RobustKernel;

core::FactorGraph MixedGraph() {
  core::FactorGraph g;
  const NoiseModel n3 = NoiseModel::Unit(3);
  g.Emplace<core::BetweenFactor<Pose2>>(MakeKey('x', 0), MakeKey('x', 1), Pose2(1, 0, 0), n3);  // odometry
  g.Emplace<core::BetweenFactor<Pose2>>(MakeKey('x', 2), MakeKey('x', 1), Pose2(-1, 0, 0), n3);  // reversed odometry
  g.Emplace<core::BetweenFactor<Pose2>>(MakeKey('x', 0), MakeKey('x', 5), Pose2(1, 1, 0), n3);  // loop
  g.Emplace<core::BetweenFactor<Pose2>>(MakeKey('x', 3, 'a'), MakeKey('x', 4, 'b'), Pose2(), n3);  // inter-robot
  g.Emplace<core::BetweenFactor<Pose3>>(MakeKey('x', 7), MakeKey('x', 9), Pose3(), NoiseModel::Unit(6));  // 3D loop
  g.Emplace<core::RelativePointFactor<Pose2, core::Point2>>(MakeKey('x', 0), MakeKey('l', 9), core::Point2(1, 1),
                                                            NoiseModel::Unit(2));  // observation
  g.Emplace<core::PriorFactor<Pose2>>(MakeKey('x', 0), Pose2(), n3);
  return g;
}

TEST(RobustifyTest, OnlyLoopClosuresGetTheKernel) {
  const core::FactorGraph g = MixedGraph();
  const RobustKernel cauchy = *RobustKernel::Create(RobustKernel::Kind::kCauchy, 1.5);
  std::size_t count = 0;
  const core::FactorGraph r = RobustifyLoopClosures(g, cauchy, &count);
  EXPECT_EQ(count, 3u);
  ASSERT_EQ(r.size(), g.size());
  const bool expected_loop[] = {false, false, true, true, true, false, false};
  for (std::size_t i = 0; i < g.size(); ++i) {
    EXPECT_EQ(IsLoopClosure(*g[i]), expected_loop[i]) << i;
    EXPECT_EQ(core::ToKeyVector(r[i]->keys()), core::ToKeyVector(g[i]->keys())) << i;
    EXPECT_STREQ(r[i]->Name(), g[i]->Name()) << i;
    if (expected_loop[i]) {
      EXPECT_EQ(r[i]->robust_kernel().kind(), RobustKernel::Kind::kCauchy) << i;
      EXPECT_EQ(r[i]->robust_kernel().parameter(), 1.5);
    } else {
      EXPECT_EQ(r[i], g[i]) << i << ": non-loop factors are shared unchanged";
    }
  }
  // Same measurement and noise: chi2 agrees at any values, the cost follows the kernel.
  core::Values v;
  ASSERT_TRUE(v.Insert(MakeKey('x', 0), Pose2(0.1, 0.2, 0.3)).ok());
  ASSERT_TRUE(v.Insert(MakeKey('x', 5), Pose2(4, -2, 1)).ok());
  EXPECT_DOUBLE_EQ(r[2]->Chi2(v), g[2]->Chi2(v));
  EXPECT_DOUBLE_EQ(r[2]->Cost(v), cauchy.Cost(g[2]->Chi2(v)));
  EXPECT_LT(r[2]->Cost(v), g[2]->Cost(v));
}

TEST(RobustifyTest, NoneRemovesKernelsFromLoopClosures) {
  const core::FactorGraph g =
      RobustifyLoopClosures(MixedGraph(), *RobustKernel::Create(RobustKernel::Kind::kDcs, 1.0));
  const core::FactorGraph r = RobustifyLoopClosures(g, RobustKernel());
  for (const core::FactorPtr& f : r) EXPECT_TRUE(f->robust_kernel().is_none());
}

TEST(RobustifyTest, ParsesSpecsWithDefaults) {
  core::Result<RobustKernel> k = ParseRobustSpec("cauchy");
  ASSERT_TRUE(k.ok());
  EXPECT_EQ(k->kind(), RobustKernel::Kind::kCauchy);
  EXPECT_EQ(k->parameter(), DefaultRobustParameter(RobustKernel::Kind::kCauchy));
  k = ParseRobustSpec("geman-mcclure:2.5");
  ASSERT_TRUE(k.ok());
  EXPECT_EQ(k->kind(), RobustKernel::Kind::kGemanMcClure);
  EXPECT_EQ(k->parameter(), 2.5);
  EXPECT_EQ(RobustSpecString(*k), "geman-mcclure:2.5");
  k = ParseRobustSpec("none");
  ASSERT_TRUE(k.ok());
  EXPECT_TRUE(k->is_none());
  EXPECT_EQ(RobustSpecString(*k), "none");
  for (const char* kind : {"huber", "cauchy", "gemanmcclure", "dcs"}) {
    const core::Result<RobustKernel> d = ParseRobustSpec(kind);
    ASSERT_TRUE(d.ok()) << kind;
    EXPECT_GT(d->parameter(), 0.0) << kind;
  }
  for (const char* bad : {"tukey", "huber:", "huber:x", "huber:1.0x", "huber:-1", "huber:0", "none:1", "dcs:inf"}) {
    EXPECT_FALSE(ParseRobustSpec(bad).ok()) << bad;
  }
}

}  // namespace
}  // namespace slamd::clients
