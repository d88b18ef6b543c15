// The replicated journal against real nats-server processes: a JetStream cluster of three on
// loopback inside this test's own network namespace (scripts/netns-run; ctest label ha).
// Records staged and committed come back from the stream in order, byte for byte, across batch
// cuts and records longer than a batch; without a quorum Commit is Unavailable and keeps the
// records, and after the quorum returns they are in the stream exactly once; a second writer is
// refused; StartReplication sends a data directory's journal, and after a crash only what the
// stream lacks. A reader skips a batch sent again and refuses a gap. Snapshots stored in NATS
// come back whole (the newest; one whose writer stopped half-way is passed over), and truncate
// the journal stream so that it is read from where the oldest kept one says.
#include <gtest/gtest.h>
#include <nats/nats.h>
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
#include "server/replication/stream_snapshots.h"
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
  // Stages `n` records after those in *sent, then commits: messages (payloads of 300-1000
  // bytes, every seventh longer than a 4 KiB batch) and, as the fifth of every nine, an update
  // boundary. *messages: the last message's sequence.
  static void StageAndCommit(StreamJournal* stream, int n,
                             std::vector<journal::JournalRecord>* sent, std::int64_t* messages,
                             std::int64_t* end) {
    for (int k = 0; k < n; ++k) {
      if (k % 9 == 4) {
        journal::JournalRecord boundary;
        boundary.mutable_boundary()->set_last_message_sequence(*messages);
        sent->push_back(boundary);
      } else {
        const std::int64_t seq = ++*messages;
        sent->push_back(Message(seq, seq % 7 == 0 ? 9000 : 300 + 70 * (seq % 11)));
      }
      const std::string frame = Frame(sent->back());
      *end += static_cast<std::int64_t>(frame.size());
      stream->Stage(frame, {.last_message = *messages, .journal_end = *end});
    }
    ASSERT_TRUE(stream->Commit().ok());
  }
  // Reads from `from` until nothing comes for a second.
  static core::Result<std::vector<journal::JournalRecord>> ReadFrom(
      const StreamJournalOptions& options, const FollowPoint& from) {
    core::Result<std::unique_ptr<StreamReader>> reader = StreamReader::Open(options, from);
    if (!reader.ok()) return reader.status();
    std::vector<journal::JournalRecord> out;
    journal::JournalRecord r;
    while (true) {
      core::Result<bool> got = reader.value()->Next(&r, 1000);
      if (!got.ok()) return got.status();
      if (!got.value()) return out;
      out.push_back(r);
    }
  }
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
  std::int64_t repeated = -1;
  const std::vector<journal::JournalRecord> got = testing::ReadWholeStream(options, &repeated);
  EXPECT_EQ(repeated, 0);
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

TEST_F(StreamJournalTest, AReaderSkipsABatchSentAgainAndRefusesAGap) {
  const StreamJournalOptions options = Options();
  std::unique_ptr<StreamJournal> stream = OpenWhenReady(options);
  ASSERT_NE(stream, nullptr);
  std::vector<journal::JournalRecord> sent;
  std::int64_t messages = 0, end = 0;
  ASSERT_NO_FATAL_FAILURE(StageAndCommit(stream.get(), 12, &sent, &messages, &end));
  // Message 2 appended again after the others (as a writer does after the stream lost the
  // batches it acknowledged): its bytes are read once.
  auto client = NatsClient::Connect(options.nats);
  ASSERT_TRUE(client.ok());
  jsCtx* js = client.value()->jetstream();
  jsOptions jo = NatsWait(2000);
  natsMsg* copy = nullptr;
  ASSERT_EQ(js_GetMsg(&copy, js, options.stream.c_str(), 2, &jo, nullptr), NATS_OK);
  natsMsg* again = nullptr;
  ASSERT_EQ(natsMsg_Create(&again, options.subject.c_str(), nullptr, natsMsg_GetData(copy),
                           natsMsg_GetDataLength(copy)),
            NATS_OK);
  const char* start = nullptr;
  ASSERT_EQ(natsMsgHeader_Get(copy, "Slamd-Stream-Offset", &start), NATS_OK);
  ASSERT_EQ(natsMsgHeader_Set(again, "Slamd-Stream-Offset", start), NATS_OK);
  ASSERT_EQ(js_PublishMsg(nullptr, js, again, nullptr, nullptr), NATS_OK);
  natsMsg_Destroy(again);
  natsMsg_Destroy(copy);
  std::int64_t repeated = -1;
  const std::vector<journal::JournalRecord> got = testing::ReadWholeStream(options, &repeated);
  EXPECT_EQ(repeated, 1);
  ASSERT_EQ(got.size(), sent.size());
  for (size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i].SerializeAsString(), sent[i].SerializeAsString()) << i;
  }
  // The first messages gone: read from the start, the rest does not continue what was read.
  ASSERT_TRUE(PurgeStreamBefore(js, options.stream, 3, 2000).ok());
  const auto gap = ReadFrom(options, {.sequence = 1});
  ASSERT_FALSE(gap.ok());
  EXPECT_EQ(gap.status().code(), core::StatusCode::kDataLoss);
  EXPECT_NE(gap.status().message().find("no longer in the stream"), std::string::npos)
      << gap.status().message();
}

TEST_F(StreamJournalTest, SnapshotsInTheStreamTruncateTheJournalStream) {
  const StreamJournalOptions options = Options();
  std::unique_ptr<StreamJournal> stream = OpenWhenReady(options);
  ASSERT_NE(stream, nullptr);
  auto snapshots = StreamSnapshots::Open(options, 2);
  ASSERT_TRUE(snapshots.ok()) << snapshots.status().ToString();
  EXPECT_EQ(snapshots.value()->LoadNewest().status().code(), core::StatusCode::kNotFound);
  std::vector<journal::JournalRecord> sent;
  std::int64_t messages = 0, end = 0;
  std::vector<StreamSnapshot> put;
  std::vector<size_t> taken_after;  // records sent when each snapshot was taken
  for (int round = 0; round < 4; ++round) {
    ASSERT_NO_FATAL_FAILURE(StageAndCommit(stream.get(), 9, &sent, &messages, &end));
    // A state of every record so far but the last five messages (still queued: the update
    // boundary after the first of them is in the state).
    const std::int64_t covered = messages - 5;
    const auto follow = stream->FollowPointFor(covered);
    ASSERT_TRUE(follow.ok()) << follow.status().ToString();
    std::string bytes(10000 + 3000 * round, '\0');  // 3-5 chunks of 4 KiB
    for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>(i * 7 + round);
    put.push_back({.bytes = bytes,
                   .source = options.source,
                   .journal_offset = end,
                   .last_message = covered,
                   .follow = follow.value()});
    taken_after.push_back(sent.size());
    ASSERT_TRUE(snapshots.value()->Put(put.back()).ok());
    const auto newest = snapshots.value()->LoadNewest();
    ASSERT_TRUE(newest.ok()) << newest.status().ToString();
    EXPECT_EQ(newest.value().bytes, put.back().bytes);
    EXPECT_EQ(newest.value().journal_offset, end);
    EXPECT_EQ(newest.value().last_message, covered);
    EXPECT_EQ(newest.value().follow.sequence, follow.value().sequence);
    EXPECT_EQ(newest.value().follow.stream_offset, follow.value().stream_offset);
    EXPECT_EQ(newest.value().follow.skip, follow.value().skip);
  }
  auto client = NatsClient::Connect(options.nats);
  ASSERT_TRUE(client.ok());
  jsCtx* js = client.value()->jetstream();
  // Two kept: the journal stream starts where the older of them is followed from.
  const auto journal_range = OpenStream(js, {.name = options.stream, .subject = options.subject});
  ASSERT_TRUE(journal_range.ok());
  EXPECT_EQ(journal_range.value().first, put[2].follow.sequence);
  const auto snapshot_range = OpenStream(js, {.name = StreamSnapshots::StreamName(options.stream),
                                              .subject = options.subject + ".snapshots"});
  ASSERT_TRUE(snapshot_range.ok());
  EXPECT_EQ(snapshot_range.value().last - snapshot_range.value().first + 1, 4 + 5)
      << "the two newest snapshots' chunks";
  // From the follow point, less what the state includes (messages up to its last, the first
  // `skip` other records): the five queued messages, then everything sent after it was taken.
  const auto rest = ReadFrom(options, put[2].follow);
  ASSERT_TRUE(rest.ok()) << rest.status().ToString();
  std::vector<std::string> after_state;
  std::int64_t skip = put[2].follow.skip;
  for (const journal::JournalRecord& r : rest.value()) {
    if (r.has_message() ? r.message().sequence() <= put[2].last_message : skip-- > 0) continue;
    after_state.push_back(r.SerializeAsString());
  }
  std::vector<std::string> expected;
  for (size_t i = 0; i < sent.size(); ++i) {
    const bool queued = sent[i].has_message() && sent[i].message().sequence() > put[2].last_message;
    if (i >= taken_after[2] || queued) expected.push_back(sent[i].SerializeAsString());
  }
  EXPECT_GT(put[2].follow.skip, 0);
  EXPECT_EQ(after_state, expected);
  // Snapshots that do not move the follow point: truncating where the stream already starts
  // loses nothing.
  for (int again = 0; again < 2; ++again) {
    StreamSnapshot same = put.back();
    same.journal_offset += 1 + again;
    ASSERT_TRUE(snapshots.value()->Put(same).ok());
  }
  const auto after = OpenStream(js, {.name = options.stream, .subject = options.subject});
  ASSERT_TRUE(after.ok());
  EXPECT_EQ(after.value().first, put[3].follow.sequence);
  EXPECT_EQ(after.value().last, journal_range.value().last);
  // A writer that stopped half-way through a newer snapshot: the newest whole one is loaded.
  natsMsg* chunk = nullptr;
  ASSERT_EQ(natsMsg_Create(&chunk, (options.subject + ".snapshots").c_str(), nullptr, "xy", 2),
            NATS_OK);
  for (const auto& [key, value] : {std::pair{"Slamd-Snapshot", "999999"},
                                   {"Slamd-Chunk", "0"},
                                   {"Slamd-Chunks", "3"},
                                   {"Slamd-Source", "x"}}) {
    ASSERT_EQ(natsMsgHeader_Set(chunk, key, value), NATS_OK);
  }
  ASSERT_EQ(js_PublishMsg(nullptr, js, chunk, nullptr, nullptr), NATS_OK);
  natsMsg_Destroy(chunk);
  const auto newest = snapshots.value()->LoadNewest();
  ASSERT_TRUE(newest.ok()) << newest.status().ToString();
  EXPECT_EQ(newest.value().bytes, put.back().bytes);
}

}  // namespace
}  // namespace slamd::server
