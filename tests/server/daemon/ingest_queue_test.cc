#include "server/daemon/ingest_queue.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace slamd::server {
namespace {

Inbound Msg(std::int64_t utime, std::int64_t received_us = 0) {
  return {OdometryMeasurement{utime, "r", 0, 1, core::Pose2(),
                              core::NoiseModel::Isotropic(3, 1.0).value()},
          received_us};
}

constexpr int kAll = 1000;  // more than any of these queues holds

std::int64_t NowMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

TEST(IngestQueueTest, PopTakesEverythingInOrder) {
  IngestQueue q(4);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(q.Push(Msg(i), 0.0));
  std::vector<Inbound> out;
  EXPECT_EQ(q.Pop(&out, 0.0, kAll), 3);
  ASSERT_EQ(out.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(MessageUtime(out[i]), i);
  EXPECT_EQ(q.size(), 0);
  EXPECT_EQ(q.Pop(&out, 0.01, kAll), 0);  // times out
  EXPECT_EQ(q.peak(), 3);              // the longest it was, not its size now
  ASSERT_TRUE(q.Push(Msg(3), 0.0));
  EXPECT_EQ(q.peak(), 3);
}

// An update takes at most `max` messages, the oldest; the rest wait in order for the next. A
// take that leaves room ends the saturation, as taking everything does.
TEST(IngestQueueTest, PopTakesAtMostMaxOldestFirst) {
  IngestQueue q(5);
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(q.Push(Msg(i, NowMicros()), 0.0));
  EXPECT_FALSE(q.WaitForRoom(0.01));
  ASSERT_TRUE(q.saturated());
  std::vector<Inbound> out;
  EXPECT_EQ(q.Pop(&out, 0.0, 2), 2);
  EXPECT_FALSE(q.saturated());
  EXPECT_EQ(q.size(), 3);
  // The rest of a burst stops once the batch holds `max`.
  EXPECT_EQ(q.PopRestOfBurst(&out, 1.0, 1.0, 3), 1);
  EXPECT_EQ(q.size(), 2);
  EXPECT_EQ(q.Pop(&out, 0.0, 10), 2);
  ASSERT_EQ(out.size(), 5u);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(MessageUtime(out[i]), i);
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

// A sustained overload: after one wait has timed out, a full queue refuses at once (however
// long the caller would wait) until the consumer takes it; then pushes wait again.
TEST(IngestQueueTest, AfterATimedOutWaitAFullQueueRefusesAtOnceUntilTaken) {
  IngestQueue q(1);
  ASSERT_TRUE(q.Push(Msg(0), 0.0));
  EXPECT_FALSE(q.Push(Msg(1), 0.0));
  EXPECT_FALSE(q.saturated());  // a caller that does not wait saturates nothing
  EXPECT_FALSE(q.WaitForRoom(0.01));
  EXPECT_TRUE(q.saturated());
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(q.Push(Msg(2), 5.0));
  EXPECT_FALSE(q.WaitForRoom(5.0));
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
  std::vector<Inbound> out;
  ASSERT_EQ(q.Pop(&out, 0.0, kAll), 1);
  EXPECT_FALSE(q.saturated());
  ASSERT_TRUE(q.Push(Msg(3), 0.0));
  std::thread consumer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    std::vector<Inbound> taken;
    q.Pop(&taken, 0.0, kAll);
  });
  EXPECT_TRUE(q.Push(Msg(4), 5.0));  // waits for the consumer again
  consumer.join();
  EXPECT_EQ(q.size(), 1);
  EXPECT_FALSE(q.saturated());
}

TEST(IngestQueueTest, BlockedPushSucceedsWhenTheConsumerDrains) {
  IngestQueue q(1);
  ASSERT_TRUE(q.Push(Msg(0), 0.0));
  std::thread consumer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    std::vector<Inbound> out;
    q.Pop(&out, 0.0, kAll);
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
  q.Pop(&out, 0.0, kAll);
  EXPECT_TRUE(q.WaitForRoom(0.0, 4));
}

// A message that comes within the quiet time of the newest one popped joins it; one that comes
// after a quiet time does not.
TEST(IngestQueueTest, PopRestOfBurstTakesWhatComesUntilQuiet) {
  IngestQueue q(8);
  ASSERT_TRUE(q.Push(Msg(0, NowMicros()), 0.0));
  std::thread producer([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    ASSERT_TRUE(q.Push(Msg(1, NowMicros()), 0.0));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    ASSERT_TRUE(q.Push(Msg(2, NowMicros()), 0.0));
    std::this_thread::sleep_for(std::chrono::milliseconds(600));
    ASSERT_TRUE(q.Push(Msg(3, NowMicros()), 0.0));
  });
  std::vector<Inbound> out;
  ASSERT_EQ(q.Pop(&out, 1.0, kAll), 1);
  EXPECT_EQ(q.PopRestOfBurst(&out, 0.2, 0.5, kAll), 2);
  producer.join();
  ASSERT_EQ(out.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(MessageUtime(out[i]), i);
  EXPECT_EQ(q.size(), 1);  // the late one is the next update's
}

TEST(IngestQueueTest, PopRestOfBurstDoesNotWaitForOldMessages) {
  IngestQueue q(8);
  // Received 10 s ago (it waited behind a long update): the burst is long over.
  std::vector<Inbound> out = {Msg(0, NowMicros() - 10'000'000)};
  ASSERT_TRUE(q.Push(Msg(1, NowMicros() - 9'000'000), 0.0));
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(q.PopRestOfBurst(&out, 5.0, 5.0, kAll), 1);  // takes what is queued, waits for nothing
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(4));
  // A continuous stream is cut after max_wait_s.
  out = {Msg(2, NowMicros())};
  std::atomic<bool> stop{false};
  std::thread producer([&] {
    for (int i = 3; !stop; ++i) {
      ASSERT_TRUE(q.Push(Msg(i, NowMicros()), 1.0));
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  const auto stream_start = std::chrono::steady_clock::now();
  EXPECT_GT(q.PopRestOfBurst(&out, 1.0, 0.05, kAll), 0);
  EXPECT_LT(std::chrono::steady_clock::now() - stream_start, std::chrono::milliseconds(900));
  stop = true;
  producer.join();
}

TEST(IngestQueueTest, CloseRefusesPushesButKeepsQueued) {
  IngestQueue q(3);
  ASSERT_TRUE(q.Push(Msg(0), 0.0));
  q.Close();
  EXPECT_TRUE(q.closed());
  EXPECT_FALSE(q.Push(Msg(1), 1.0));
  std::vector<Inbound> out;
  EXPECT_EQ(q.Pop(&out, 1.0, kAll), 1);
  EXPECT_EQ(q.Pop(&out, 1.0, kAll), 0);  // closed and empty: no wait
}

}  // namespace
}  // namespace slamd::server
