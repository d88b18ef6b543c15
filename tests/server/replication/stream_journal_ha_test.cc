// The replicated journal against real nats-server processes: a JetStream cluster of three on
// loopback inside this test's own network namespace (scripts/netns-run; ctest label ha).
// Records staged and committed come back from the stream in order, byte for byte, across batch
// cuts and records longer than a batch; without a quorum Commit is Unavailable and keeps the
// records, and after the quorum returns they are in the stream exactly once; a second writer is
// refused; StartReplication sends a data directory's journal, and after a crash only what the
// stream lacks.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "server/journal/journal.h"
#include "server/journal/journal_format.h"
#include "server/journal/read_journal.h"
#include "server/replication/replicated_journal.h"
#include "server/replication/stream_journal.h"
#include "server/replication/stream_reader.h"
#include "slamd_proto/journal.pb.h"
#include "tests/testing/nats_cluster.h"
#include "tests/testing/processes.h"

namespace slamd::server {
namespace {

using testing::NatsCluster;

journal::JournalRecord Message(std::int64_t sequence, size_t payload_bytes) {
  journal::JournalRecord r;
  journal::InboundMessage* m = r.mutable_message();
  m->set_channel("SLAMD_ODOMETRY");
  m->set_message_type("odometry_t");
  m->set_lcm_payload(std::string(payload_bytes, static_cast<char>('a' + sequence % 26)));
  m->set_sequence(sequence);
  return r;
}

std::string Frame(const journal::JournalRecord& r) {
  std::string frame;
  internal::AppendJournalFrame(r.SerializeAsString(), &frame);
  return frame;
}

// Each test has its own stream on the suite's cluster.
class StreamJournalTest : public testing::SharedNatsClusterTest {
 protected:
  StreamJournalOptions Options(const std::string& source = "0123456789abcdef") const {
    return {.nats = {.servers = cluster_->UrlList()},
            .stream = test_name(),
            .subject = "test." + test_name(),
            .ack_timeout_ms = 2000,
            .max_batch_bytes = 4096,
            .source = source};
  }
  // Open, retried while the cluster elects its JetStream leader.
  std::unique_ptr<StreamJournal> OpenWhenReady(const StreamJournalOptions& options) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (true) {
      auto opened = StreamJournal::Open(options);
      if (opened.ok()) return std::move(opened).value();
      if (std::chrono::steady_clock::now() > deadline) {
        ADD_FAILURE() << opened.status().ToString();
        return nullptr;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
};

TEST_F(StreamJournalTest, RecordsComeBackInOrderAcrossBatchesAndLongRecords) {
  const StreamJournalOptions options = Options();
  std::unique_ptr<StreamJournal> stream = OpenWhenReady(options);
  ASSERT_NE(stream, nullptr);
  EXPECT_EQ(stream->stream_end().sequence, 0);
  std::vector<journal::JournalRecord> sent;
  std::int64_t end = 0;
  for (int commit = 0; commit < 5; ++commit) {
    for (int k = 0; k < 7; ++k) {
      const std::int64_t seq = static_cast<std::int64_t>(sent.size()) + 1;
      // Mostly small records, some longer than a batch (cut across stream messages).
      sent.push_back(Message(seq, k == 3 ? 10000 : 300 + 50 * k));
      const std::string frame = Frame(sent.back());
      end += static_cast<std::int64_t>(frame.size());
      stream->Stage(frame, {.last_message = seq, .journal_end = end});
    }
    ASSERT_TRUE(stream->Commit().ok());
    EXPECT_EQ(stream->pending_bytes(), 0);
    EXPECT_EQ(stream->stream_end().journal_end, end);
    EXPECT_EQ(stream->stream_end().last_message, static_cast<std::int64_t>(sent.size()));
  }
  EXPECT_GT(stream->batches_published(), 5 * 2);  // 4 KiB batches: cut
  const std::vector<journal::JournalRecord> got = testing::ReadWholeStream(options);
  ASSERT_EQ(got.size(), sent.size());
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i].SerializeAsString(), sent[i].SerializeAsString()) << i;
  }
  // A writer opened later sees where the stream ends.
  std::unique_ptr<StreamJournal> again = OpenWhenReady(options);
  ASSERT_NE(again, nullptr);
  EXPECT_EQ(again->stream_end().sequence, stream->stream_end().sequence);
  EXPECT_EQ(again->stream_end().journal_end, end);
  EXPECT_EQ(again->stream_end().source, options.source);
}

TEST_F(StreamJournalTest, WithoutAQuorumCommitIsUnavailableAndKeepsTheRecords) {
  StreamJournalOptions options = Options();
  options.ack_timeout_ms = 500;
  std::unique_ptr<StreamJournal> stream = OpenWhenReady(options);
  ASSERT_NE(stream, nullptr);
  std::vector<journal::JournalRecord> sent;
  std::int64_t end = 0;
  auto stage = [&](int n) {
    for (int k = 0; k < n; ++k) {
      const std::int64_t seq = static_cast<std::int64_t>(sent.size()) + 1;
      sent.push_back(Message(seq, 200));
      const std::string frame = Frame(sent.back());
      end += static_cast<std::int64_t>(frame.size());
      stream->Stage(frame, {.last_message = seq, .journal_end = end});
    }
  };
  stage(10);
  ASSERT_TRUE(stream->Commit().ok());
  cluster_->Kill(1);
  cluster_->Kill(2);
  stage(10);
  const core::Status down = stream->Commit();
  EXPECT_EQ(down.code(), core::StatusCode::kUnavailable) << down.ToString();
  EXPECT_GT(stream->pending_bytes(), 0);
  stage(5);  // more while it is down
  EXPECT_FALSE(stream->Commit().ok());
  cluster_->Start(1);
  cluster_->Start(2);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  core::Status up = stream->Commit();
  while (!up.ok() && std::chrono::steady_clock::now() < deadline) {
    ASSERT_EQ(up.code(), core::StatusCode::kUnavailable) << up.ToString();
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    up = stream->Commit();
  }
  ASSERT_TRUE(up.ok()) << up.ToString();
  EXPECT_EQ(stream->pending_bytes(), 0);
  const std::vector<journal::JournalRecord> got = testing::ReadWholeStream(options);
  ASSERT_EQ(got.size(), sent.size());  // each exactly once, in order
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i].message().sequence(), static_cast<std::int64_t>(i) + 1);
  }
}

TEST_F(StreamJournalTest, ASecondWriterIsRefused) {
  const StreamJournalOptions options = Options();
  std::unique_ptr<StreamJournal> first = OpenWhenReady(options);
  ASSERT_NE(first, nullptr);
  std::unique_ptr<StreamJournal> second = OpenWhenReady(Options("fedcba9876543210"));
  ASSERT_NE(second, nullptr);
  const std::string frame = Frame(Message(1, 100));
  second->Stage(frame, {.last_message = 1, .journal_end = 16 + 100});
  ASSERT_TRUE(second->Commit().ok());
  first->Stage(frame, {.last_message = 1, .journal_end = 16 + 100});
  const core::Status refused = first->Commit();
  EXPECT_EQ(refused.code(), core::StatusCode::kFailedPrecondition) << refused.ToString();
  EXPECT_NE(refused.message().find("another writer"), std::string::npos) << refused.message();
}

TEST_F(StreamJournalTest, StartReplicationSendsWhatTheStreamLacks) {
  const std::string data_dir = dir_ + "/" + test_name() + "_data";
  std::filesystem::create_directories(data_dir);
  auto open_journal = [&] {
    auto recovered = ReadJournal(data_dir);
    std::int64_t last = 0;
    if (recovered.ok()) {
      for (const journal::JournalRecord& r : recovered.value().records) {
        if (r.has_message()) last = r.message().sequence();
      }
    }
    auto segments = ListJournalSegments(data_dir);
    EXPECT_TRUE(segments.ok());
    return Journal::Open(data_dir, {}, segments.value(), last).value();
  };
  auto append = [](Journal* journal, int n) {
    for (int k = 0; k < n; ++k) {
      const std::vector<std::uint8_t> payload(120, static_cast<std::uint8_t>(k));
      ASSERT_TRUE(journal->AppendMessage("SLAMD_ODOMETRY", "odometry_t", payload, k).ok());
    }
  };
  StreamJournalOptions options = Options();
  std::unique_ptr<StreamJournal> waited = OpenWhenReady(options);  // the cluster is up
  ASSERT_NE(waited, nullptr);
  waited.reset();
  {
    std::unique_ptr<Journal> journal = open_journal();
    append(journal.get(), 5);  // before replication: sent at its start
    auto stream = StartReplication(data_dir, options, journal.get());
    ASSERT_TRUE(stream.ok()) << stream.status().ToString();
    append(journal.get(), 4);
    ASSERT_TRUE(stream.value()->Commit().ok());
    append(journal.get(), 3);  // never committed: the crash
    journal->set_replica(nullptr);
  }
  std::unique_ptr<Journal> journal = open_journal();
  auto restarted = StartReplication(data_dir, options, journal.get());
  ASSERT_TRUE(restarted.ok()) << restarted.status().ToString();
  EXPECT_EQ(restarted.value()->stream_end().journal_end, journal->offset());
  const std::vector<journal::JournalRecord> got = testing::ReadWholeStream(options);
  auto local = ReadJournal(data_dir);
  ASSERT_TRUE(local.ok());
  ASSERT_EQ(got.size(), local.value().records.size());
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].SerializeAsString(), local.value().records[i].SerializeAsString()) << i;
  }
  EXPECT_EQ(got.size(), 12u);

  // Another data directory is behind this stream: refused.
  const std::string other_dir = dir_ + "/" + test_name() + "_other";
  std::filesystem::create_directories(other_dir);
  std::unique_ptr<Journal> other = Journal::Open(other_dir, {}, {}, 0).value();
  auto refused = StartReplication(other_dir, options, other.get());
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), core::StatusCode::kFailedPrecondition);
  EXPECT_NE(refused.status().message().find("standby"), std::string::npos);
  journal->set_replica(nullptr);
}

}  // namespace
}  // namespace slamd::server
