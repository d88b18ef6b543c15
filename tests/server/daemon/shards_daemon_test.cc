// Map shards through the daemon (in-process bus, manual drive): two shards on one bus, each
// owning one robot, take only their robots' messages (and the closures their robot names
// first), send each other summaries on the bus (no NATS servers configured), and end at the
// estimate of one unsharded daemon fed every message; a shard restarted from its data directory
// recovers the summaries it had applied (they are journaled).
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

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

}  // namespace slamd::server::shards_daemon_test
