// Behaviour every Bus must have, as a value-parameterised suite. A test file instantiates it with
// a factory for its implementation:
//   INSTANTIATE_TEST_SUITE_P(Memq, BusConformanceTest, ::testing::Values(BusFactory{...}));
#pragma once

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "server/transport/bus.h"
#include "tests/server/transport/bus_test_helpers.h"

namespace slamd::server::testing {

class BusConformanceTest : public ::testing::TestWithParam<BusFactory> {
 protected:
  void SetUp() override {
    bus_ = GetParam().make();
    ASSERT_NE(bus_, nullptr);
  }
  // Subscribes, recording everything into `into`.
  Subscription Record(const std::string& pattern, std::vector<Received>* into) {
    auto sub =
        bus_->Subscribe(pattern, [into](std::string_view channel, std::span<const std::uint8_t> b) {
          into->push_back(Received{std::string(channel), {b.begin(), b.end()}});
        });
    EXPECT_TRUE(sub.ok()) << sub.status().ToString();
    return sub.ok() ? std::move(sub).value() : Subscription();
  }
  std::unique_ptr<Bus> bus_;
};

TEST_P(BusConformanceTest, PublishedBytesArriveOnTheirChannel) {
  std::vector<Received> got;
  Subscription sub = Record("CH_A", &got);
  ASSERT_TRUE(bus_->Publish("CH_A", Bytes({1, 2, 3, 255})).ok());
  ASSERT_TRUE(HandleUntil(*bus_, [&] { return !got.empty(); }).ok());
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].channel, "CH_A");
  EXPECT_EQ(got[0].bytes, Bytes({1, 2, 3, 255}));
}

TEST_P(BusConformanceTest, EmptyAndLargePayloads) {
  std::vector<Received> got;
  Subscription sub = Record("CH", &got);
  std::vector<std::uint8_t> large(1 << 20);
  for (size_t i = 0; i < large.size(); ++i) large[i] = static_cast<std::uint8_t>(i * 31);
  ASSERT_TRUE(bus_->Publish("CH", {}).ok());
  ASSERT_TRUE(bus_->Publish("CH", large).ok());
  ASSERT_TRUE(HandleUntil(*bus_, [&] { return got.size() >= 2; }).ok());
  ASSERT_EQ(got.size(), 2u);
  EXPECT_TRUE(got[0].bytes.empty());
  EXPECT_EQ(got[1].bytes, large);
}

TEST_P(BusConformanceTest, NamesMatchWholeChannelsAndRegexesMatchPatterns) {
  std::vector<Received> exact, pattern;
  Subscription a = Record("SLAMD_ODOMETRY", &exact);
  Subscription b = Record("SLAMD_.*", &pattern);
  std::vector<Received> end;
  Subscription c = Record("END", &end);
  for (const char* ch :
       {"SLAMD_ODOMETRY", "SLAMD_ODOMETRY2", "XSLAMD_ODOMETRY", "SLAMD_PRIOR", "OTHER"}) {
    ASSERT_TRUE(bus_->Publish(ch, Bytes({7})).ok());
  }
  ASSERT_TRUE(bus_->Publish("END", Bytes({0})).ok());
  ASSERT_TRUE(HandleUntil(*bus_, [&] { return !end.empty(); }).ok());
  ASSERT_EQ(exact.size(), 1u);
  EXPECT_EQ(exact[0].channel, "SLAMD_ODOMETRY");
  ASSERT_EQ(pattern.size(), 3u);
  EXPECT_EQ(pattern[0].channel, "SLAMD_ODOMETRY");
  EXPECT_EQ(pattern[1].channel, "SLAMD_ODOMETRY2");
  EXPECT_EQ(pattern[2].channel, "SLAMD_PRIOR");
}

TEST_P(BusConformanceTest, UnsubscribeStopsDelivery) {
  std::vector<Received> got, other;
  Subscription sub = Record("CH", &got);
  Subscription keep = Record("CH", &other);
  ASSERT_TRUE(bus_->Publish("CH", Bytes({1})).ok());
  ASSERT_TRUE(HandleUntil(*bus_, [&] { return got.size() == 1 && other.size() == 1; }).ok());
  sub.Unsubscribe();
  ASSERT_TRUE(bus_->Publish("CH", Bytes({2})).ok());
  ASSERT_TRUE(HandleUntil(*bus_, [&] { return other.size() == 2; }).ok());
  EXPECT_EQ(got.size(), 1u);
  EXPECT_EQ(other.size(), 2u);
}

TEST_P(BusConformanceTest, ABurstArrivesCompleteAndInOrder) {
  // LCM's default per-subscription queue (30) would drop most of these silently.
  constexpr int kCount = 3000;
  std::vector<Received> got;
  Subscription sub = Record("BURST", &got);
  for (int i = 0; i < kCount; ++i) {
    ASSERT_TRUE(bus_->Publish("BURST", Bytes({i & 0xff, (i >> 8) & 0xff})).ok());
  }
  ASSERT_TRUE(HandleUntil(
                  *bus_, [&] { return got.size() >= kCount; }, 5000)
                  .ok());
  ASSERT_EQ(got.size(), static_cast<size_t>(kCount));
  for (int i = 0; i < kCount; ++i) ASSERT_EQ(got[i].bytes, Bytes({i & 0xff, (i >> 8) & 0xff})) << i;
}

TEST_P(BusConformanceTest, PublishIsThreadSafe) {
  constexpr int kPerThread = 200;
  std::vector<Received> got;
  Subscription sub = Record("MT", &got);
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kPerThread; ++i) ASSERT_TRUE(bus_->Publish("MT", Bytes({t})).ok());
    });
  }
  ASSERT_TRUE(HandleUntil(
                  *bus_, [&] { return got.size() >= 3 * kPerThread; }, 5000)
                  .ok());
  for (auto& t : threads) t.join();
  EXPECT_EQ(got.size(), static_cast<size_t>(3 * kPerThread));
}

TEST_P(BusConformanceTest, ACallbackMayPublish) {
  std::vector<Received> replies;
  Subscription replier = bus_->Subscribe("REQ",
                                         [&](std::string_view, std::span<const std::uint8_t> b) {
                                           ASSERT_TRUE(bus_->Publish("REP", b).ok());
                                         })
                             .value();
  Subscription rec = Record("REP", &replies);
  ASSERT_TRUE(bus_->Publish("REQ", Bytes({9})).ok());
  ASSERT_TRUE(HandleUntil(*bus_, [&] { return !replies.empty(); }).ok());
  EXPECT_EQ(replies[0].bytes, Bytes({9}));
}

TEST_P(BusConformanceTest, AThrowingCallbackIsReportedAndDoesNotStopOthers) {
  std::vector<Received> got;
  Subscription thrower =
      bus_->Subscribe("CH", [](std::string_view,
                               std::span<const std::uint8_t>) { throw std::runtime_error("boom"); })
          .value();
  Subscription rec = Record("CH", &got);
  ASSERT_TRUE(bus_->Publish("CH", Bytes({1})).ok());
  core::Status error = HandleUntil(*bus_, [&] { return !got.empty(); });
  EXPECT_EQ(error.code(), core::StatusCode::kFailedPrecondition);
  EXPECT_NE(error.message().find("callback on channel 'CH' threw: boom"), std::string::npos)
      << error.message();
  EXPECT_EQ(got.size(), 1u);
  // The bus keeps working and the error is not reported twice.
  thrower.Unsubscribe();
  ASSERT_TRUE(bus_->Publish("CH", Bytes({2})).ok());
  EXPECT_TRUE(HandleUntil(*bus_, [&] { return got.size() == 2; }).ok());
  EXPECT_EQ(got.size(), 2u);
}

TEST_P(BusConformanceTest, TimeoutWithNothingToDo) {
  auto r = bus_->HandleOnce(0);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(*r, 0);
  const auto start = std::chrono::steady_clock::now();
  r = bus_->HandleOnce(30);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(*r, 0);
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(25));
  EXPECT_FALSE(bus_->HandleOnce(-1).ok());
}

// HandleFor waits in microseconds: not rounded down to a poll (nor refused), and a message that
// arrives meanwhile ends the wait.
TEST_P(BusConformanceTest, HandleForWaitsInMicrosecondsAndWakesOnArrival) {
  using std::chrono::microseconds;
  const auto start = std::chrono::steady_clock::now();
  auto r = bus_->HandleFor(microseconds(600));
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(*r, 0);
  EXPECT_GE(std::chrono::steady_clock::now() - start, microseconds(500));
  EXPECT_EQ(bus_->HandleFor(microseconds(-1)).status().code(), core::StatusCode::kInvalidArgument);

  std::vector<Received> got;
  Subscription sub = Record("LATE", &got);
  std::thread publisher([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_TRUE(bus_->Publish("LATE", Bytes({4})).ok());
  });
  const auto waited = std::chrono::steady_clock::now();
  r = bus_->HandleFor(std::chrono::seconds(20));
  const auto took = std::chrono::steady_clock::now() - waited;
  publisher.join();
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(*r, 1);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].bytes, Bytes({4}));
  EXPECT_LT(took, std::chrono::seconds(10));  // woken by the message, not by the timeout
}

TEST_P(BusConformanceTest, BadNamesAndPatternsAreInvalidArguments) {
  EXPECT_EQ(bus_->Publish("", Bytes({1})).code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(bus_->Publish(std::string(64, 'c'), Bytes({1})).code(),
            core::StatusCode::kInvalidArgument);
  auto noop = [](std::string_view, std::span<const std::uint8_t>) {};
  EXPECT_EQ(bus_->Subscribe("", noop).status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(bus_->Subscribe("CH", nullptr).status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(bus_->Subscribe("(unclosed", noop).status().code(), core::StatusCode::kInvalidArgument);
}

TEST_P(BusConformanceTest, SubscriptionMayOutliveTheBus) {
  std::vector<Received> got;
  Subscription sub = Record("CH", &got);
  bus_.reset();
  sub.Unsubscribe();  // must not touch the destroyed bus
  SUCCEED();
}

}  // namespace slamd::server::testing
