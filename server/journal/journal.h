// Journal: the daemon's write-ahead journal, one file `<data_dir>/journal.slamdj`, shared by the
// intake thread (accepted messages) and the estimator thread (update boundaries, refinements,
// commits). Thread-safe: one mutex around a JournalWriter (journal_writer.h has the format and
// the sync policies).
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

#include "core/base/status.h"
#include "server/journal/journal_writer.h"

namespace slamd::server {

// The journal file of a data directory.
std::string JournalPath(const std::string& data_dir);

class Journal {
 public:
  // Opens (or creates) the journal for appending; the caller recovered it first (a torn tail
  // truncated). `last_sequence` is the last message sequence in the file (0 when new).
  static core::Result<std::unique_ptr<Journal>> Open(const std::string& data_dir,
                                                     const JournalWriterOptions& options,
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
  // Group commit per the sync policy (always: fdatasync now; interval: if due; never: no-op).
  core::Status Commit();
  // fdatasync now whatever the policy (shutdown).
  core::Status Sync();

  std::int64_t offset() const;          // end of the last record [bytes]
  std::int64_t durable_offset() const;  // synced up to here [bytes]
  std::int64_t records() const;         // appended since Open
  std::int64_t last_sequence() const;

 private:
  Journal(std::unique_ptr<JournalWriter> writer, std::int64_t last_sequence);
  core::Status AppendLocked(const journal::JournalRecord& record);

  mutable std::mutex mutex_;
  std::unique_ptr<JournalWriter> writer_;
  std::int64_t last_sequence_ = 0;
};

}  // namespace slamd::server
