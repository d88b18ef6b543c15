// StreamSnapshots: the replicated journal's snapshots, so that its stream can be truncated. A
// snapshot (the bytes of a local snapshot file's state, server/snapshot/state_codec.h) is stored
// in the JetStream stream "<stream>_SNAPSHOTS" (subject "<subject>.snapshots", the journal
// stream's replicas) as consecutive messages of at most max_batch_bytes, each with the headers
//   Slamd-Source, Slamd-Snapshot (the state's journal offset), Slamd-Last-Message,
//   Slamd-Chunk / Slamd-Chunks (its index, their count), Slamd-Crc32c (of the whole state,
//   masked), Slamd-Follow-Sequence / -Offset / -Skip (where a reader of this state starts in the
//   journal stream: stream_journal.h, FollowPoint).
// Once a snapshot is stored, only the newest `keep` stay, and the journal stream loses the
// messages before where the oldest of them is followed from: the stream is bounded by what came
// after that snapshot, as the local journal is by its segments. A standby that starts (or one
// that lagged behind a truncation) loads the newest complete snapshot and follows the journal
// stream from its follow point.
//
// One writer (the leader's snapshot thread); readers anywhere. A snapshot whose chunks are not
// all stored (its writer died) is passed over by readers.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include "core/base/status.h"
#include "server/replication/nats_client.h"
#include "server/replication/stream_journal.h"

namespace slamd::server {

struct StreamSnapshot {
  std::string bytes;                // the encoded state
  std::string source;               // the data directory whose journal the stream holds
  std::int64_t journal_offset = 0;  // the state's position in that journal (its name)
  std::int64_t last_message = 0;    // the last message the state includes
  FollowPoint follow;               // where a reader of the journal stream starts
};

class StreamSnapshots {
 public:
  // Opens (or creates) the snapshot stream of the journal stream `journal` (its nats, stream,
  // subject, replicas, ack_timeout_ms, max_batch_bytes and source). `keep` >= 1.
  static core::Result<std::unique_ptr<StreamSnapshots>> Open(const StreamJournalOptions& journal,
                                                             int keep);

  // Stores `snapshot`, each chunk acknowledged by the stream's quorum; then truncates both streams
  // as the file comment says. Unavailable when NATS does not answer (nothing is truncated).
  core::Status Put(const StreamSnapshot& snapshot);

  // The newest snapshot stored whole; NotFound when there is none.
  core::Result<StreamSnapshot> LoadNewest();

  static std::string StreamName(const std::string& journal_stream) {
    return journal_stream + "_SNAPSHOTS";
  }

 private:
  StreamSnapshots(const StreamJournalOptions& journal, int keep, std::unique_ptr<NatsClient> client)
      : journal_(journal), keep_(keep), client_(std::move(client)) {}
  // The snapshot whose last chunk is message `last`, or why it is not whole.
  core::Result<StreamSnapshot> LoadEndingAt(std::int64_t last, std::int64_t* first);

  const StreamJournalOptions journal_;
  const int keep_;
  const std::unique_ptr<NatsClient> client_;
  struct Stored {
    std::int64_t first_chunk = 0;
    std::int64_t follow_sequence = 0;
  };
  std::deque<Stored> stored_;  // this writer's, oldest first, at most keep_
};

}  // namespace slamd::server
