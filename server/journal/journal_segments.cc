#include "server/journal/journal_segments.h"

#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <system_error>

#include "server/journal/file_util.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kPrefix = "journal-";
constexpr std::string_view kSuffix = ".slamdj";

// The base of a segment file name, -1 when `name` is not one.
std::int64_t BaseOf(const std::string& name) {
  return internal::ParseNumberedName(name, kPrefix, kSuffix);
}

std::int64_t FileSize(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 ? static_cast<std::int64_t>(st.st_size) : 0;
}

}  // namespace

std::string JournalSegmentName(std::int64_t base) {
  return internal::NumberedName(kPrefix, base, kSuffix);
}

std::string JournalSegmentPath(const std::string& dir, std::int64_t base) {
  return dir + "/" + JournalSegmentName(base);
}

std::string LegacyJournalPath(const std::string& data_dir) { return data_dir + "/journal.slamdj"; }

core::Result<std::vector<JournalSegment>> ListJournalSegments(const std::string& dir) {
  std::vector<JournalSegment> out;
  std::error_code ec;
  fs::directory_iterator it(dir, ec);
  if (ec) return core::IoError("cannot list the journal directory " + dir + ": " + ec.message());
  bool legacy = false;
  for (; it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const std::int64_t base = BaseOf(name);
    if (base >= 0) out.push_back({.path = dir + "/" + name, .base = base});
    legacy = legacy || name == "journal.slamdj";
  }
  if (ec) return core::IoError("cannot list the journal directory " + dir + ": " + ec.message());
  std::sort(out.begin(), out.end(),
            [](const JournalSegment& a, const JournalSegment& b) { return a.base < b.base; });
  if (legacy) {
    if (!out.empty() && out.front().base == 0) {
      return core::DataLoss("journal " + dir + " has both journal.slamdj and " +
                            JournalSegmentName(0) + ": move the one that is not the journal away");
    }
    out.insert(out.begin(), {.path = LegacyJournalPath(dir), .base = 0});
  }
  return out;
}

core::Result<std::unique_ptr<SegmentedJournalReader>> SegmentedJournalReader::Open(
    const std::string& path, const JournalReaderOptions& options) {
  std::vector<JournalSegment> segments;
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    core::Result<std::vector<JournalSegment>> listed = ListJournalSegments(path);
    if (!listed.ok()) return listed.status();
    segments = std::move(listed).value();
    if (segments.empty()) return core::NotFound("no journal in " + path);
  } else {
    const std::int64_t base = BaseOf(fs::path(path).filename().string());
    segments.push_back({.path = path, .base = std::max<std::int64_t>(base, 0)});
  }
  std::unique_ptr<SegmentedJournalReader> reader(
      new SegmentedJournalReader(std::move(segments), options));
  core::Result<std::unique_ptr<JournalReader>> first =
      JournalReader::Open(reader->segments_[0].path, options);
  if (!first.ok()) return first.status();
  reader->reader_ = std::move(first).value();
  reader->valid_end_offset_ = reader->segments_[0].base + reader->reader_->valid_end_offset();
  for (const JournalSegment& s : reader->segments_) reader->disk_bytes_ += FileSize(s.path);
  return reader;
}

JournalReadState SegmentedJournalReader::Fail(core::Status status) {
  error_ = std::move(status);
  return state_ = JournalReadState::kError;
}

void SegmentedJournalReader::Skip(std::int64_t offset, std::int64_t length, std::string reason) {
  skipped_.push_back({.offset = offset, .length = length, .reason = std::move(reason)});
  skipped_bytes_ += length;
}

bool SegmentedJournalReader::OpenSegment(size_t k) {
  core::Result<std::unique_ptr<JournalReader>> opened =
      JournalReader::Open(segments_[k].path, options_);
  if (!opened.ok()) {
    Fail(opened.status());
    return false;
  }
  current_ = k;
  reader_ = std::move(opened).value();
  skipped_in_segment_ = 0;
  return true;
}

bool SegmentedJournalReader::NextSegment(std::int64_t end_of_current) {
  JournalSegment& done = segments_[current_];
  done.end = end_of_current;
  if (current_ + 1 == segments_.size()) return false;
  const JournalSegment& next = segments_[current_ + 1];
  if (next.base != end_of_current) {
    const std::string why = "journal segment " + next.path + " starts at offset " +
                            std::to_string(next.base) + " but the one before ends at " +
                            std::to_string(end_of_current) + " (a segment is missing or damaged)";
    if (!options_.salvage) {
      Fail(core::DataLoss(why));
      return false;
    }
    Skip(end_of_current, std::max<std::int64_t>(0, next.base - end_of_current), why);
  }
  if (!OpenSegment(current_ + 1)) return false;
  valid_end_offset_ = segments_[current_].base + reader_->valid_end_offset();
  return true;
}

JournalReadState SegmentedJournalReader::Next(journal::JournalRecord* record,
                                              std::int64_t* offset) {
  while (state_ == JournalReadState::kRecord) {
    const std::int64_t base = segments_[current_].base;
    std::int64_t local = 0;
    const JournalReadState s = reader_->Next(record, &local);
    if (s == JournalReadState::kRecord) {
      // Regions the segment's reader skipped under salvage, in global offsets.
      for (size_t i = skipped_in_segment_; i < reader_->skipped_regions().size(); ++i) {
        const SkippedRegion& r = reader_->skipped_regions()[i];
        Skip(base + r.offset, r.length, r.reason);
      }
      skipped_in_segment_ = reader_->skipped_regions().size();
      if (record->has_message()) {
        segments_[current_].last_message_sequence = record->message().sequence();
      }
      if (offset != nullptr) *offset = base + local;
      valid_end_offset_ = base + reader_->valid_end_offset();
      return s;
    }
    const bool last = current_ + 1 == segments_.size();
    if (s == JournalReadState::kError) return Fail(reader_->error());
    if (s == JournalReadState::kTornTail) {
      end_reason_ = reader_->end_reason();
      const std::int64_t at = base + reader_->torn_tail_offset();
      if (last) {
        segments_[current_].end = at;
        torn_tail_offset_ = at;
        return state_ = s;
      }
      const std::string why = "journal segment " + segments_[current_].path +
                              ": invalid record at offset " + std::to_string(at) + " (" +
                              end_reason_ + ") before the next segment";
      if (!options_.salvage) return Fail(core::DataLoss(why));
      Skip(at, base + reader_->file_size() - at, why);
      if (!NextSegment(base + reader_->file_size())) return state_;
      continue;
    }
    // A clean end.
    if (!NextSegment(base + reader_->file_size())) {
      if (state_ == JournalReadState::kRecord) state_ = JournalReadState::kCleanEnd;
      return state_;
    }
  }
  return state_;
}

}  // namespace slamd::server
