// LcmBus over real UDP multicast (udpm://, ttl=0). Runs ONLY inside a private network namespace
// made by scripts/netns-run (ctest does this; label netns). Before anything is sent, every test
// checks that /proc/self/net/dev lists nothing but `lo` and refuses (fails) otherwise, so it can
// never multicast on a real network.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <string>
#include <thread>

#include "server/transport/lcm_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/odometry_t.hpp"
#include "tests/server/ingest/test_messages.h"
#include "tests/server/transport/bus_test_helpers.h"

namespace slamd::server::testing {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

// The interfaces this process's network namespace has, from /proc/self/net/dev.
std::set<std::string> Interfaces() {
  std::ifstream in("/proc/self/net/dev");
  std::set<std::string> names;
  std::string line;
  for (int i = 0; std::getline(in, line); ++i) {
    if (i < 2) continue;  // two header lines
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    const size_t start = line.find_first_not_of(' ');
    names.insert(line.substr(start, colon - start));
  }
  return names;
}

class UdpmTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::set<std::string> interfaces = Interfaces();
    if (interfaces != std::set<std::string>{"lo"}) {
      std::string list;
      for (const auto& name : interfaces) list += " " + name;
      GTEST_FAIL() << "refusing to send UDP multicast: this is not a private network namespace "
                      "(interfaces:"
                   << list << "). Run through scripts/netns-run (ctest -L netns).";
    }
  }

  static std::unique_ptr<LcmBus> Make(int queue_capacity = LcmBusParams{}.queue_capacity) {
    auto bus = LcmBus::Create(LcmBusParams{.url = kUrl, .queue_capacity = queue_capacity});
    EXPECT_TRUE(bus.ok()) << bus.status().ToString();
    return bus.ok() ? std::move(bus).value() : nullptr;
  }
};

TEST_F(UdpmTest, TypedMessagesTravelBetweenTwoBuses) {
  auto sender = Make();
  auto receiver = Make();
  ASSERT_TRUE(sender && receiver);
  std::vector<slamd::odometry_t> got;
  int errors = 0;
  auto sub = Subscribe<slamd::odometry_t>(
      *receiver, "SLAMD_ODOMETRY",
      [&](std::string_view, const slamd::odometry_t& m) { got.push_back(m); },
      [&](std::string_view, const core::Status&) { ++errors; });
  ASSERT_TRUE(sub.ok());
  constexpr int kCount = 100;
  for (int i = 0; i < kCount; ++i) {
    slamd::odometry_t m = i % 2 ? Odometry2() : Odometry3();
    m.from_index = i;
    m.to_index = i + 1;
    ASSERT_TRUE(Publish(*sender, "SLAMD_ODOMETRY", m).ok());
  }
  ASSERT_TRUE(HandleUntil(
                  *receiver, [&] { return got.size() >= kCount; }, 5000)
                  .ok());
  ASSERT_EQ(got.size(), static_cast<size_t>(kCount));
  EXPECT_EQ(errors, 0);
  for (int i = 0; i < kCount; ++i) {
    EXPECT_EQ(got[i].from_index, i);
    EXPECT_EQ(got[i].values, (i % 2 ? Odometry2() : Odometry3()).values);
  }
}

TEST_F(UdpmTest, RaisedQueueCapacityKeepsABurstThatLcmsDefaultWouldDrop) {
  // Messages arrive (LCM's receive thread queues them) while nobody calls HandleOnce.
  auto burst = [](int capacity) -> int {
    auto sender = Make();
    auto receiver = Make(capacity);
    if (!sender || !receiver) return -1;
    int got = 0;
    auto sub = receiver->Subscribe("BURST",
                                   [&](std::string_view, std::span<const std::uint8_t>) { ++got; });
    if (!sub.ok()) return -1;
    const std::vector<std::uint8_t> payload(100, 0x5a);
    for (int i = 0; i < 500; ++i) {  // ~5 k msg/s: well below where UDP itself starts to lose
      if (!sender->Publish("BURST", payload).ok()) return -1;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    while (true) {
      auto n = receiver->HandleOnce(50);
      if (!n.ok() || *n == 0) break;
    }
    return got;
  };
  EXPECT_EQ(burst(LcmBusParams{}.queue_capacity), 500);
  const int with_default = burst(30);  // the control: LCM's default capacity drops most of them
  EXPECT_LE(with_default, 100);
  std::printf("burst of 500 with LCM's default queue capacity 30: %d received\n", with_default);
}

TEST_F(UdpmTest, AsksForALargeReceiveBufferUnlessTheUrlNamesOne) {
  auto bus = Make();
  ASSERT_TRUE(bus);
  EXPECT_EQ(bus->url(), std::string(kUrl) + "&recv_buf_size=4194304");
  auto own = LcmBus::Create(LcmBusParams{.url = std::string(kUrl) + "&recv_buf_size=65536"});
  ASSERT_TRUE(own.ok());
  EXPECT_EQ(own.value()->url(), std::string(kUrl) + "&recv_buf_size=65536");
  auto none = LcmBus::Create(LcmBusParams{.url = kUrl, .udpm_receive_buffer_bytes = 0});
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none.value()->url(), kUrl);
}

TEST_F(UdpmTest, WithoutAMulticastRouteCreateExplainsTheFix) {
  // Only ever inside the namespace (checked in SetUp, and again here because this edits routes):
  // remove the route, try, put it back.
  ASSERT_EQ(Interfaces(), std::set<std::string>{"lo"});
  ASSERT_EQ(std::system("ip route del 224.0.0.0/4 dev lo"), 0);
  auto bus = LcmBus::Create(LcmBusParams{.url = kUrl});
  ASSERT_EQ(std::system("ip route add 224.0.0.0/4 dev lo"), 0);
  ASSERT_FALSE(bus.ok());
  EXPECT_EQ(bus.status().code(), core::StatusCode::kIoError);
  EXPECT_NE(bus.status().message().find("ip route add 224.0.0.0/4 dev lo"), std::string::npos)
      << bus.status().message();
  EXPECT_TRUE(Make() != nullptr);  // and with the route back it works again
}

}  // namespace
}  // namespace slamd::server::testing
