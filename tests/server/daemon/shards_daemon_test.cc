// Map shards through the daemon (in-process bus, manual drive): two shards on one bus, each
// owning one robot, take only their robots' messages (and the closures their robot names
// first), send each other summaries on the bus (no NATS servers configured), and end at the
// estimate of one unsharded daemon fed every message; a shard restarted from its data directory
// recovers the summaries it had applied (they are journaled).
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <random>
#include <set>

#include "server/daemon/daemon.h"
#include "server/transport/in_process_bus.h"
#include "tests/server/daemon/daemon_test_client.h"

namespace slamd::server::shards_daemon_test {

using core::Pose2;
using daemon_test::Params;
using ::slamd::testing::Noise;

constexpr int kPoses = 15;

// Two robots on parallel lines 3 m apart, noisy odometry, a prior each, and closures both ways.
std::vector<std::pair<std::string, std::vector<std::uint8_t>>> World() {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0.0, 0.05);
  const auto noisy = [&](const Pose2& z) {
    return z.Retract(core::Vector3(n(rng), n(rng), n(rng)));
  };
  const auto truth = [](int r, int i) { return Pose2(1.0 * i, 3.0 * r, 0.0); };
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> out;
  const auto add = [&](const char* channel, const auto& msg) {
    std::vector<std::uint8_t> bytes;
    EXPECT_TRUE(Encode(msg, &bytes).ok());
    out.emplace_back(channel, std::move(bytes));
  };
  for (int r = 0; r < 2; ++r) {
    const std::string robot = "r" + std::to_string(r);
    slamd::prior_t prior;
    ToLcm(PriorMeasurement{1, robot, 0, PriorKind::kPose2, truth(r, 0), Noise(3, 0.01)}, &prior);
    add("SLAMD_PRIOR", prior);
    for (int i = 0; i + 1 < kPoses; ++i) {
      slamd::odometry_t odo;
      ToLcm(OdometryMeasurement{2, robot, std::uint64_t(i), std::uint64_t(i + 1),
                                noisy(truth(r, i).Between(truth(r, i + 1))), Noise(3, 0.05)},
            &odo);
      add("SLAMD_ODOMETRY", odo);
    }
  }
  for (const int i : {3, 8, 13}) {
    for (const auto& [a, b, j] : {std::tuple{0, 1, i + 1}, std::tuple{1, 0, i - 1}}) {
      slamd::loop_closure_t loop;
      ToLcm(LoopClosureMeasurement{3,
                                   "r" + std::to_string(a),
                                   std::uint64_t(i),
                                   "r" + std::to_string(b),
                                   std::uint64_t(j),
                                   noisy(truth(a, i).Between(truth(b, j))),
                                   Noise(3, 0.05),
                                   {}},
            &loop);
      add("SLAMD_LOOP_CLOSURE", loop);
    }
  }
  return out;
}

// Unsharded when self is "".
ServerParams ShardParams(const std::string& self, const std::string& data_dir = "") {
  ServerParams p = Params();
  p.refine.enabled = true;
  p.refine.idle_s = 0.0;
  p.isam2.refine_threshold = 1e-9;
  p.isam2.wildfire_threshold = 0.0;  // exact estimates: summaries go on until 1e-6
  p.data_dir = data_dir;
  p.shards.summary_every_ms = 10;
  if (!self.empty())
    p.estimator.shards = {.self = self, .shards = {{"S0", {"r0"}}, {"S1", {"r1"}}}};
  return p;
}

Pose2 PoseOf(const Daemon& d, const std::string& robot, int i) {
  return std::get<Pose2>(d.estimator_for_tests().PoseEstimate(robot, i).value());
}

// The largest distance between each shard's own robot and the central daemon's.
double Gap(const Daemon& s0, const Daemon& s1, const Daemon& central) {
  double gap = 0.0;
  for (int i = 0; i < kPoses; ++i) {
    gap = std::max(
        gap, (PoseOf(s0, "r0", i).translation() - PoseOf(central, "r0", i).translation()).norm());
    gap = std::max(
        gap, (PoseOf(s1, "r1", i).translation() - PoseOf(central, "r1", i).translation()).norm());
  }
  return gap;
}

// Drives both shards (one bus) until their own robots' estimates are within `tol` of the
// central daemon's, at most `seconds`; returns the gap reached.
double DriveUntilClose(Daemon& s0, Daemon& s1, const Daemon& central, double tol,
                       double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  double gap = 1e9;
  while (std::chrono::steady_clock::now() < deadline) {
    EXPECT_TRUE(s0.PumpIntake(1).ok());  // delivers to both shards' subscriptions
    EXPECT_TRUE(s1.PumpIntake(0).ok());
    s0.StepEstimator(0.0);
    s1.StepEstimator(0.0);
    gap = Gap(s0, s1, central);
    if (gap < tol) break;
  }
  return gap;
}

TEST(ShardsDaemon, TwoShardsOnOneBusEndAtTheCentralEstimate) {
  const auto world = World();
  InProcessBus central_bus;
  auto central = Daemon::Create(ShardParams(""), &central_bus).value();
  for (const auto& [channel, bytes] : world) ASSERT_TRUE(central_bus.Publish(channel, bytes).ok());
  ASSERT_TRUE(central->PumpIntake(0).ok());
  for (int k = 0; k < 200 && central->StepEstimator(0.0) >= 0 && !central->snapshot()->settled;
       ++k) {
  }
  ASSERT_TRUE(central->snapshot()->settled);

  const std::string dir = daemon_test::FreshDataDir("shards_s0");
  InProcessBus bus;
  daemon_test::Client client(bus);
  auto s0 = Daemon::Create(ShardParams("S0", dir), &bus).value();
  auto s1 = Daemon::Create(ShardParams("S1"), &bus).value();
  for (const auto& [channel, bytes] : world) ASSERT_TRUE(bus.Publish(channel, bytes).ok());
  const double gap = DriveUntilClose(*s0, *s1, *central, 1e-6, 20.0);
  EXPECT_LT(gap, 1e-6);
  // Each took its robot's messages and its closures, and left the rest to the other.
  // Applied: 1 prior, 14 odometry, 3 closures, and the summaries S1 sent.
  EXPECT_GT(s0->snapshot()->counters.applied, 18);
  EXPECT_GT(s1->snapshot()->counters.applied, 18);
  EXPECT_TRUE(client.rejects.empty()) << client.rejects.front().detail;
  EXPECT_EQ(s0->snapshot()->robots.size(), 1u);
  EXPECT_EQ(s0->snapshot()->robots[0].name, "r0");

  // S0 restarted from its data directory has the summaries it applied: the same estimate.
  const Pose2 before = PoseOf(*s0, "r0", kPoses - 1);
  s0->Stop();
  s0.reset();
  InProcessBus quiet;
  auto again = Daemon::Create(ShardParams("S0", dir), &quiet).value();
  EXPECT_LT((PoseOf(*again, "r0", kPoses - 1).translation() - before.translation()).norm(), 1e-6);
  again->Stop();
  std::filesystem::remove_all(dir);
}

// A fleet-wide map (map_robot "*") is answered by every shard, each with its own robots' map_t
// pages and a query_reply_t naming it and how many shards answer; keys of several shards' robots
// by each owner (another shard's key not found there, even a pose it shares); a query of one
// shard's robot by that shard alone.
TEST(ShardsDaemon, EveryShardAnswersForItsOwnRobots) {
  InProcessBus bus;
  auto s0 = Daemon::Create(ShardParams("S0"), &bus).value();
  auto s1 = Daemon::Create(ShardParams("S1"), &bus).value();
  std::vector<slamd::query_reply_t> replies;
  std::vector<slamd::map_t> pages;
  const ChannelNames channels;
  Subscription on_reply =
      Subscribe<slamd::query_reply_t>(
          bus, channels.QueryReply(),
          [&](std::string_view, const slamd::query_reply_t& m) { replies.push_back(m); }, nullptr)
          .value();
  Subscription on_map =
      Subscribe<slamd::map_t>(
          bus, channels.Map(), [&](std::string_view, const slamd::map_t& m) { pages.push_back(m); },
          nullptr)
          .value();
  for (const auto& [channel, bytes] : World()) ASSERT_TRUE(bus.Publish(channel, bytes).ok());
  const auto drive = [&] {
    for (int k = 0; k < 5; ++k) {
      ASSERT_TRUE(s0->PumpIntake(0).ok());  // delivers to both shards' subscriptions
      ASSERT_TRUE(s1->PumpIntake(0).ok());
      s0->StepEstimator(0.0);
      s1->StepEstimator(0.0);
    }
  };
  drive();
  // S0 holds r1's poses its closures name (shared poses), not r1's map.
  ASSERT_TRUE(s0->estimator_for_tests().PoseEstimate("r1", 4).ok());
  const auto ask = [&](std::int64_t id, const std::string& map_robot,
                       std::vector<WireKey> keys = {{"r1", KeyKind::kPose, 3}},
                       bool joint = false) {
    replies.clear();
    pages.clear();
    slamd::query_t q;
    ToLcm(QueryRequest{.client = "c",
                       .request_id = id,
                       .keys = std::move(keys),
                       .want_marginals = joint,
                       .want_joint_marginal = joint,
                       .map_robot = map_robot},
          &q);
    ASSERT_TRUE(Publish(bus, channels.Inbound<QuerySpec>(), q).ok());
    drive();
  };

  ask(7, "*");
  ASSERT_EQ(replies.size(), 2u);
  std::map<std::string, slamd::query_reply_t> by_shard;
  int announced = 0;
  for (const slamd::query_reply_t& r : replies) {
    EXPECT_EQ(r.request_id, 7);
    EXPECT_EQ(r.shards_answering, 2);
    EXPECT_EQ(r.status, slamd::query_reply_t::STATUS_OK) << r.error;
    announced += r.map_pages;
    by_shard[r.shard] = r;
  }
  ASSERT_EQ(by_shard.count("S0") + by_shard.count("S1"), 2u);
  ASSERT_EQ(by_shard["S0"].num_results, 1);
  EXPECT_FALSE(by_shard["S0"].results[0].found);  // r1's key: S1's to answer
  ASSERT_EQ(by_shard["S1"].num_results, 1);
  EXPECT_TRUE(by_shard["S1"].results[0].found);
  EXPECT_EQ(static_cast<int>(pages.size()), announced);
  std::set<std::pair<std::string, std::string>> maps;  // (shard, robot)
  for (const slamd::map_t& m : pages) maps.insert({m.shard, m.robot});
  // Each shard its own robot (S0's shared poses of r1 are S1's to publish).
  EXPECT_EQ(maps, (std::set<std::pair<std::string, std::string>>{{"S0", "r0"}, {"S1", "r1"}}));

  ask(8, "r1");
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].shard, "S1");
  EXPECT_EQ(replies[0].shards_answering, 1);
  ASSERT_FALSE(pages.empty());
  for (const slamd::map_t& m : pages) EXPECT_EQ(m.shard, "S1");

  // r0:x2 and r1:x4 (a pose S0 shares): each found by its owner only.
  ask(9, "", {{"r0", KeyKind::kPose, 2}, {"r1", KeyKind::kPose, 4}});
  ASSERT_EQ(replies.size(), 2u);
  EXPECT_TRUE(pages.empty());
  for (const slamd::query_reply_t& r : replies) {
    EXPECT_EQ(r.shards_answering, 2);
    EXPECT_EQ(r.status, slamd::query_reply_t::STATUS_OK) << r.error;
    ASSERT_EQ(r.num_results, 2);
    EXPECT_EQ(r.results[0].found, r.shard == "S0") << r.shard;
    EXPECT_EQ(r.results[1].found, r.shard == "S1") << r.shard;
  }
  // No shard holds the joint marginal of both.
  ask(10, "", {{"r0", KeyKind::kPose, 2}, {"r1", KeyKind::kPose, 4}}, /*joint=*/true);
  ASSERT_EQ(replies.size(), 2u);
  for (const slamd::query_reply_t& r : replies) {
    EXPECT_EQ(r.status, slamd::query_reply_t::STATUS_PARTIAL);
    EXPECT_EQ(r.error, "no joint marginal of keys of several shards");
    EXPECT_EQ(r.joint_dimension, 0);
  }
  // One shard's robot: that shard alone.
  ask(11, "", {{"r0", KeyKind::kPose, 2}});
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].shard, "S0");
  EXPECT_TRUE(replies[0].results[0].found);
}

}  // namespace slamd::server::shards_daemon_test
