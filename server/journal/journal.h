// Journal: the daemon's write-ahead journal, segment files in the data directory
// (journal_segments.h), shared by the intake thread (accepted messages), the estimator thread
// (update boundaries, refinements, commits) and the snapshot thread (deleting covered segments).
// Thread-safe: one mutex around the JournalWriter of the newest segment (journal_writer.h has
// the format and the sync policies).
//
// Segments: once the newest segment holds segment_bytes, the next record starts a new one; the
// full one is synced first, so every segment but the newest is whole and durable. Offsets are
// global (journal_segments.h). DeleteCovered removes the oldest segments a snapshot makes
// unnecessary, so the journal on disk is bounded by what came after the oldest kept snapshot.
//
// Sequence numbers: accepted messages are numbered 1, 2, ... without gaps over the life of the
// data directory; Open() continues after the last one recovery saw.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/base/status.h"
#include "server/journal/journal_replica.h"
#include "server/journal/journal_segments.h"
#include "server/journal/journal_writer.h"

namespace slamd::journal {
class Removal;  // msgs/proto/journal.proto
}

namespace slamd::server {

struct JournalOptions {
  JournalWriterOptions writer = {};
  // A new segment starts once the newest holds this many bytes [bytes]; >= 4096.
  std::int64_t segment_bytes = std::int64_t{64} << 20;

  core::Status Validate() const;  // "JournalOptions::segment_bytes = 0; violates >= 4096"
};

class Journal {
 public:
  // Opens (or creates) the journal of `data_dir` for appending at the end of its newest segment;
  // the caller recovered it first (a torn tail truncated). `segments`: what recovery read
  // (SegmentedJournalReader::segments(); empty when there is no journal yet); `last_sequence`:
  // the last message sequence in them (0 when new). A legacy journal.slamdj is renamed to the
  // segment of base 0.
  static core::Result<std::unique_ptr<Journal>> Open(const std::string& data_dir,
                                                     const JournalOptions& options,
                                                     std::vector<JournalSegment> segments,
                                                     std::int64_t last_sequence);

  // Appends one accepted message; returns its sequence number. IoError (disk full, ...) leaves
  // the journal as it was: the message was not accepted.
  core::Result<std::int64_t> AppendMessage(std::string_view channel, std::string_view type,
                                           std::span<const std::uint8_t> lcm_bytes,
                                           std::int64_t wall_us);
  // After an Isam2 update that consumed `count` messages ending at `last_message_sequence`.
  core::Status AppendBoundary(std::int64_t update_sequence, std::int64_t last_message_sequence,
                              int count);
  // After a refinement that made `rounds` rounds.
  core::Status AppendRefinement(int rounds);
  // After the estimator swapped in a rebuilt solver (Estimator::FinishRebuild), with the
  // rebuild's catch-up rounds (Estimator::last_swap_rounds).
  core::Status AppendRebuildSwap(std::int64_t update_sequence, std::span<const int> rounds);
  // After the estimator removed variables (its lifelong window).
  core::Status AppendRemoval(const journal::Removal& removal);
  // Appends a record another journal wrote (a standby copying the replicated journal): a
  // message keeps its sequence, which must follow the last one (FailedPrecondition otherwise).
  core::Status AppendCopy(const journal::JournalRecord& record);
  // Group commit per the sync policy (always: fdatasync now; interval: if due; never: no-op).
  core::Status Commit();
  // fdatasync now whatever the policy (shutdown).
  core::Status Sync();

  // From now on every record appended is also staged in `replica` (not owned; it must outlive
  // the journal, or be detached with nullptr), framed as on disk; its Commit is the caller's.
  void set_replica(JournalReplica* replica);

  // Deletes the segments (never the newest) whose records a state at this position includes:
  // the segment ends at or before `journal_offset` and its messages are all numbered up to
  // `last_message_sequence`. Returns how many were deleted; IoError if one could not be.
  core::Result<int> DeleteCovered(std::int64_t last_message_sequence, std::int64_t journal_offset);

  std::int64_t offset() const;          // end of the last record (global) [bytes]
  std::int64_t durable_offset() const;  // synced up to here (global) [bytes]
  std::int64_t disk_bytes() const;      // the segments' bytes on disk [bytes]
  int segments() const;                 // on disk, the newest included
  std::int64_t records() const;         // appended since Open
  std::int64_t last_sequence() const;

 private:
  Journal(std::string data_dir, const JournalOptions& options, std::vector<JournalSegment> closed,
          JournalSegment current, std::unique_ptr<JournalWriter> writer,
          std::int64_t last_sequence);
  core::Status AppendLocked(const journal::JournalRecord& record);
  // Syncs and closes the newest segment and opens the next.
  core::Status StartSegmentLocked();

  const std::string data_dir_;
  const JournalOptions options_;
  mutable std::mutex mutex_;
  std::vector<JournalSegment> closed_;  // whole, durable, oldest first (end filled)
  JournalSegment current_;              // being appended to by writer_
  std::unique_ptr<JournalWriter> writer_;
  std::int64_t records_ = 0;  // appended since Open, in all segments
  std::int64_t last_sequence_ = 0;
  JournalReplica* replica_ = nullptr;
};

}  // namespace slamd::server
