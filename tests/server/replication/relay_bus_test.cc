// The framing of forwarded queries and relayed answers between map shards, and RelayBus's checks
// that need no NATS server (the round trip through real shards is in
// tests/integration/shards_ha_test.cc).
#include "server/replication/relay_bus.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace slamd::server {
namespace {

TEST(RelayFrame, RoundTripsTagAndBody) {
  const std::vector<std::uint8_t> body = {0, 1, 2, 255};
  const std::vector<std::uint8_t> framed = Frame("QUERY_REPLY", body);
  ASSERT_EQ(framed.size(), 1 + 11 + body.size());
  const std::optional<Framed> parts = Unframe(framed);
  ASSERT_TRUE(parts.has_value());
  EXPECT_EQ(parts->tag, "QUERY_REPLY");
  EXPECT_EQ(std::vector<std::uint8_t>(parts->body.begin(), parts->body.end()), body);
  // An empty body is a body.
  const std::vector<std::uint8_t> tag_only = Frame("S1", {});
  const std::optional<Framed> empty = Unframe(tag_only);  // views into tag_only
  ASSERT_TRUE(empty.has_value());
  EXPECT_EQ(empty->tag, "S1");
  EXPECT_TRUE(empty->body.empty());
}

TEST(RelayFrame, RejectsTruncatedOrTaglessPayloads) {
  EXPECT_FALSE(Unframe({}).has_value());
  const std::vector<std::uint8_t> no_tag = {0, 7, 7};
  EXPECT_FALSE(Unframe(no_tag).has_value());
  std::vector<std::uint8_t> framed = Frame("MAP", std::vector<std::uint8_t>{9});
  for (std::size_t cut = 1; cut < 4; ++cut) {  // inside the tag
    EXPECT_FALSE(Unframe(std::span(framed).first(cut)).has_value()) << cut;
  }
  EXPECT_TRUE(Unframe(std::span(framed).first(4)).has_value());  // the tag whole, no body
}

TEST(RelayBus, PublishesOnlyChannelsOfItsPrefixAndNeverSubscribes) {
  RelayBus relay(nullptr, "slamd.shards.S1.reply", "SLAMD_");  // refused before any NATS call
  const std::vector<std::uint8_t> bytes = {1};
  for (const char* channel : {"OTHER_QUERY_REPLY", "SLAMD_", "SLAM"}) {
    const core::Status s = relay.Publish(channel, bytes);
    EXPECT_EQ(s.code(), core::StatusCode::kInvalidArgument) << channel;
    EXPECT_NE(s.message().find("prefix 'SLAMD_'"), std::string::npos) << s.message();
  }
  EXPECT_FALSE(relay.Subscribe("SLAMD_.*", nullptr).ok());
  EXPECT_FALSE(relay.HandleOnce(0).ok());
}

}  // namespace
}  // namespace slamd::server
