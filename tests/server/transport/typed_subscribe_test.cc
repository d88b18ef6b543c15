// Typed Subscribe/Publish on both buses: decoding, every decode-error path, exceptions contained.
#include "server/transport/typed_subscribe.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "server/transport/in_process_bus.h"
#include "server/transport/lcm_bus.h"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "tests/server/ingest/test_messages.h"
#include "tests/server/transport/bus_test_helpers.h"

namespace slamd::server::testing {
namespace {

struct Errors {
  std::vector<std::string> channels;
  std::vector<core::Status> statuses;
  ErrorCallback callback() {
    return [this](std::string_view channel, const core::Status& s) {
      channels.emplace_back(channel);
      statuses.push_back(s);
    };
  }
};

class TypedSubscribeTest : public ::testing::TestWithParam<BusFactory> {
 protected:
  void SetUp() override { bus_ = GetParam().make(); }

  // Subscribes odometry_t on ODO; returns after handling until `n` callbacks of either kind ran.
  void Expect(int n) {
    ASSERT_TRUE(HandleUntil(*bus_, [&] {
                  return static_cast<int>(got_.size() + errors_.statuses.size()) >= n;
                }).ok());
  }
  Subscription SubscribeOdometry() {
    auto sub = Subscribe<slamd::odometry_t>(
        *bus_, "ODO", [this](std::string_view, const slamd::odometry_t& m) { got_.push_back(m); },
        errors_.callback());
    EXPECT_TRUE(sub.ok());
    return std::move(sub).value();
  }
  std::vector<std::uint8_t> Encoded(const slamd::odometry_t& m) {
    std::vector<std::uint8_t> bytes;
    EXPECT_TRUE(Encode(m, &bytes).ok());
    return bytes;
  }

  std::unique_ptr<Bus> bus_;
  std::vector<slamd::odometry_t> got_;
  Errors errors_;
};

TEST_P(TypedSubscribeTest, DecodesWhatPublishEncoded) {
  Subscription sub = SubscribeOdometry();
  const slamd::odometry_t sent = Odometry3();
  ASSERT_TRUE(Publish(*bus_, "ODO", sent).ok());
  Expect(1);
  ASSERT_EQ(got_.size(), 1u);
  EXPECT_TRUE(errors_.statuses.empty());
  EXPECT_EQ(got_[0].robot, sent.robot);
  EXPECT_EQ(got_[0].to_index, sent.to_index);
  EXPECT_EQ(got_[0].values, sent.values);
  EXPECT_EQ(got_[0].covariance, sent.covariance);
}

TEST_P(TypedSubscribeTest, AnotherTypeOnTheChannelIsAFingerprintError) {
  Subscription sub = SubscribeOdometry();
  ASSERT_TRUE(Publish(*bus_, "ODO", Prior(1)).ok());
  Expect(1);
  ASSERT_EQ(errors_.statuses.size(), 1u);
  EXPECT_TRUE(got_.empty());
  EXPECT_EQ(errors_.channels[0], "ODO");
  EXPECT_EQ(errors_.statuses[0].code(), core::StatusCode::kDataLoss);
  EXPECT_NE(errors_.statuses[0].message().find("slamd.odometry_t: fingerprint"), std::string::npos)
      << errors_.statuses[0].message();
}

TEST_P(TypedSubscribeTest, TruncatedShortAndTrailingBytesAreDecodeErrors) {
  Subscription sub = SubscribeOdometry();
  std::vector<std::uint8_t> bytes = Encoded(Odometry2());
  std::vector<std::uint8_t> truncated(bytes.begin(), bytes.end() - 5);
  std::vector<std::uint8_t> trailing = bytes;
  trailing.push_back(0);
  ASSERT_TRUE(bus_->Publish("ODO", truncated).ok());
  ASSERT_TRUE(bus_->Publish("ODO", Bytes({1, 2, 3})).ok());
  ASSERT_TRUE(bus_->Publish("ODO", trailing).ok());
  Expect(3);
  ASSERT_EQ(errors_.statuses.size(), 3u);
  EXPECT_TRUE(got_.empty());
  EXPECT_NE(errors_.statuses[0].message().find("do not decode"), std::string::npos)
      << errors_.statuses[0].message();
  EXPECT_NE(errors_.statuses[1].message().find("shorter than the 8-byte type fingerprint"),
            std::string::npos);
  EXPECT_NE(errors_.statuses[2].message().find("1 trailing bytes"), std::string::npos);
}

TEST_P(TypedSubscribeTest, AHostileCountIsRefusedWithoutAllocating) {
  Subscription sub = SubscribeOdometry();
  slamd::odometry_t m = Odometry2();
  std::vector<std::uint8_t> bytes = Encoded(m);
  // num_values sits after hash (8), utime (8), robot (4 + 6), from, to (16), dimension (1).
  const size_t at = 8 + 8 + 4 + m.robot.size() + 1 + 16 + 1;
  ASSERT_EQ(bytes[at + 3], 3);  // big-endian 3
  for (std::int32_t count : {0x7fffffff, -1}) {
    for (int i = 0; i < 4; ++i)
      bytes[at + i] = static_cast<std::uint8_t>((count >> (24 - 8 * i)) & 0xff);
    ASSERT_TRUE(bus_->Publish("ODO", bytes).ok());
  }
  Expect(2);
  ASSERT_EQ(errors_.statuses.size(), 2u);
  for (const auto& s : errors_.statuses)
    EXPECT_EQ(s.code(), core::StatusCode::kDataLoss) << s.message();
}

TEST_P(TypedSubscribeTest, AThrowingHandlerReachesOnErrorAndTheBusKeepsGoing) {
  int calls = 0;
  auto sub = Subscribe<slamd::odometry_t>(
      *bus_, "ODO",
      [&](std::string_view, const slamd::odometry_t&) {
        if (++calls == 1) throw std::runtime_error("estimator exploded");
      },
      errors_.callback());
  ASSERT_TRUE(sub.ok());
  ASSERT_TRUE(Publish(*bus_, "ODO", Odometry2()).ok());
  ASSERT_TRUE(Publish(*bus_, "ODO", Odometry2()).ok());
  // No exception escapes to the bus: HandleOnce reports nothing.
  ASSERT_TRUE(HandleUntil(*bus_, [&] { return calls >= 2; }).ok());
  EXPECT_EQ(calls, 2);
  ASSERT_EQ(errors_.statuses.size(), 1u);
  EXPECT_EQ(errors_.statuses[0].code(), core::StatusCode::kFailedPrecondition);
  EXPECT_NE(errors_.statuses[0].message().find("estimator exploded"), std::string::npos);
}

TEST_P(TypedSubscribeTest, AThrowingErrorCallbackIsReportedByHandleOnce) {
  auto sub = Subscribe<slamd::odometry_t>(
      *bus_, "ODO", [](std::string_view, const slamd::odometry_t&) {},
      [](std::string_view, const core::Status&) { throw std::logic_error("bad error handler"); });
  ASSERT_TRUE(sub.ok());
  ASSERT_TRUE(bus_->Publish("ODO", Bytes({1})).ok());
  const core::Status s = HandleUntil(
      *bus_, [] { return false; }, 100);
  EXPECT_EQ(s.code(), core::StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("bad error handler"), std::string::npos) << s.message();
}

TEST_P(TypedSubscribeTest, NullErrorCallbackDropsErrorsQuietly) {
  int calls = 0;
  auto sub = Subscribe<slamd::odometry_t>(
      *bus_, "ODO", [&](std::string_view, const slamd::odometry_t&) { ++calls; }, nullptr);
  ASSERT_TRUE(sub.ok());
  ASSERT_TRUE(bus_->Publish("ODO", Bytes({1, 2})).ok());
  ASSERT_TRUE(Publish(*bus_, "ODO", Odometry2()).ok());
  EXPECT_TRUE(HandleUntil(*bus_, [&] { return calls == 1; }).ok());
  EXPECT_EQ(calls, 1);
  EXPECT_FALSE(Subscribe<slamd::odometry_t>(*bus_, "ODO", nullptr, nullptr).ok());
}

std::unique_ptr<Bus> MakeMemqBus() {
  return std::move(LcmBus::Create(LcmBusParams{.url = "memq://"})).value();
}

INSTANTIATE_TEST_SUITE_P(
    Buses, TypedSubscribeTest,
    ::testing::Values(BusFactory{"InProcessBus", [] { return std::make_unique<InProcessBus>(); }},
                      BusFactory{"LcmBusMemq", MakeMemqBus}),
    [](const auto& info) { return info.param.name; });

TEST(DecodeAs, EveryPrefixOfAMessageFailsCleanly) {
  std::vector<std::uint8_t> bytes;
  ASSERT_TRUE(Encode(Odometry3(), &bytes).ok());
  slamd::odometry_t m;
  for (size_t n = 0; n < bytes.size(); ++n) {
    EXPECT_EQ(internal::DecodeAs(std::span(bytes.data(), n), &m).code(),
              core::StatusCode::kDataLoss)
        << n;
  }
  EXPECT_TRUE(internal::DecodeAs(std::span<const std::uint8_t>(bytes), &m).ok());
}

}  // namespace
}  // namespace slamd::server::testing
