#include "server/transport/in_process_bus.h"

#include <gtest/gtest.h>

#include "tests/server/transport/bus_conformance.h"

namespace slamd::server::testing {
namespace {

INSTANTIATE_TEST_SUITE_P(InProcess, BusConformanceTest,
                         ::testing::Values(BusFactory{
                             "InProcessBus", [] { return std::make_unique<InProcessBus>(); }}),
                         [](const auto& info) { return info.param.name; });

TEST(InProcessBus, DispatchesEverythingQueuedInOneCallInPublishOrder) {
  InProcessBus bus;
  std::vector<std::string> order;
  auto a = bus.Subscribe(
      "A", [&](std::string_view ch, std::span<const std::uint8_t>) { order.emplace_back(ch); });
  auto b = bus.Subscribe(
      "B", [&](std::string_view ch, std::span<const std::uint8_t>) { order.emplace_back(ch); });
  ASSERT_TRUE(a.ok() && b.ok());
  for (const char* ch : {"A", "B", "A", "C"}) ASSERT_TRUE(bus.Publish(ch, {}).ok());
  EXPECT_EQ(bus.pending(), 4);
  auto n = bus.HandleOnce(0);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 4);  // C had no subscriber but was taken off the queue
  EXPECT_EQ(order, (std::vector<std::string>{"A", "B", "A"}));
  EXPECT_EQ(bus.pending(), 0);
}

TEST(InProcessBus, MessagesPublishedByACallbackWaitForTheNextCall) {
  InProcessBus bus;
  int pings = 0;
  auto sub = bus.Subscribe("PING", [&](std::string_view, std::span<const std::uint8_t>) {
    if (++pings < 3) {
      ASSERT_TRUE(bus.Publish("PING", {}).ok());
    }
  });
  ASSERT_TRUE(sub.ok());
  ASSERT_TRUE(bus.Publish("PING", {}).ok());
  EXPECT_EQ(*bus.HandleOnce(0), 1);
  EXPECT_EQ(pings, 1);
  EXPECT_EQ(*bus.HandleOnce(0), 1);
  EXPECT_EQ(*bus.HandleOnce(0), 1);
  EXPECT_EQ(*bus.HandleOnce(0), 0);
  EXPECT_EQ(pings, 3);
}

TEST(InProcessBus, HandleOnceWakesWhenAnotherThreadPublishes) {
  InProcessBus bus;
  int got = 0;
  auto sub = bus.Subscribe("X", [&](std::string_view, std::span<const std::uint8_t>) { ++got; });
  ASSERT_TRUE(sub.ok());
  std::thread publisher([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_TRUE(bus.Publish("X", {}).ok());
  });
  const auto start = std::chrono::steady_clock::now();
  auto n = bus.HandleOnce(5000);
  publisher.join();
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(*n, 1);
  EXPECT_EQ(got, 1);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
}

}  // namespace
}  // namespace slamd::server::testing
