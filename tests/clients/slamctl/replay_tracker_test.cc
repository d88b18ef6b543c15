// ReplayTracker: acknowledgement by later estimates, latency percentiles (nearest rank, against
// a hand-computed list), rejects counted only for our robots, the settled condition.
#include "clients/slamctl/replay_tracker.h"

#include <gtest/gtest.h>

namespace slamd::clients {
namespace {

ReplayItem Pose(const std::string& robot, std::int64_t pose) {
  ReplayItem item;
  item.channel = "SLAMD_ODOMETRY";
  item.robot = robot;
  item.new_pose = pose;
  return item;
}

TEST(ReplayTrackerTest, PercentileIsNearestRank) {
  std::vector<double> v = {5, 1, 4, 2, 3, 6, 7, 8, 9, 10};
  EXPECT_EQ(Percentile(&v, 0.5), 5);
  EXPECT_EQ(Percentile(&v, 0.9), 9);
  EXPECT_EQ(Percentile(&v, 0.99), 10);
  EXPECT_EQ(Percentile(&v, 0.0), 1);
  std::vector<double> empty;
  EXPECT_EQ(Percentile(&empty, 0.5), 0);
}

TEST(ReplayTrackerTest, EstimatesAcknowledgeEveryPoseAtOrBelowTheirIndex) {
  ReplayTracker t({"a", "b"});
  t.OnSent(Pose("a", 0), 10.0);
  t.OnSent(Pose("a", 1), 10.1);
  t.OnSent(Pose("b", 0), 10.2);
  ReplayItem other = Pose("a", -1);
  t.OnSent(other, 10.3);  // a landmark: no pose
  EXPECT_EQ(t.sent(), 4);
  EXPECT_EQ(t.Unacked("a"), 2u);
  EXPECT_EQ(t.Unacked("b"), 1u);
  EXPECT_FALSE(t.AllAcked());
  t.OnEstimate("a", 1, 10.5);  // coalesced: acknowledges a0 and a1
  EXPECT_EQ(t.Unacked("a"), 0u);
  EXPECT_EQ(t.Acked("a"), 1);
  EXPECT_EQ(t.Acked("b"), -1);
  t.OnEstimate("c", 7, 10.6);  // someone else's robot
  EXPECT_FALSE(t.AllAcked());
  t.OnEstimate("b", 0, 11.2);
  EXPECT_TRUE(t.AllAcked());
  const LatencySummary lat = t.Latency();
  EXPECT_EQ(lat.count, 3u);  // 500, 400, 1000 ms
  EXPECT_NEAR(lat.p50_ms, 500, 1e-9);
  EXPECT_NEAR(lat.max_ms, 1000, 1e-9);
  EXPECT_NEAR(lat.p90_ms, 1000, 1e-9);
}

TEST(ReplayTrackerTest, CountsOnlyOurRejects) {
  ReplayTracker t({"a"});
  slamd::reject_t r{};
  r.robot = "a";
  r.reason = slamd::reject_t::REASON_DUPLICATE;
  r.message_type = "odometry_t";
  t.OnReject(r);
  r.robot = "zz";
  t.OnReject(r);
  EXPECT_EQ(t.rejected(), 1);
  EXPECT_EQ(t.rejected_by_reason().at("duplicate"), 1);
  ASSERT_EQ(t.reject_details().size(), 1u);
}

TEST(ReplayTrackerTest, SettlesOnAStatusThatCoversEverything) {
  ReplayTracker t({"a"});
  slamd::status_t before{};
  before.messages_received = 100;
  before.messages_already_held = 7;
  t.SetBaseline(before);
  t.OnSent(Pose("a", 0), 0.0);
  t.OnSent(Pose("a", -1), 0.0);
  slamd::status_t s{};
  s.messages_received = 101;  // baseline 100: one of our two arrived
  s.messages_already_held = 8;     // one of ours the server had already
  EXPECT_EQ(t.already_held(), 0);  // no status yet since the baseline
  s.settled = true;
  t.OnStatus(s);
  EXPECT_EQ(t.already_held(), 1);
  EXPECT_FALSE(t.ReceivedAll());
  EXPECT_FALSE(t.Settled());
  s.messages_received = 102;
  t.OnStatus(s);
  EXPECT_TRUE(t.ReceivedAll());
  EXPECT_FALSE(t.Settled());  // pose a0 not acknowledged yet
  t.OnEstimate("a", 0, 0.1);
  EXPECT_TRUE(t.Settled());
  s.queue_depth = 3;
  t.OnStatus(s);
  EXPECT_FALSE(t.Settled());
  s.queue_depth = 0;
  s.settled = false;
  t.OnStatus(s);
  EXPECT_FALSE(t.Settled());
  EXPECT_EQ(t.status_count(), 4);

  // A rejected pose is never acknowledged: with a reject of ours, the status alone decides.
  t.OnSent(Pose("a", 1), 0.2);
  s.messages_received = 103;
  s.settled = true;
  t.OnStatus(s);
  EXPECT_FALSE(t.Settled());
  slamd::reject_t r{};
  r.robot = "a";
  r.reason = slamd::reject_t::REASON_UNKNOWN_POSE;
  t.OnReject(r);
  EXPECT_TRUE(t.Settled());
}

}  // namespace
}  // namespace slamd::clients
