// The replication options and helpers that need no NATS server: validation messages name the
// field, server lists split, libnats statuses map to Unavailable (retry) or IoError.
#include <gtest/gtest.h>
#include <nats/nats.h>

#include <string>
#include <vector>

#include "server/replication/leader_lease.h"
#include "server/replication/nats_client.h"
#include "server/replication/stream_journal.h"

namespace slamd::server {
namespace {

TEST(ReplicationOptions, SplitServersDropsEmptyEntriesAndSpaces) {
  EXPECT_EQ(SplitServers("nats://a:1, nats://b:2,,"),
            (std::vector<std::string>{"nats://a:1", "nats://b:2"}));
  EXPECT_TRUE(SplitServers("").empty());
}

TEST(ReplicationOptions, ValidationNamesTheField) {
  const NatsOptions nats{.servers = {"nats://127.0.0.1:4222"}};
  EXPECT_TRUE((StreamJournalOptions{.nats = nats, .source = "x"}).Validate().ok());
  const std::vector<std::pair<StreamJournalOptions, std::string>> bad = {
      {{.nats = {}, .source = "x"}, "NatsOptions::servers: empty"},
      {{.nats = {.servers = {"tcp://a:1"}}, .source = "x"}, "not a nats:// URL"},
      {{.nats = nats, .stream = "a.b", .source = "x"}, "StreamJournalOptions::stream = 'a.b'"},
      {{.nats = nats, .subject = "a.*", .source = "x"}, "StreamJournalOptions::subject"},
      {{.nats = nats, .replicas = 7, .source = "x"}, "replicas = 7; violates <= 5"},
      {{.nats = nats, .max_batch_bytes = 100, .source = "x"}, "max_batch_bytes = 100"},
      {{.nats = nats}, "StreamJournalOptions::source: empty"}};
  for (const auto& [options, message] : bad) {
    const core::Status s = options.Validate();
    EXPECT_EQ(s.code(), core::StatusCode::kInvalidArgument) << message;
    EXPECT_NE(s.message().find(message), std::string::npos) << s.message();
  }
  EXPECT_TRUE((LeaderLeaseOptions{.nats = nats, .holder = "h"}).Validate().ok());
  EXPECT_NE((LeaderLeaseOptions{.nats = nats, .ttl_ms = 10, .holder = "h"})
                .Validate()
                .message()
                .find("ttl_ms = 10"),
            std::string::npos);
  EXPECT_NE((LeaderLeaseOptions{.nats = nats}).Validate().message().find("holder: empty"),
            std::string::npos);
}

TEST(ReplicationOptions, SubjectsAreLiteralTokensJoinedByDots) {
  for (const char* good : {"slamd", "slamd.journal", "a-b.c_d.9"}) EXPECT_TRUE(IsNatsSubject(good));
  for (const char* bad : {"", ".a", "a.", "a..b", "a.*", "a.>", "a b"}) {
    EXPECT_FALSE(IsNatsSubject(bad)) << bad;
  }
}

TEST(ReplicationOptions, NatsStatusMapsRetryableFailuresToUnavailable) {
  EXPECT_TRUE(NatsStatus("x", NATS_OK).ok());
  EXPECT_EQ(NatsStatus("x", NATS_TIMEOUT).code(), core::StatusCode::kUnavailable);
  EXPECT_EQ(NatsStatus("x", NATS_NO_SERVER).code(), core::StatusCode::kUnavailable);
  const core::Status other = NatsStatus("append", NATS_ERR, 10071);
  EXPECT_EQ(other.code(), core::StatusCode::kIoError);
  EXPECT_NE(other.message().find("append"), std::string::npos);
  EXPECT_NE(other.message().find("JetStream error 10071"), std::string::npos);
}

TEST(ReplicationOptions, UnreachableNatsIsUnavailableNamingTheServers) {
  // Nothing listens on port 1 of loopback: refused at once.
  auto client = NatsClient::Connect({.servers = {"nats://127.0.0.1:1"}, .connect_timeout_ms = 200});
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.status().code(), core::StatusCode::kUnavailable) << client.status().ToString();
  EXPECT_NE(client.status().message().find("nats://127.0.0.1:1"), std::string::npos);
}

}  // namespace
}  // namespace slamd::server
