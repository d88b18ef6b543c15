// ReplayResender: a message refused as queue_full goes again after a doubling back-off, until
// give_up_after_s from its first refusal; other rejects, other channels and messages sent long ago are not sent
// again; messages sharing a reject's name are queued once each.
#include "clients/slamctl/replay_resend.h"

#include <gtest/gtest.h>

namespace slamd::clients {
namespace {

ReplayItem Item(const std::string& channel, const std::string& robot, std::int64_t utime) {
  ReplayItem item;
  item.channel = channel;
  item.robot = robot;
  item.utime = utime;
  return item;
}

slamd::reject_t Reject(const ReplayItem& item, std::int32_t reason) {
  slamd::reject_t r{};
  r.channel = item.channel;
  r.robot = item.robot;
  r.message_utime = item.utime;
  r.reason = reason;
  return r;
}

TEST(ReplayResenderTest, QueueFullGoesAgainAfterADoublingBackOffThenStands) {
  ReplayResender resender({.give_up_after_s = 0.2, .first_delay_s = 0.02, .max_delay_s = 0.05});
  const ReplayItem odometry = Item("SLAMD_ODOMETRY", "a", 1000);
  const slamd::reject_t full = Reject(odometry, slamd::reject_t::REASON_QUEUE_FULL);
  double now = 10.0;
  resender.OnSent(7, odometry, now);
  // Each refusal: queued, due after 20, then 40, then 50 ms (capped) ...
  const std::vector<double> delays = {0.02, 0.04, 0.05, 0.05, 0.05};
  for (double delay : delays) {
    ASSERT_TRUE(resender.OnReject(full, now)) << now;
    EXPECT_FALSE(resender.idle());
    EXPECT_TRUE(resender.TakeDue(now + delay - 0.001).empty()) << delay;
    now += delay;
    EXPECT_EQ(resender.TakeDue(now), std::vector<std::size_t>{7}) << delay;
    EXPECT_TRUE(resender.idle());
    resender.OnSent(7, odometry, now);
  }
  EXPECT_EQ(resender.resent(), 5);
  // ... until 0.2 s after the first refusal (10.21 now): then the refusal stands.
  EXPECT_FALSE(resender.OnReject(full, now));
  EXPECT_EQ(resender.given_up(), 1);
  EXPECT_TRUE(resender.idle());
}

TEST(ReplayResenderTest, OnlyQueueFullOfOurOwnRecentMessagesGoesAgain) {
  ReplayResender resender({.give_up_after_s = 60, .remember_s = 30.0});
  const ReplayItem odometry = Item("SLAMD_ODOMETRY", "a", 1000);
  resender.OnSent(0, odometry, 10.0);
  // Another reason: the server refused it for good.
  EXPECT_FALSE(resender.OnReject(Reject(odometry, slamd::reject_t::REASON_DUPLICATE), 10.1));
  // Another channel, robot or utime: not a message we sent.
  slamd::reject_t other = Reject(odometry, slamd::reject_t::REASON_QUEUE_FULL);
  other.channel = "SLAMD_PRIOR";
  EXPECT_FALSE(resender.OnReject(other, 10.1));
  other = Reject(Item("SLAMD_ODOMETRY", "b", 1000), slamd::reject_t::REASON_QUEUE_FULL);
  EXPECT_FALSE(resender.OnReject(other, 10.1));
  other = Reject(Item("SLAMD_ODOMETRY", "a", 1001), slamd::reject_t::REASON_QUEUE_FULL);
  EXPECT_FALSE(resender.OnReject(other, 10.1));
  EXPECT_TRUE(resender.idle());
  EXPECT_EQ(resender.given_up(), 0);  // none of those was ours
  // Sent more than remember_s before the reject's time (another send prunes it): forgotten.
  resender.OnSent(1, Item("SLAMD_ODOMETRY", "a", 2000), 41.0);
  EXPECT_FALSE(resender.OnReject(Reject(odometry, slamd::reject_t::REASON_QUEUE_FULL), 41.0));
  // Re-sends off: nothing goes again.
  ReplayResender off({.give_up_after_s = 0});
  off.OnSent(0, odometry, 10.0);
  EXPECT_FALSE(off.OnReject(Reject(odometry, slamd::reject_t::REASON_QUEUE_FULL), 10.0));
}

TEST(ReplayResenderTest, MessagesSharingARejectsNameAreQueuedOnceEach) {
  ReplayResender resender({.give_up_after_s = 60, .first_delay_s = 0.02});
  // Two loop closures of one step: same channel, robot and utime.
  const ReplayItem closure = Item("SLAMD_LOOP_CLOSURE", "a", 5000);
  resender.OnSent(3, closure, 10.0);
  resender.OnSent(4, closure, 10.0);
  resender.OnSent(5, Item("SLAMD_ODOMETRY", "a", 5000), 10.0);  // same name, other channel
  const slamd::reject_t full = Reject(closure, slamd::reject_t::REASON_QUEUE_FULL);
  EXPECT_TRUE(resender.OnReject(full, 10.0));
  EXPECT_TRUE(resender.OnReject(full, 10.0));  // the second's refusal: both queued already
  EXPECT_EQ(resender.TakeDue(10.1), (std::vector<std::size_t>{3, 4}));
  EXPECT_EQ(resender.resent(), 2);
}

// A message waiting to go again is remembered however long the server keeps refusing it.
TEST(ReplayResenderTest, AQueuedMessageIsNotForgotten) {
  ReplayResender resender({.give_up_after_s = 60, .first_delay_s = 0.02, .remember_s = 1.0});
  const ReplayItem odometry = Item("SLAMD_ODOMETRY", "a", 1000);
  resender.OnSent(0, odometry, 10.0);
  ASSERT_TRUE(resender.OnReject(Reject(odometry, slamd::reject_t::REASON_QUEUE_FULL), 10.5));
  resender.OnSent(1, Item("SLAMD_ODOMETRY", "a", 2000), 12.0);  // prunes what is older than 11
  EXPECT_EQ(resender.TakeDue(12.0), std::vector<std::size_t>{0});
  resender.OnSent(0, odometry, 12.0);
  EXPECT_TRUE(resender.OnReject(Reject(odometry, slamd::reject_t::REASON_QUEUE_FULL), 12.1));
}

}  // namespace
}  // namespace slamd::clients
