// JournalWriter: appends framed JournalRecords (journal_format.h) to one journal file and makes
// them durable with fdatasync according to a sync policy.
//
// Opening: Open() creates the file (writing and syncing the header and the directory entry) or
// opens an existing one for append at its current end. It does NOT scan an existing file: the
// caller must first read it with JournalReader and, on a torn tail, call TruncateTornTail(), so
// the file ends on a record boundary. Open() only checks the 16-byte header.
//
// Durability: bytes up to durable_offset() have been fdatasync()ed. Append() never syncs by
// itself; the caller commits groups of records:
//   kAlways   - MaybeSync() syncs whenever there are unsynced bytes. The daemon calls it once per
//               solver update, after appending the UpdateBoundary record (group commit: one
//               fdatasync per update, not per message). A process crash (kill -9) loses nothing
//               that was appended (the page cache survives); a power failure can lose what was
//               appended after the last sync.
//   kInterval - MaybeSync(now) syncs when there are unsynced bytes and at least interval_ms have
//               passed since the last sync. The caller must call it at least every interval_ms
//               while sync_pending() (e.g. on the estimator's queue-pop timeout).
//   kNever    - MaybeSync() never syncs; only an explicit Sync() (or Close()) does.
//
// Failure: a failed or short write (ENOSPC, EFBIG, EDQUOT, EIO) returns kIoError naming the cause
// (strerror and errno name), the path and the offset; the file is truncated back to the end of
// the last complete record, so it never keeps a partial record, and the writer stays usable: the
// next Append() retries. If that truncation itself fails, the next Append() retries it first.
// A failed Sync() leaves durable_offset() unchanged. Caveat: after a failed fdatasync Linux may
// already have dropped the dirty pages, so a later successful Sync() does not prove the records
// in between reached the disk; treat a Sync() error as fatal for durability claims.
// The process must ignore SIGXFSZ (signal(SIGXFSZ, SIG_IGN)) so that exceeding RLIMIT_FSIZE
// gives EFBIG instead of killing it.
//
// Thread safety: none. The daemon must serialise Append/Sync from its intake and estimator
// threads (one mutex around the writer).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "core/base/status.h"

namespace slamd::journal {
class JournalRecord;  // msgs/proto/journal.proto; include "slamd_proto/journal.pb.h" to build one
}

namespace slamd::server {

enum class SyncPolicy { kAlways, kInterval, kNever };

const char* SyncPolicyName(SyncPolicy policy);  // "always", "interval", "never"

struct JournalWriterOptions {
  // When MaybeSync() calls fdatasync (see the header comment). Default kAlways.
  SyncPolicy sync_policy = SyncPolicy::kAlways;
  // Minimum time between syncs under kInterval [ms]; ignored otherwise. Default 100, >= 1.
  int interval_ms = 100;

  // InvalidArgument naming the field, e.g. "JournalWriterOptions::interval_ms = 0; violates >= 1".
  core::Status Validate() const;
};

class JournalWriter {
 public:
  using Clock = std::chrono::steady_clock;

  // Creates `path` (mode 0600) or opens it for append; see the header comment. Errors:
  // InvalidArgument (options), IoError (open/write/sync refused), DataLoss (existing file with
  // a bad header), FailedPrecondition (existing file shorter than the header: truncate it).
  static core::Result<std::unique_ptr<JournalWriter>> Open(const std::string& path,
                                                           const JournalWriterOptions& options);
  ~JournalWriter();  // closes the file WITHOUT syncing; call Close() for a clean shutdown
  JournalWriter(const JournalWriter&) = delete;
  JournalWriter& operator=(const JournalWriter&) = delete;

  // Appends one record (its `kind` must be set; serialised size <= kJournalMaxRecordPayload,
  // else InvalidArgument and nothing is written). Returns the file offset just past the record.
  core::Result<int64_t> Append(const journal::JournalRecord& record);

  // fdatasync now if anything is unsynced; afterwards durable_offset() == offset().
  core::Status Sync();
  // Applies the sync policy at time `now` (see the header comment).
  core::Status MaybeSync(Clock::time_point now);
  // Sync() and close the file; the writer accepts nothing afterwards (FailedPrecondition).
  core::Status Close();

  int64_t offset() const { return offset_; }                  // end of the last record [bytes]
  int64_t durable_offset() const { return durable_offset_; }  // synced up to here [bytes]
  bool sync_pending() const { return offset_ > durable_offset_; }
  int64_t records() const { return records_; }   // appended by this writer since Open
  // The framed bytes of the last record Append() wrote (as in the file).
  std::string_view last_frame() const { return buffer_; }
  int64_t sync_count() const { return syncs_; }  // fdatasync calls made since Open
  const std::string& path() const { return path_; }
  const JournalWriterOptions& options() const { return options_; }

 private:
  JournalWriter(std::string path, int fd, const JournalWriterOptions& options, int64_t offset);
  core::Status TruncateToOffset();  // drops bytes past offset_ (a failed write's partial record)

  const std::string path_;
  int fd_ = -1;
  const JournalWriterOptions options_;
  int64_t offset_ = 0;
  int64_t durable_offset_ = 0;
  int64_t records_ = 0;
  int64_t syncs_ = 0;
  bool tail_dirty_ = false;  // a failed write may have left bytes past offset_
  Clock::time_point last_sync_;
  std::string buffer_;  // one framed record; reused so Append allocates only when it grows
};

}  // namespace slamd::server
