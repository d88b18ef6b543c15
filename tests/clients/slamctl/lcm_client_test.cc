// LcmClient: typed subscribe / publish, HandleUntil with a condition and a timeout, undecodable
// bytes counted, the default URL; over InProcessBus and LCM's memq://.
#include "clients/slamctl/lcm_client.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <chrono>

#include "server/transport/in_process_bus.h"
#include "slamd/status_t.hpp"

namespace slamd::clients {
namespace {

void RoundTrip(LcmClient& client) {
  int seen = 0;
  std::int64_t last = 0;
  ASSERT_TRUE(client
                  .Subscribe<slamd::status_t>("S_STATUS",
                                              [&](const slamd::status_t& s) {
                                                ++seen;
                                                last = s.update_sequence;
                                              })
                  .ok());
  slamd::status_t s{};
  s.update_sequence = 5;
  ASSERT_TRUE(client.Publish("S_STATUS", s).ok());
  auto got = client.HandleUntil([&] { return seen == 1; }, 2.0);
  ASSERT_TRUE(got.ok());
  EXPECT_TRUE(*got);
  EXPECT_EQ(last, 5);

  const std::uint8_t junk[4] = {1, 2, 3, 4};
  ASSERT_TRUE(client.PublishBytes("S_STATUS", junk).ok());
  ASSERT_TRUE(client.HandleUntil([&] { return client.decode_errors() == 1; }, 2.0).value());
  EXPECT_NE(client.last_error().find("S_STATUS"), std::string::npos) << client.last_error();
  EXPECT_EQ(seen, 1);

  const auto start = std::chrono::steady_clock::now();
  auto timeout = client.HandleUntil([] { return false; }, 0.1);
  ASSERT_TRUE(timeout.ok());
  EXPECT_FALSE(*timeout);
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(100));
  EXPECT_EQ(client.Drain().value(), 0);
}

TEST(LcmClientTest, InProcessBus) {
  LcmClient client(std::make_unique<server::InProcessBus>());
  RoundTrip(client);
}

TEST(LcmClientTest, LcmMemq) {
  auto client = LcmClient::Create("memq://");
  ASSERT_TRUE(client.ok()) << client.status().ToString();
  EXPECT_EQ((*client)->url(), "memq://");
  RoundTrip(**client);
}

TEST(LcmClientTest, DefaultUrl) {
  unsetenv("LCM_DEFAULT_URL");
  EXPECT_EQ(DefaultLcmUrl(), "udpm://239.255.76.67:7667?ttl=0");
  setenv("LCM_DEFAULT_URL", "memq://", 1);
  EXPECT_EQ(DefaultLcmUrl(), "memq://");
  auto client = LcmClient::Create("");
  ASSERT_TRUE(client.ok());
  EXPECT_EQ((*client)->url(), "memq://");
  unsetenv("LCM_DEFAULT_URL");
  EXPECT_FALSE(LcmClient::Create("nonsense://x").ok());
}

}  // namespace
}  // namespace slamd::clients
