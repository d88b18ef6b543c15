// SnapshotWriter: the daemon's snapshots. The estimator thread exports its state when one is due
// (journal.snapshot_every_updates / _s / _bytes) and hands it over; the writer's thread,
// slamd-snapshot (one for the writer's life: its allocator arena keeps the encoding's buffers for
// the next snapshot, where a thread per snapshot could land in another arena and leave them
// behind), encodes it and writes it atomically (server/journal/snapshot_file.h), keeping
// journal.keep_snapshots, then deletes the journal segments the oldest kept snapshot covers
// (journal.delete_covered_segments). With keep_snapshots >= 2 the oldest snapshot and the
// segments only it needed go before the new one is written, so the data directory never holds
// more than keep_snapshots snapshots and the journal from the oldest of them (one snapshot kept
// stays until the next is durable). At most 5% of the time goes to snapshots: the next is due
// no sooner than 20x the last one's export + write time, as on a large map both grow.
// With a replicated journal, the leader's snapshots are also stored in the stream's snapshot
// stream, which truncates the journal stream (server/replication/stream_snapshots.h).
// Deleting needs the position of the oldest kept snapshot: the writer knows those it wrote and
// the one recovered at start; while an older one of unknown position is kept, nothing is deleted.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "server/config/server_params.h"
#include "server/journal/journal.h"
#include "server/replication/stream_snapshots.h"
#include "server/snapshot/estimator_state.h"
#include "server/snapshot/state_codec.h"

namespace spdlog {
class logger;
}  // namespace spdlog

namespace slamd::server {

class SnapshotWriter {
 public:
  // `last_sequence`: the update sequence of the state recovered at start (no snapshot is due
  // before the estimate moves on from it); `recovered`: the position of the snapshot recovery
  // loaded (nullptr: none). `journal` outlives the writer. `now_us`: steady clock.
  SnapshotWriter(std::string data_dir, const ServerParams::Journal& params, Journal* journal,
                 std::shared_ptr<spdlog::logger> log, std::int64_t last_sequence,
                 const JournalPosition* recovered, std::int64_t now_us);
  ~SnapshotWriter();  // waits for the snapshot being written, then ends the thread
  SnapshotWriter(const SnapshotWriter&) = delete;
  SnapshotWriter& operator=(const SnapshotWriter&) = delete;

  // A snapshot of update `sequence` is due at `now_us`, the journal ending at `journal_offset`
  // (global), and none is being written.
  bool Due(std::int64_t sequence, std::int64_t now_us, std::int64_t journal_offset) const;
  // Where a snapshot also goes: the replicated journal's snapshot stream (not owned; it
  // outlives the writer), with what a reader of the journal stream needs.
  struct ToStream {
    StreamSnapshots* snapshots = nullptr;
    std::string source;  // the data directory whose journal the stream holds
    FollowPoint follow;  // where a reader of this snapshot starts in the journal stream
  };
  // Writes `state` (exported in export_us) of update `sequence` at `position` on the writer's
  // thread; after the file, to `to_stream` when given.
  void Write(std::shared_ptr<const EstimatorState> state, const JournalPosition& position,
             std::int64_t sequence, std::int64_t now_us, std::int64_t export_us,
             std::optional<ToStream> to_stream = std::nullopt);
  // Waits for the snapshot being written, if any.
  void Join();

 private:
  struct Job {
    std::shared_ptr<const EstimatorState> state;
    JournalPosition position;
    std::int64_t export_us = 0;
    std::optional<ToStream> to_stream;
  };
  void Run();                     // the writer's thread
  void WriteNow(const Job& job);  // on the writer's thread
  // On the writer's thread: before a snapshot is written (keep_snapshots - 1 kept), and after
  // it is durable.
  void MakeRoom();
  void DeleteCoveredSegments();

  std::string data_dir_;
  ServerParams::Journal params_;
  Journal* journal_;
  // The last message sequence of each snapshot whose position is known, by journal offset (the
  // snapshot's file name). Only the writer's thread touches it once running.
  std::map<std::int64_t, std::int64_t> known_;
  std::shared_ptr<spdlog::logger> log_;
  std::int64_t last_sequence_;  // of the last snapshot written (or recovered)
  std::int64_t last_us_;        // when it was due
  std::int64_t last_offset_;    // its journal offset (0: none)
  std::mutex mutex_;
  std::condition_variable wake_;  // a job, the stop, or (to Join) the job done
  std::optional<Job> job_;        // handed over, not yet done (under mutex_)
  bool stop_ = false;             // under mutex_
  std::atomic<bool> busy_{false};
  std::thread thread_;                    // last: started when the rest is ready
  std::atomic<std::int64_t> cost_us_{0};  // the last snapshot's export + write time
};

}  // namespace slamd::server
