// ReadJournal: the whole journal in memory (for tests, `slamctl journal inspect|export` and
// small journals): a data directory's segments or one journal file, with global offsets
// (journal_segments.h). Recovery of long journals streams with SegmentedJournalReader instead.
// Includes the generated protobuf header, unlike the other journal headers.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/base/status.h"
#include "server/journal/journal_reader.h"
#include "server/journal/journal_segments.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {

struct JournalContents {
  std::vector<journal::JournalRecord> records;         // in file order
  std::vector<int64_t> offsets;                        // frame offset of each record [bytes]
  JournalReadState end = JournalReadState::kCleanEnd;  // kCleanEnd or kTornTail
  int64_t torn_tail_offset = -1;       // when end == kTornTail (global; in the last segment)
  std::string end_reason;              // why the torn tail was not a valid record
  int64_t valid_end_offset = 0;        // end of the last valid record (the append position)
  int64_t file_size = 0;   // where the journal ends (the last segment's base + size) [bytes]
  int64_t disk_bytes = 0;  // all segments' bytes [bytes]
  std::vector<JournalSegment> segments;
  std::vector<SkippedRegion> skipped;  // corrupt regions skipped under salvage
  int64_t skipped_bytes = 0;
};

// Errors: those of JournalReader::Open, and the reader's error() when it stops with kError
// (corruption in the middle without salvage, or a read error).
core::Result<JournalContents> ReadJournal(const std::string& path,
                                          const JournalReaderOptions& options = {});

}  // namespace slamd::server
