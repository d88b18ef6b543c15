#include "server/journal/read_journal.h"

namespace slamd::server {

core::Result<JournalContents> ReadJournal(const std::string& path,
                                          const JournalReaderOptions& options) {
  auto reader = SegmentedJournalReader::Open(path, options);
  if (!reader.ok()) return reader.status();
  JournalContents out;
  journal::JournalRecord record;
  int64_t offset = 0;
  JournalReadState state;
  while ((state = (*reader)->Next(&record, &offset)) == JournalReadState::kRecord) {
    out.records.push_back(record);
    out.offsets.push_back(offset);
  }
  if (state == JournalReadState::kError) return (*reader)->error();
  out.end = state;
  out.torn_tail_offset = (*reader)->torn_tail_offset();
  out.end_reason = (*reader)->end_reason();
  out.valid_end_offset = (*reader)->valid_end_offset();
  out.file_size = (*reader)->end_offset();
  out.disk_bytes = (*reader)->disk_bytes();
  out.segments = (*reader)->segments();
  out.skipped = (*reader)->skipped_regions();
  out.skipped_bytes = (*reader)->skipped_bytes();
  return out;
}

}  // namespace slamd::server
