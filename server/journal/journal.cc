#include "server/journal/journal.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <limits>

#include "core/base/param_check.h"
#include "server/journal/file_util.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {

core::Status JournalOptions::Validate() const {
  SLAMD_RETURN_IF_ERROR(writer.Validate());
  SLAMD_PARAM_CHECK(JournalOptions, segment_bytes, >=, 4096);
  return core::Status::Ok();
}

core::Result<std::unique_ptr<Journal>> Journal::Open(const std::string& data_dir,
                                                     const JournalOptions& options,
                                                     std::vector<JournalSegment> segments,
                                                     std::int64_t last_sequence) {
  SLAMD_RETURN_IF_ERROR(options.Validate());
  if (segments.empty()) segments.push_back({.base = 0});
  if (segments.front().path == LegacyJournalPath(data_dir) || segments.front().path.empty()) {
    const std::string path = JournalSegmentPath(data_dir, 0);
    if (!segments.front().path.empty()) {
      if (::rename(segments.front().path.c_str(), path.c_str()) != 0) {
        return core::IoError("cannot rename " + segments.front().path + " to " + path + ": " +
                             internal::ErrnoDescription(errno));
      }
      SLAMD_RETURN_IF_ERROR(internal::SyncDirectory(data_dir));
    }
    segments.front().path = path;
  }
  JournalSegment current = segments.back();
  segments.pop_back();
  for (JournalSegment& closed : segments) {
    if (closed.end >= 0) continue;
    // Not read to its end by the caller: what it holds is unknown, so it is never deleted.
    closed.end = std::numeric_limits<std::int64_t>::max();
    closed.last_message_sequence = std::numeric_limits<std::int64_t>::max();
  }
  core::Result<std::unique_ptr<JournalWriter>> writer =
      JournalWriter::Open(current.path, options.writer);
  if (!writer.ok()) return writer.status();
  return std::unique_ptr<Journal>(new Journal(data_dir, options, std::move(segments),
                                              std::move(current), std::move(writer).value(),
                                              last_sequence));
}

Journal::Journal(std::string data_dir, const JournalOptions& options,
                 std::vector<JournalSegment> closed, JournalSegment current,
                 std::unique_ptr<JournalWriter> writer, std::int64_t last_sequence)
    : data_dir_(std::move(data_dir)),
      options_(options),
      closed_(std::move(closed)),
      current_(std::move(current)),
      writer_(std::move(writer)),
      last_sequence_(last_sequence) {}

core::Status Journal::StartSegmentLocked() {
  SLAMD_RETURN_IF_ERROR(writer_->Sync());
  const std::int64_t end = current_.base + writer_->offset();
  JournalSegment next{.path = JournalSegmentPath(data_dir_, end), .base = end};
  core::Result<std::unique_ptr<JournalWriter>> opened =
      JournalWriter::Open(next.path, options_.writer);
  if (!opened.ok()) return opened.status();  // the full segment stays the one appended to
  SLAMD_RETURN_IF_ERROR(writer_->Close());
  current_.end = end;
  closed_.push_back(std::move(current_));
  current_ = std::move(next);
  writer_ = std::move(opened).value();
  return core::Status::Ok();
}

core::Status Journal::AppendLocked(const journal::JournalRecord& record) {
  if (writer_->offset() >= options_.segment_bytes && writer_->records() > 0) {
    SLAMD_RETURN_IF_ERROR(StartSegmentLocked());
  }
  core::Result<std::int64_t> end = writer_->Append(record);
  if (!end.ok()) return end.status();
  ++records_;
  if (record.has_message()) current_.last_message_sequence = record.message().sequence();
  if (replica_ != nullptr) {
    replica_->Stage(
        writer_->last_frame(),
        {.last_message = record.has_message() ? record.message().sequence() : last_sequence_,
         .journal_end = current_.base + end.value()});
  }
  return core::Status::Ok();
}

void Journal::set_replica(JournalReplica* replica) {
  std::lock_guard lock(mutex_);
  replica_ = replica;
}

core::Result<std::int64_t> Journal::AppendMessage(std::string_view channel, std::string_view type,
                                                  std::span<const std::uint8_t> lcm_bytes,
                                                  std::int64_t wall_us) {
  journal::JournalRecord record;
  journal::InboundMessage* m = record.mutable_message();
  m->set_channel(std::string(channel));
  m->set_message_type(std::string(type));
  m->set_lcm_payload(lcm_bytes.data(), lcm_bytes.size());
  m->set_received_wall_us(wall_us);
  std::lock_guard lock(mutex_);
  m->set_sequence(last_sequence_ + 1);
  SLAMD_RETURN_IF_ERROR(AppendLocked(record));
  return ++last_sequence_;
}

core::Status Journal::AppendBoundary(std::int64_t update_sequence,
                                     std::int64_t last_message_sequence, int count) {
  journal::JournalRecord record;
  journal::UpdateBoundary* b = record.mutable_boundary();
  b->set_update_sequence(update_sequence);
  b->set_last_message_sequence(last_message_sequence);
  b->set_message_count(count);
  std::lock_guard lock(mutex_);
  return AppendLocked(record);
}

core::Status Journal::AppendRefinement(int rounds) {
  journal::JournalRecord record;
  record.mutable_refinement()->set_rounds(rounds);
  std::lock_guard lock(mutex_);
  return AppendLocked(record);
}

core::Status Journal::AppendRebuildSwap(std::int64_t update_sequence, std::span<const int> rounds) {
  journal::JournalRecord record;
  record.mutable_rebuild_swap()->set_update_sequence(update_sequence);
  for (int n : rounds) record.mutable_rebuild_swap()->add_catch_up_rounds(n);
  std::lock_guard lock(mutex_);
  return AppendLocked(record);
}

core::Status Journal::AppendRemoval(const journal::Removal& removal) {
  journal::JournalRecord record;
  *record.mutable_removal() = removal;
  std::lock_guard lock(mutex_);
  return AppendLocked(record);
}

core::Status Journal::AppendCopy(const journal::JournalRecord& record) {
  std::lock_guard lock(mutex_);
  if (record.has_message()) {
    const std::int64_t seq = record.message().sequence();
    if (seq != last_sequence_ + 1) {
      return core::FailedPrecondition("copied message " + std::to_string(seq) +
                                      " does not follow the journal's last, " +
                                      std::to_string(last_sequence_));
    }
    SLAMD_RETURN_IF_ERROR(AppendLocked(record));
    last_sequence_ = seq;
    return core::Status::Ok();
  }
  return AppendLocked(record);
}

core::Status Journal::Commit() {
  std::lock_guard lock(mutex_);
  return writer_->MaybeSync(JournalWriter::Clock::now());
}

core::Status Journal::Sync() {
  std::lock_guard lock(mutex_);
  return writer_->Sync();
}

core::Result<int> Journal::DeleteCovered(std::int64_t last_message_sequence,
                                         std::int64_t journal_offset) {
  std::lock_guard lock(mutex_);
  int deleted = 0;
  core::Status status;
  while (!closed_.empty() && closed_.front().end <= journal_offset &&
         closed_.front().last_message_sequence <= last_message_sequence) {
    if (::unlink(closed_.front().path.c_str()) != 0 && errno != ENOENT) {
      status = core::IoError("cannot delete journal segment " + closed_.front().path + ": " +
                             internal::ErrnoDescription(errno));
      break;
    }
    closed_.erase(closed_.begin());
    ++deleted;
  }
  if (deleted > 0) {
    const core::Status synced = internal::SyncDirectory(data_dir_);
    if (status.ok()) status = synced;
  }
  if (!status.ok()) return status;
  return deleted;
}

std::int64_t Journal::offset() const {
  std::lock_guard lock(mutex_);
  return current_.base + writer_->offset();
}
std::int64_t Journal::durable_offset() const {
  std::lock_guard lock(mutex_);
  return current_.base + writer_->durable_offset();
}
std::int64_t Journal::disk_bytes() const {
  std::lock_guard lock(mutex_);
  std::int64_t bytes = writer_->offset();
  for (const JournalSegment& s : closed_) bytes += s.end - s.base;
  return bytes;
}
int Journal::segments() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(closed_.size()) + 1;
}
std::int64_t Journal::records() const {
  std::lock_guard lock(mutex_);
  return records_;
}
std::int64_t Journal::last_sequence() const {
  std::lock_guard lock(mutex_);
  return last_sequence_;
}

}  // namespace slamd::server
