// JournalReader: streams the records of a journal file (journal_format.h) with their offsets and
// classifies how the file ends. Used by recovery before a JournalWriter reopens the file.
//
// The torn-vs-middle rule. When the record at offset X is not valid (short header, length out of
// range or past the end of the file, checksum mismatch, payload that does not parse):
//   * torn tail  - if NO valid record (journal_format.h's definition: in-range length, whole
//                  frame inside the file, checksum and parse OK) starts at any byte offset after
//                  X. This is what a crash mid-write leaves (an append-only writer only ever
//                  tears its last record), and also a bit flip in the last record. Next()
//                  returns kTornTail with torn_tail_offset() == X; recovery calls
//                  TruncateTornTail(path, X) and reopens the writer.
//   * corruption - if a valid record starts at some Y > X (found by scanning byte by byte):
//                  bytes X..Y-1 were damaged after being written, so records after them would be
//                  lost by a truncation. Without salvage Next() returns kError and error()
//                  names X, Y and the reason. With salvage the reader skips to Y, counts the
//                  skipped bytes and regions, and continues.
// A checksum matches garbage by chance with probability 2^-32 per scanned position whose length
// field is plausible, so a false "corruption" verdict on a torn tail is negligible.
// Caveats: (1) after a POWER failure (not a process crash) the kernel may have written the pages
// past the last sync out of order, leaving a hole of zeros before valid records; that is reported
// as corruption (needs salvage, and the hole's messages are gone: check sequence continuity),
// never silently truncated. (2) A payload that embeds a complete journal frame verbatim (e.g. an
// LCM message carrying journal bytes) can make a torn record look like middle corruption.
//
// Header: a bad magic or version is always an error from Open() (salvage does not apply: a
// different version may mean a different format). A file shorter than the header whose bytes
// are a prefix of a valid header (a crash during creation) is a torn tail at offset 0.
//
// The file size is taken at Open(); bytes appended later are not seen. Memory: one record at a
// time (<= kJournalMaxRecordPayload) plus a 64 KiB scan buffer. Not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/base/status.h"

namespace slamd::journal {
class JournalRecord;
}

namespace slamd::server {

struct JournalReaderOptions {
  // Skip corrupt regions in the middle instead of stopping (the daemon's --salvage). Default off.
  bool salvage = false;
};

enum class JournalReadState {
  kRecord,    // Next() filled *record and *offset
  kCleanEnd,  // the file ends exactly after the last valid record
  kTornTail,  // the last record is incomplete or corrupt; see torn_tail_offset()
  kError,     // stopped: corruption in the middle (DataLoss; never under salvage) or a read
              // error (IoError); see error()
};

const char* JournalReadStateName(JournalReadState state);

struct SkippedRegion {
  int64_t offset = 0;  // first damaged byte [bytes from file start]
  int64_t length = 0;  // bytes skipped [bytes]
  std::string reason;  // why the record at `offset` was not valid
};

class JournalReader {
 public:
  // Errors: NotFound / IoError (cannot open or stat), DataLoss naming the path and offset 0 for
  // a bad magic or unsupported version.
  static core::Result<std::unique_ptr<JournalReader>> Open(const std::string& path,
                                                           const JournalReaderOptions& options);
  ~JournalReader();
  JournalReader(const JournalReader&) = delete;
  JournalReader& operator=(const JournalReader&) = delete;

  // The next record (record must not be null; the frame's offset goes to `offset` if not null),
  // or the end state. After
  // kCleanEnd, kTornTail or kError every further call returns the same state.
  JournalReadState Next(journal::JournalRecord* record, int64_t* offset = nullptr);

  JournalReadState state() const { return state_; }
  // Offset of the first byte of the torn tail (valid after kTornTail; -1 otherwise).
  int64_t torn_tail_offset() const { return torn_tail_offset_; }
  // After kError: DataLoss naming the path, the bad offset, the reason and the next valid
  // offset; or IoError when the OS refused a read (never classified as a torn tail).
  const core::Status& error() const { return error_; }
  // Why the torn tail / corrupt record was not valid, e.g. "checksum mismatch".
  const std::string& end_reason() const { return end_reason_; }
  // End of the last valid record returned so far (the header size before any record).
  int64_t valid_end_offset() const { return valid_end_offset_; }
  int64_t records_read() const { return records_read_; }
  int64_t file_size() const { return file_size_; }
  // Regions skipped under salvage, in file order; skipped_bytes() is the sum of their lengths.
  const std::vector<SkippedRegion>& skipped_regions() const { return skipped_; }
  int64_t skipped_bytes() const { return skipped_bytes_; }
  const std::string& path() const { return path_; }

 private:
  JournalReader(std::string path, int fd, int64_t file_size, const JournalReaderOptions& options);
  enum class Probe { kValid, kInvalid, kReadError };
  // kValid when a valid record starts at p (fills *record and *frame_size); else *why says why.
  Probe ProbeAt(int64_t p, journal::JournalRecord* record, int64_t* frame_size, std::string* why);
  // Smallest offset >= from where a valid record starts, -1 if none, -2 on a read error (*why).
  int64_t FindNextValid(int64_t from, std::string* why);

  const std::string path_;
  int fd_ = -1;
  const int64_t file_size_;
  const JournalReaderOptions options_;
  int64_t pos_ = 0;
  JournalReadState state_ = JournalReadState::kRecord;
  int64_t torn_tail_offset_ = -1;
  core::Status error_;
  std::string end_reason_;
  int64_t valid_end_offset_ = 0;
  int64_t records_read_ = 0;
  std::vector<SkippedRegion> skipped_;
  int64_t skipped_bytes_ = 0;
  std::string payload_;                              // reused record buffer
  std::unique_ptr<journal::JournalRecord> scratch_;  // parse target while scanning
};

// Cuts the file at `offset` (a torn_tail_offset()) and fdatasyncs it. InvalidArgument if offset
// is negative or beyond the end of the file; IoError if the OS refuses.
core::Status TruncateTornTail(const std::string& path, int64_t offset);

}  // namespace slamd::server
