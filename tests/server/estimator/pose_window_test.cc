// The lifelong window in the estimator (server/estimator/pose_window.cc): its summaries, their
// chunks and a robot's own window.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <string>

#include "core/factors/linear_container_factor.h"
#include "server/estimator/estimator.h"
#include "server/estimator/reduced_graph.h"
#include "tests/server/estimator/estimator_test_messages.h"

namespace slamd::server {
namespace {

using core::Pose2;
using namespace estimator_test;  // NOLINT: the shared messages and checks

// The window's summaries in a landmark world: a robot circling a ring of 21 poses, seeing the
// ring's 7 landmarks, every pose behind 10 removed but keyframes. Sparse (the default), every
// summary factor is on at most 1 + summary_parents variables and the root (a keyframe the
// removal reports for the journal; a child in its parent pose's frame has that parent as root),
// in the root-relative form, and the factors stay bounded lap after lap; dense, each summary is
// one factor on the whole blanket. Either way the estimate keeps up with the robot (its newest
// pose within 0.5 m of the ring's).
TEST(EstimatorTest, WindowSummariesInALandmarkWorld) {
  const Pose2 step(1.0, 0.0, 2 * M_PI / 21);
  for (const int parents : {1, 2, 0}) {
    const bool sparse = parents > 0;
    SCOPED_TRACE(sparse ? "sparse, parents " + std::to_string(parents) : "dense");
    EstimatorParams p{.chi2_interval_s = 0.0};
    p.window = {.keep_poses = 10,
                .keyframe_spacing_m = 3.0,
                .every_updates = 5,
                .sparse_summaries = sparse,
                .summary_parents = std::max(parents, 1)};
    auto e = Make(p);
    ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
    std::vector<std::int64_t> factors_per_lap;
    std::size_t roots = 0;
    const auto truth = [&](std::uint64_t i) {
      Pose2 pose;
      for (std::uint64_t k = 0; k < i % 21; ++k) pose = pose * step;
      return pose;
    };
    for (std::uint64_t i = 0; i < 126; ++i) {
      std::vector<Inbound> batch = {Odo("r", i, i + 1, step)};
      // Landmark j sits 2 m to the left of ring pose 3j; seen from that pose and the next.
      if (i % 3 != 2) {
        const std::uint64_t j = i % 21 / 3;
        const core::Point2 at = truth(i).TransformTo(truth(3 * j).TransformFrom({0.0, 2.0}));
        batch.push_back(Landmark("r", i, j, std::atan2(at.y(), at.x()), at.norm()));
      }
      ASSERT_TRUE(e->Process(batch).status.ok()) << i;
      const NodeRemovalRecord removal = e->ApplyPoseWindow();
      // The trees' roots, for the journal: kept poses (keyframes), sorted.
      EXPECT_TRUE(std::is_sorted(removal.roots.begin(), removal.roots.end()));
      for (core::Key root : removal.roots) {
        EXPECT_TRUE(e->solver().linearization_point().Contains(root)) << core::KeyToString(root);
      }
      roots += removal.roots.size();
      if (i % 21 == 20) factors_per_lap.push_back(e->snapshot()->num_factors);
    }
    EXPECT_GT(e->snapshot()->counters.removed_variables, 60);
    int trees = 0, wide = 0, widest = 0;
    for (const core::FactorPtr& f : e->solver().factor_slots()) {
      const auto* c = dynamic_cast<const core::LinearContainerFactor*>(f.get());
      if (!c) continue;
      const int keys = static_cast<int>(c->keys().size());
      trees += c->root_relative() && keys <= parents + 2;
      wide += keys > parents + 2;
      widest = std::max(widest, keys);
    }
    if (sparse) {
      EXPECT_GT(roots, 0u);
      EXPECT_GT(trees, 0);
      EXPECT_EQ(wide, 0);
      EXPECT_EQ(widest, parents + 2);
      // Bounded: the last lap holds no more factors than the second or third (a few more: a
      // lap's removals end at another point of the ring).
      ASSERT_EQ(factors_per_lap.size(), 6u);
      EXPECT_LE(factors_per_lap.back(), std::max(factors_per_lap[1], factors_per_lap[2]) + 5);
    } else {
      EXPECT_GT(wide, 0);
    }
    EXPECT_LT((PoseOf(*e, "r", 126).translation() - truth(126).translation()).norm(), 0.5);
  }
}

// Two robots circling rings 100 m apart, each seeing its own landmarks, their old poses removed
// in the same window passes: each summary factor holds one robot's poses (a removal's chunk is
// one robot's, so that no tree bridges the maps of robots that share nothing).
TEST(EstimatorTest, WindowSummariesStayWithinOneRobot) {
  const Pose2 step(1.0, 0.0, 2 * M_PI / 21);
  EstimatorParams p{.chi2_interval_s = 0.0};
  p.window = {.keep_poses = 10, .keyframe_spacing_m = 3.0, .every_updates = 5};
  auto e = Make(p);
  ASSERT_TRUE(e->Process({Prior("a", 0, Pose2()), Prior("b", 0, Pose2(100, 0, 0))}).status.ok());
  const auto ring = [&](std::uint64_t i) {
    Pose2 pose;
    for (std::uint64_t k = 0; k < i % 21; ++k) pose = pose * step;
    return pose;
  };
  std::int64_t removed = 0;
  for (std::uint64_t i = 0; i < 84; ++i) {
    std::vector<Inbound> batch = {Odo("a", i, i + 1, step), Odo("b", i, i + 1, step)};
    if (i % 3 != 2) {
      const std::uint64_t j = i % 21 / 3;
      const core::Point2 at = ring(i).TransformTo(ring(3 * j).TransformFrom({0.0, 2.0}));
      const double bearing = std::atan2(at.y(), at.x());
      batch.push_back(Landmark("a", i, j, bearing, at.norm()));
      batch.push_back(Landmark("b", i, 100 + j, bearing, at.norm()));
    }
    ASSERT_TRUE(e->Process(batch).status.ok()) << i;
    const NodeRemovalRecord now = e->ApplyPoseWindow();
    std::set<std::uint8_t> robots;
    for (core::Key k : now.keys) robots.insert(core::KeyRobot(k));
    removed += robots.size() == 2;
  }
  EXPECT_GT(removed, 5);  // passes that removed poses of both robots
  int containers = 0;
  for (const core::FactorPtr& f : e->solver().factor_slots()) {
    if (!dynamic_cast<const core::LinearContainerFactor*>(f.get())) continue;
    ++containers;
    std::set<std::uint8_t> robots;
    for (core::Key k : f->keys()) {
      if (core::KeySymbol(k) == 'x') robots.insert(core::KeyRobot(k));
    }
    EXPECT_LE(robots.size(), 1u) << f->Name() << " on " << core::KeyToString(f->keys().front());
  }
  EXPECT_GT(containers, 10);
}

// A window left behind by one large update (a burst of messages taken at once) does not wait
// `every_updates` for its next pass while more than a pass's worth of poses is behind it: it
// removes at every update until it has caught up, so that under sustained load the graph stays
// bounded rather than growing between passes.
TEST(EstimatorTest, WindowBehindRemovesAtEveryUpdateUntilCaughtUp) {
  EstimatorParams p{.chi2_interval_s = 0.0};
  p.window = {.keep_poses = 10, .keyframe_spacing_m = 0.0, .every_updates = 50};
  auto e = Make(p);
  ASSERT_TRUE(e->Process({Prior("a", 0, Pose2())}).status.ok());
  std::vector<Inbound> burst;
  for (std::uint64_t i = 0; i < 1200; ++i) burst.push_back(Odo("a", i, i + 1, kStep));
  ASSERT_TRUE(e->Process(burst).status.ok());
  std::uint64_t next = 1200;
  std::vector<std::size_t> removed;  // per update, once the first pass has run
  for (int update = 0; update < 60 && removed.size() < 6; ++update, ++next) {
    ASSERT_TRUE(e->Process({Odo("a", next, next + 1, kStep)}).status.ok());
    const NodeRemovalRecord now = e->ApplyPoseWindow();
    if (!removed.empty() || !now.keys.empty()) removed.push_back(now.keys.size());
  }
  ASSERT_EQ(removed.size(), 6u);
  // About 1,240 poses behind at the first pass (update 50): half of them at it, half of the
  // rest at the next update, then 256 (the least a pass behind takes), then the rest.
  EXPECT_GT(removed[0], 600u);
  EXPECT_LT(removed[0], 640u);
  EXPECT_NEAR(static_cast<double>(removed[1]), removed[0] / 2.0, 1.0);
  EXPECT_EQ(removed[2], 256u);
  EXPECT_GT(removed[3], 0u);
  EXPECT_LT(removed[3], 256u);
  EXPECT_EQ(removed[4], 0u);  // caught up: the next pass waits `every_updates` again
  EXPECT_EQ(e->snapshot()->counters.removed_variables,
            static_cast<std::int64_t>(removed[0] + removed[1] + removed[2] + removed[3]));
}

// keep_aliases: a removed pose up to 30 behind the window is held as an alias of the keyframe
// that replaced it, where its estimate was; older ones are forgotten. A loop closure to a held
// pose is composed onto its keyframe (one factor), its measurements sent again are held
// already; to a forgotten one it is rejected. A replay
// that applies the live removals' records (the journal's) gets the same estimates bit for bit.
// A keyframe removed with an alias of its own takes the aliases anchored at it along; one
// removed without takes them out.
TEST(EstimatorTest, WindowHoldsRecentlyRemovedPosesAsAliasesOfKeyframes) {
  const Pose2 step(1.0, 0.0, 2 * M_PI / 21);  // a ring of 21 poses
  const auto truth = [&](std::uint64_t i) {
    Pose2 pose;
    for (std::uint64_t k = 0; k < i % 21; ++k) pose = pose * step;
    return pose;
  };
  EstimatorParams p{.chi2_interval_s = 0.0};
  p.window = {.keep_poses = 10, .keyframe_spacing_m = 3.0, .every_updates = 5, .keep_aliases = 30};
  auto live = Make(p);
  auto replay = Make(p);
  const auto both = [&](const std::vector<Inbound>& batch) {
    for (Estimator* e : {live.get(), replay.get()}) {
      const ProcessResult r = e->Process(batch);
      ASSERT_TRUE(r.status.ok());
      ASSERT_TRUE(r.rejections.empty()) << r.rejections[0].verdict.message;
    }
  };
  const auto estimate = [](Estimator& e, std::uint64_t i) -> std::optional<Pose2> {
    const core::Result<core::Variable> v = e.PoseEstimate("r", i);
    return v.ok() ? std::optional<Pose2>(std::get<Pose2>(v.value())) : std::nullopt;
  };
  both({Prior("r", 0, Pose2())});
  int held = 0;
  constexpr std::uint64_t kNewest = 84;
  for (std::uint64_t i = 0; i < kNewest; ++i) {
    both({Odo("r", i, i + 1, step)});
    std::vector<std::optional<Pose2>> before;
    for (std::uint64_t k = 0; k <= i + 1; ++k) before.push_back(estimate(*live, k));
    const NodeRemovalRecord removal = live->ApplyPoseWindow();
    if (!removal.keys.empty()) ASSERT_TRUE(replay->RemoveVariables(removal).ok());
    EXPECT_TRUE(std::is_sorted(removal.aliases.begin(), removal.aliases.end(),
                               [](const auto& a, const auto& b) { return a.first < b.first; }));
    for (const auto& [pose, alias] : removal.aliases) {
      ++held;
      EXPECT_NE(std::find(removal.keys.begin(), removal.keys.end(), pose), removal.keys.end());
      EXPECT_TRUE(live->solver().linearization_point().Contains(alias.anchor));
      EXPECT_EQ(alias.covariance.llt().info(), Eigen::Success) << alias.covariance;
      const std::optional<Pose2> now = estimate(*live, core::KeyIndex(pose));
      ASSERT_TRUE(now && before[core::KeyIndex(pose)]);
      EXPECT_LT(core::LocalCoordinates(*now, *before[core::KeyIndex(pose)]).norm(), 1e-9);
    }
  }
  EXPECT_GT(held, 20);
  const auto key = [&](std::uint64_t i) {
    return core::MakeKey('x', i, *live->registry().Find("r"));
  };
  // Forgotten beyond 10 + 30 behind (the last pass may have trimmed up to 5 updates before).
  for (std::uint64_t k = 0; k <= kNewest; ++k) {
    const bool node = live->solver().linearization_point().Contains(key(k));
    if (k + 45 < kNewest) EXPECT_EQ(estimate(*live, k).has_value(), node) << k;
    if (k + 40 >= kNewest) EXPECT_TRUE(estimate(*live, k).has_value()) << k;
  }
  const std::uint64_t h = kNewest - 25;
  ASSERT_FALSE(live->solver().linearization_point().Contains(key(h)));
  const std::int64_t factors = live->snapshot()->num_factors;
  both({Loop("r", kNewest, "r", h, truth(kNewest).Between(truth(h)))});
  EXPECT_EQ(live->snapshot()->num_factors, factors + 1);
  for (std::uint64_t k = 0; k <= kNewest; ++k) {
    const std::optional<Pose2> a = estimate(*live, k), b = estimate(*replay, k);
    ASSERT_EQ(a.has_value(), b.has_value()) << k;
    if (a) EXPECT_EQ(core::LocalCoordinates(*a, *b).norm(), 0.0) << k;
  }
  // The measurements of a held pose stay known: the odometry into h sent again is held
  // already (nothing added), a different one with its identity a duplicate.
  ProcessResult again = live->Process({Odo("r", h - 1, h, step)});
  EXPECT_TRUE(again.rejections.empty());
  EXPECT_EQ(again.already_held_robots.count("r"), 1u);
  EXPECT_EQ(live->snapshot()->num_factors, factors + 1);
  again = live->Process({Odo("r", h - 1, h, step * step)});
  EXPECT_EQ(OnlyRejection(again), RejectReason::kDuplicate);
  std::uint64_t forgotten = 0;
  while (estimate(*live, forgotten)) ++forgotten;
  const ProcessResult r =
      live->Process({Loop("r", kNewest, "r", forgotten, truth(kNewest).Between(truth(forgotten)))});
  EXPECT_EQ(OnlyRejection(r), RejectReason::kUnknownPose);

  // Re-anchoring: the keyframe of h's alias removed with an alias of its own, relative to
  // another keyframe: h stays where it was, now anchored there.
  const auto alias_of = [&](core::Key pose) {
    for (const auto& [key, alias] : live->ExportState().aliases) {
      if (key == pose) return std::optional<PoseAlias>(alias);
    }
    return std::optional<PoseAlias>();
  };
  const core::Key hk = key(h);
  const core::Key keyframe = alias_of(hk)->anchor;
  core::Key other = 0;
  for (core::Key k : live->solver().linearization_point().keys()) {
    if (k != keyframe && core::KeyIndex(k) + 10 < kNewest) other = k;
  }
  ASSERT_NE(other, 0u);
  Eigen::MatrixXd joint;
  const core::Key pair[] = {other, keyframe};
  ASSERT_TRUE(live->JointMarginal(pair, &joint).ok());
  const Pose2 at = *estimate(*live, h);
  NodeRemovalRecord what{.keys = {keyframe}};
  what.aliases = {{keyframe, RelativeAlias(other, live->solver().CalculateEstimate(other),
                                           live->solver().CalculateEstimate(keyframe), joint)}};
  // Validated before anything is removed: an alias of a pose not removed, or anchored at one
  // that is, or aliases out of order.
  const std::int64_t variables = live->snapshot()->num_variables;
  const PoseAlias& a = what.aliases[0].second;
  for (const NodeRemovalRecord& bad :
       {NodeRemovalRecord{.keys = {keyframe}, .aliases = {{other, a}}},
        NodeRemovalRecord{.keys = {keyframe, other}, .aliases = what.aliases},
        NodeRemovalRecord{.keys = {keyframe, other},
        .aliases = {{std::max(keyframe, other), a}, {std::min(keyframe, other), a}}}}) {
    const core::Status status = live->RemoveVariables(bad);
    EXPECT_EQ(status.code(), core::StatusCode::kInvalidArgument);
    EXPECT_NE(status.message().find("alias"), std::string::npos) << status.message();
    EXPECT_EQ(live->snapshot()->num_variables, variables);
  }
  ASSERT_TRUE(live->RemoveVariables(what).ok());
  EXPECT_EQ(alias_of(hk)->anchor, other);
  EXPECT_LT(core::LocalCoordinates(*estimate(*live, h), at).norm(), 1e-9);
  ASSERT_TRUE(live->RemoveVariables({.keys = {other}}).ok());
  EXPECT_FALSE(alias_of(hk).has_value());
  EXPECT_FALSE(estimate(*live, h).has_value());
}

// A robot's own window (robot_windows) in place of the default one: robot "a" keeps its newest
// 10 poses and keyframes 3 m apart, robot "b" (default window: off) keeps everything; the
// counters and the graph say so, and a loop closure to one of a's removed poses (none held as
// an alias) is rejected.
TEST(EstimatorTest, RobotWindowRemovesOnlyThatRobotsOldPoses) {
  EstimatorParams p{.chi2_interval_s = 0.0};
  p.window.every_updates = 5;
  p.robot_windows = {
      {.robot = "a", .window = {.keep_poses = 10, .keyframe_spacing_m = 3.0, .keep_aliases = 0}}};
  ASSERT_TRUE(p.Validate().ok());
  auto e = Make(p);
  ASSERT_TRUE(e->Process({Prior("a", 0, Pose2()), Prior("b", 0, Pose2(0, 5, 0))}).status.ok());
  std::vector<core::Key> removed;
  for (std::uint64_t i = 0; i < 60; ++i) {
    ASSERT_TRUE(e->Process({Odo("a", i, i + 1, kStep), Odo("b", i, i + 1, kStep)}).status.ok());
    const NodeRemovalRecord now = e->ApplyPoseWindow();
    removed.insert(removed.end(), now.keys.begin(), now.keys.end());
  }
  ASSERT_FALSE(removed.empty());
  const std::uint8_t a = *e->registry().Find("a");
  for (core::Key k : removed) EXPECT_EQ(core::KeyRobot(k), a) << core::KeyToString(k);
  EXPECT_EQ(e->snapshot()->counters.removed_variables, static_cast<std::int64_t>(removed.size()));
  EXPECT_EQ(e->snapshot()->num_variables, 2 * 61 - static_cast<std::int64_t>(removed.size()));
  EXPECT_TRUE(e->PoseEstimate("b", 1).ok());  // b keeps every pose
  const ProcessResult r = e->Process({Loop("a", 60, "a", 1, Pose2())});
  ASSERT_EQ(r.rejections.size(), 1u);
  EXPECT_EQ(r.rejections[0].verdict.reason, RejectReason::kUnknownPose);
  // Validation names the entry.
  p.robot_windows.push_back({.robot = "a"});
  EXPECT_EQ(p.Validate().message(),
            "estimator.robot_window[1].robot = \"a\"; already given a window");
}

}  // namespace
}  // namespace slamd::server
