#include "server/daemon/ingest_queue.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace slamd::server {
namespace {

Inbound Msg(std::int64_t utime) {
  return {OdometryMeasurement{utime, "r", 0, 1, core::Pose2(),
                              core::NoiseModel::Isotropic(3, 1.0).value()},
          0};
}

TEST(IngestQueueTest, PopAllTakesEverythingInOrder) {
  IngestQueue q(4);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(q.Push(Msg(i), 0.0));
  std::vector<Inbound> out;
  EXPECT_EQ(q.PopAll(&out, 0.0), 3);
  ASSERT_EQ(out.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(MessageUtime(out[i]), i);
  EXPECT_EQ(q.size(), 0);
  EXPECT_EQ(q.PopAll(&out, 0.01), 0);  // times out
  EXPECT_EQ(q.peak(), 3);              // the longest it was, not its size now
  ASSERT_TRUE(q.Push(Msg(3), 0.0));
  EXPECT_EQ(q.peak(), 3);
}

TEST(IngestQueueTest, FullQueueBlocksForTheTimeoutThenRefuses) {
  IngestQueue q(2);
  ASSERT_TRUE(q.Push(Msg(0), 0.0));
  ASSERT_TRUE(q.Push(Msg(1), 0.0));
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(q.Push(Msg(2), 0.05));
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(45));
  EXPECT_EQ(q.size(), 2);
}

TEST(IngestQueueTest, BlockedPushSucceedsWhenTheConsumerDrains) {
  IngestQueue q(1);
  ASSERT_TRUE(q.Push(Msg(0), 0.0));
  std::thread consumer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    std::vector<Inbound> out;
    q.PopAll(&out, 0.0);
  });
  EXPECT_TRUE(q.Push(Msg(1), 5.0));
  consumer.join();
  EXPECT_EQ(q.size(), 1);
}

// The intake holds a burst of messages until it has taken it in whole: it asks for room for
// all of it.
TEST(IngestQueueTest, WaitForRoomCountsTheMessagesAskedFor) {
  IngestQueue q(4);
  ASSERT_TRUE(q.Push(Msg(0), 0.0));
  EXPECT_TRUE(q.WaitForRoom(0.0, 3));
  EXPECT_FALSE(q.WaitForRoom(0.0, 4));
  EXPECT_TRUE(q.WaitForRoom(0.0));
  ASSERT_TRUE(q.Push(Msg(1), 0.0));
  EXPECT_FALSE(q.WaitForRoom(0.01, 3));  // times out
  std::vector<Inbound> out;
  q.PopAll(&out, 0.0);
  EXPECT_TRUE(q.WaitForRoom(0.0, 4));
}

TEST(IngestQueueTest, CloseRefusesPushesButKeepsQueued) {
  IngestQueue q(3);
  ASSERT_TRUE(q.Push(Msg(0), 0.0));
  q.Close();
  EXPECT_TRUE(q.closed());
  EXPECT_FALSE(q.Push(Msg(1), 1.0));
  std::vector<Inbound> out;
  EXPECT_EQ(q.PopAll(&out, 1.0), 1);
  EXPECT_EQ(q.PopAll(&out, 1.0), 0);  // closed and empty: no wait
}

}  // namespace
}  // namespace slamd::server
