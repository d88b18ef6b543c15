// Journal segments: the daemon's journal is a sequence of files in the data directory,
// "journal-<base, 20 digits>.slamdj", each in the one-file format of journal_format.h. A journal
// position is global: a record at byte p of the segment whose base is B is at offset B + p, and a
// segment's base is where the previous one ended (its base + its size), so positions grow over
// the life of the data directory as if the segments were one file. The journal starts a new
// segment once the current one exceeds its size limit (server/journal/journal.h), and deletes
// the oldest segments once snapshots cover them: what remains starts at a segment boundary.
// A data directory from before segments has one file "journal.slamdj": it is the segment of
// base 0 (the journal renames it when it opens).
//
// SegmentedJournalReader streams the records of all segments in order with global offsets. The
// torn-vs-middle rule of journal_reader.h applies to the last segment; an invalid record in an
// earlier segment (closed, synced before the next was created) or a segment that does not start
// where the previous one ended is corruption (kError, DataLoss) unless salvage skips it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/base/status.h"
#include "server/journal/journal_reader.h"

namespace slamd::server {

struct JournalSegment {
  std::string path;  // dir + "/" + file name
  std::int64_t base = 0;
  // What reading it found (SegmentedJournalReader::segments); unknown (-1, 0) when only listed.
  std::int64_t end = -1;                   // base + its size after the last valid record
  std::int64_t last_message_sequence = 0;  // of the last message in it; 0 when it has none
};

// "journal-00000000000000004096.slamdj" for base 4096 (zero-padded: names sort by base).
std::string JournalSegmentName(std::int64_t base);
// dir + "/" + JournalSegmentName(base).
std::string JournalSegmentPath(const std::string& dir, std::int64_t base);
// The single journal file of a data directory from before segments (the segment of base 0).
std::string LegacyJournalPath(const std::string& data_dir);

// The segments of `dir` by base, ascending (names only; contents not read). An empty list when
// there are none; IoError if dir cannot be listed; DataLoss when the legacy file and a segment of
// base 0 both exist (which one is the journal is unknowable).
core::Result<std::vector<JournalSegment>> ListJournalSegments(const std::string& dir);

class SegmentedJournalReader {
 public:
  // `path`: a data directory (all its segments; NotFound when it has none) or one journal file
  // (its base from its segment name, else 0). Errors: those of ListJournalSegments and of
  // JournalReader::Open for the first segment.
  static core::Result<std::unique_ptr<SegmentedJournalReader>> Open(
      const std::string& path, const JournalReaderOptions& options);

  // As JournalReader::Next, with `offset` the record's global offset.
  JournalReadState Next(journal::JournalRecord* record, std::int64_t* offset = nullptr);

  // As JournalReader's, with global offsets.
  JournalReadState state() const { return state_; }
  std::int64_t torn_tail_offset() const { return torn_tail_offset_; }
  const core::Status& error() const { return error_; }
  const std::string& end_reason() const { return end_reason_; }
  std::int64_t valid_end_offset() const { return valid_end_offset_; }
  const std::vector<SkippedRegion>& skipped_regions() const { return skipped_; }
  std::int64_t skipped_bytes() const { return skipped_bytes_; }
  // Where the first segment starts (0 unless older segments were deleted).
  std::int64_t first_offset() const { return segments_.front().base; }
  // The bytes of all segments [bytes].
  std::int64_t disk_bytes() const { return disk_bytes_; }
  // Where the segment being read ends (global): the journal's end once the last is reached.
  std::int64_t end_offset() const { return segments_[current_].base + reader_->file_size(); }
  // The segments, with end and last_message_sequence filled for those read to their end.
  const std::vector<JournalSegment>& segments() const { return segments_; }
  // After kTornTail: the segment file with the torn tail and the offset in it to truncate at
  // (TruncateTornTail).
  const std::string& torn_tail_path() const { return segments_[current_].path; }
  std::int64_t torn_tail_file_offset() const {
    return torn_tail_offset_ - segments_[current_].base;
  }

 private:
  SegmentedJournalReader(std::vector<JournalSegment> segments, const JournalReaderOptions& options)
      : segments_(std::move(segments)), options_(options) {}
  // Opens segment k; false (with state_ kError) when it cannot be opened.
  bool OpenSegment(size_t k);
  // Moves past the end of the current segment (or the bad record at its end, under salvage) to
  // the next; false (with state_ set) when there is none or the journal cannot go on.
  bool NextSegment(std::int64_t end_of_current);
  void Skip(std::int64_t offset, std::int64_t length, std::string reason);
  JournalReadState Fail(core::Status status);

  std::vector<JournalSegment> segments_;
  const JournalReaderOptions options_;
  size_t current_ = 0;
  std::unique_ptr<JournalReader> reader_;
  JournalReadState state_ = JournalReadState::kRecord;
  std::int64_t torn_tail_offset_ = -1;
  core::Status error_;
  std::string end_reason_;
  std::int64_t valid_end_offset_ = 0;
  std::vector<SkippedRegion> skipped_;
  std::int64_t skipped_bytes_ = 0;
  size_t skipped_in_segment_ = 0;  // of the current segment's reader, already in skipped_
  std::int64_t disk_bytes_ = 0;
};

}  // namespace slamd::server
