// StreamJournal: the replicated journal. A JournalReplica (server/journal/journal_replica.h) that
// appends the journal's records, framed as on disk, to a NATS JetStream stream whose replicas
// (RAFT, file storage) hold them on several machines.
//
// Batches: Commit() cuts what was staged since the last one into stream messages of at most
// max_batch_bytes (whole records where they fit; a larger record is cut across messages: a
// reader concatenates the payloads and parses frames), published one at a time, each acknowledged
// by the stream's quorum before the next goes out. A message carries the headers
//   Nats-Msg-Id                   <writer id>-<batch number>: the stream drops a re-sent copy
//   Nats-Expected-Last-Sequence   the stream sequence this writer last saw: the stream refuses
//                                 the message if anything else was appended meanwhile, so
//                                 batches are never reordered or interleaved with another writer
//   Slamd-Source                  the id of the data directory whose journal this is
//   Slamd-Stream-Offset           where its payload starts in the stream's bytes (all payloads
//                                 one after the other since the first message)
//   Slamd-Journal-End             that journal's global offset past the last whole record here
//   Slamd-Last-Message            the sequence of the last accepted message up to there
// A reader knows from Slamd-Stream-Offset which bytes it already has (a batch sent again) and
// whether any are missing (the stream truncated before it); see stream_reader.h.
//
// Truncation: the stream may lose its oldest messages once a snapshot covers them
// (stream_snapshots.h); FollowPoint names the message a reader of such a snapshot starts at.
//
// Failure: an unacknowledged batch (NATS down, no quorum, a partition) stays pending and Commit
// returns Unavailable; the next Commit sends it again (same id). When the stream refuses a batch
// because its last sequence moved, the newest stream message is read: if it is one of this
// writer's pending batches (an earlier attempt landed after its acknowledgement was lost), that
// batch and those before it are done; if it is a batch acknowledged earlier, the stream lost the
// ones after it (NATS acknowledges before its servers sync to disk: a majority killed at once
// can come back without them) and they are sent again from memory (the newest 64 MiB are kept;
// a restart sends the rest from the local journal); otherwise another writer appended and Commit
// returns FailedPrecondition (this process must stop writing: it is no longer the leader).
//
// Thread safety: Stage() from any thread (the journal calls it under its lock); Commit() and the
// accessors from any thread (one commit at a time; accessors wait for it).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "core/base/status.h"
#include "server/journal/journal_replica.h"
#include "server/replication/nats_client.h"

typedef struct __natsMsg natsMsg;

namespace slamd::server {

// Headers of the stream messages that name their writer and the last message up to them (the
// snapshot stream's too).
inline constexpr const char* kSourceHeader = "Slamd-Source";
inline constexpr const char* kLastMessageHeader = "Slamd-Last-Message";

struct StreamJournalOptions {
  NatsOptions nats = {};
  std::string stream = "SLAMD";           // JetStream stream name ([A-Za-z0-9_-])
  std::string subject = "slamd.journal";  // the subject it captures
  int replicas = 3;                       // copies of every message (1..5)
  int ack_timeout_ms = 1000;              // a batch not acknowledged by then: Unavailable [ms]
  // Largest stream message (NATS refuses payloads above its max_payload, 1 MiB by default).
  int max_batch_bytes = 256 << 10;  // [bytes], 4096 .. 1,000,000
  std::string source;               // Slamd-Source of what this writer appends (not empty)

  core::Status Validate() const;  // "StreamJournalOptions::replicas = 7; violates <= 5"
};

// What a stream message says about where it ends (its headers; zeros and "" when absent).
struct StreamPosition {
  std::int64_t sequence = 0;  // the stream's (0: empty stream)
  std::string source;
  std::int64_t stream_offset = -1;  // -1: not said (a stream written before the header)
  std::int64_t payload_bytes = 0;
  std::int64_t journal_end = 0;
  std::int64_t last_message = 0;
};

// Where a reader of a state starts: a stream message that begins with a whole record, every
// message before it in the state, and the records after it that are not messages in the state
// for the first `skip` of them (messages say by their sequence whether a state includes them).
struct FollowPoint {
  std::int64_t sequence = 1;       // the stream message
  std::int64_t stream_offset = 0;  // its Slamd-Stream-Offset
  std::int64_t skip = 0;
};
StreamPosition PositionOf(natsMsg* msg);
// A header of `msg` as a number; `absent` when it is missing or not a number.
std::int64_t NumberHeader(natsMsg* msg, const char* key, std::int64_t absent = 0);

class StreamJournal final : public JournalReplica {
 public:
  // Connects, creates the stream when it does not exist (file storage, `replicas` copies, a
  // 2-minute de-duplication window) and reads where it ends. Unavailable when NATS does not
  // answer; FailedPrecondition when the stream exists with another subject.
  static core::Result<std::unique_ptr<StreamJournal>> Open(const StreamJournalOptions& options);

  void Stage(std::string_view frame, Position after) override;
  core::Status Commit() override;

  // The newest stream message this writer knows of (at Open, whoever wrote it; then its own).
  StreamPosition stream_end() const;
  std::int64_t pending_bytes() const;      // staged or sent and not acknowledged [bytes]
  std::int64_t batches_published() const;  // acknowledged since Open
  // Where a reader of a state that includes every record acknowledged so far and the messages
  // up to `last_message` starts (the newest such point among the newest 4096 batches). Call
  // after a Commit that left nothing pending, before anything but messages is staged again.
  // NotFound when there is none.
  core::Result<FollowPoint> FollowPointFor(std::int64_t last_message) const;
  const std::string& source() const { return options_.source; }  // Slamd-Source of its batches
  const StreamJournalOptions& options() const { return options_; }

 private:
  struct Batch {
    std::string id;
    std::string bytes;
    std::int64_t stream_offset = 0;  // Slamd-Stream-Offset
    bool whole_start = false;        // bytes begin with a record (not a record's continuation)
    std::int64_t last_message_before = 0;  // the last message before its first record
    int others = 0;                        // records ending here that are not messages
    Position end;                          // of its last whole record
  };
  // Where a staged frame ends.
  struct Mark {
    size_t end = 0;
    Position position;
  };
  enum class Sent { kStored, kMoved, kFailed };

  StreamJournal(const StreamJournalOptions& options, std::unique_ptr<NatsClient> client,
                StreamPosition end);
  // Moves what is staged into pending_ batches; both mutexes held.
  void CutBatchesLocked();
  // Publishes `batch`: kStored with its stream *sequence, kMoved, or kFailed with *error.
  Sent Publish(const Batch& batch, std::int64_t* sequence, core::Status* error);
  // After kMoved: drops the pending batches the stream already holds, or FailedPrecondition.
  core::Status Reconcile();
  // An acknowledged batch (at `sequence`; 0 when unknown: an earlier one of a reconciled run):
  // the stream's end moves past it, and it is kept (the newest 64 MiB) for Reconcile.
  void Stored(Batch batch, std::int64_t sequence);

  const StreamJournalOptions options_;
  const std::unique_ptr<NatsClient> client_;
  const std::string writer_id_;

  mutable std::mutex stage_mutex_;
  std::string staged_;
  std::vector<Mark> marks_;

  mutable std::mutex commit_mutex_;  // Commit, pending_ and the stream position
  std::deque<Batch> pending_;
  Position cut_;  // end of the last whole record cut into a batch
  bool cut_whole_ = true;          // the last batch cut ended with a whole record
  std::int64_t stream_bytes_ = 0;  // payload bytes cut into batches since the stream began
  std::int64_t next_batch_ = 1;
  StreamPosition end_;
  std::int64_t batches_published_ = 0;
  std::deque<Batch> acked_;  // the newest acknowledged batches, oldest first
  std::int64_t acked_bytes_ = 0;
  bool retained_all_ = true;  // acked_ holds every batch this writer stored
  std::int64_t lost_batches_ = 0;  // acknowledged, lost by the stream, sent again (new ids)
  // Where readers may start, among the newest acknowledged batches (oldest first), with the
  // count of other records acknowledged before each.
  struct Start {
    FollowPoint point;
    std::int64_t last_message_before = 0;
    std::int64_t others_before = 0;
  };
  std::deque<Start> starts_;
  std::int64_t others_acked_ = 0;  // records other than messages acknowledged since Open
};

}  // namespace slamd::server
