// LcmBus on memq:// (in-process, no network). udpm:// is tested only in lcm_bus_netns_test.cc.
#include "server/transport/lcm_bus.h"

#include <gtest/gtest.h>

#include "tests/server/transport/bus_conformance.h"

namespace slamd::server::testing {
namespace {

std::unique_ptr<Bus> MakeMemq() {
  auto bus = LcmBus::Create(LcmBusParams{.url = "memq://"});
  EXPECT_TRUE(bus.ok()) << bus.status().ToString();
  return bus.ok() ? std::unique_ptr<Bus>(std::move(bus).value()) : nullptr;
}

INSTANTIATE_TEST_SUITE_P(Memq, BusConformanceTest,
                         ::testing::Values(BusFactory{"LcmBusMemq", MakeMemq}),
                         [](const auto& info) { return info.param.name; });

TEST(LcmBus, ParamsAreValidated) {
  auto empty = LcmBus::Create(LcmBusParams{});
  EXPECT_EQ(empty.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(empty.status().message().find("url is empty"), std::string::npos);
  auto zero = LcmBus::Create(LcmBusParams{.url = "memq://", .queue_capacity = 0});
  EXPECT_EQ(zero.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(zero.status().message().find("queue_capacity = 0; violates >= 1"), std::string::npos);
}

TEST(LcmBus, UnknownProviderIsAnIoErrorNamingTheUrl) {
  auto bus = LcmBus::Create(LcmBusParams{.url = "nosuchprovider://x"});
  ASSERT_FALSE(bus.ok());
  EXPECT_EQ(bus.status().code(), core::StatusCode::kIoError);
  EXPECT_NE(bus.status().message().find("'nosuchprovider://x'"), std::string::npos)
      << bus.status().message();
  // The multicast-route advice is for udpm:// only.
  EXPECT_EQ(bus.status().message().find("ip route add"), std::string::npos);
}

TEST(LcmBus, EachMemqBusIsItsOwnNetwork) {
  auto a = LcmBus::Create(LcmBusParams{.url = "memq://"});
  auto b = LcmBus::Create(LcmBusParams{.url = "memq://"});
  ASSERT_TRUE(a.ok() && b.ok());
  int got = 0;
  auto sub = (*b)->Subscribe("X", [&](std::string_view, std::span<const std::uint8_t>) { ++got; });
  ASSERT_TRUE(sub.ok());
  ASSERT_TRUE((*a)->Publish("X", Bytes({1})).ok());
  ASSERT_TRUE((*b)->HandleOnce(20).ok());
  EXPECT_EQ(got, 0);
  EXPECT_EQ((*a)->url(), "memq://");
}

TEST(LcmBus, HandleOnceDispatchesOneMessage) {
  auto bus = LcmBus::Create(LcmBusParams{.url = "memq://"});
  ASSERT_TRUE(bus.ok());
  int got = 0;
  auto sub =
      (*bus)->Subscribe("X", [&](std::string_view, std::span<const std::uint8_t>) { ++got; });
  ASSERT_TRUE(sub.ok());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE((*bus)->Publish("X", Bytes({i})).ok());
  EXPECT_EQ(*(*bus)->HandleOnce(100), 1);
  EXPECT_EQ(got, 1);
}

}  // namespace
}  // namespace slamd::server::testing
