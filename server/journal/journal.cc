#include "server/journal/journal.h"

#include "slamd_proto/journal.pb.h"

namespace slamd::server {

std::string JournalPath(const std::string& data_dir) { return data_dir + "/journal.slamdj"; }

core::Result<std::unique_ptr<Journal>> Journal::Open(const std::string& data_dir,
                                                     const JournalWriterOptions& options,
                                                     std::int64_t last_sequence) {
  core::Result<std::unique_ptr<JournalWriter>> writer =
      JournalWriter::Open(JournalPath(data_dir), options);
  if (!writer.ok()) return writer.status();
  return std::unique_ptr<Journal>(new Journal(std::move(writer).value(), last_sequence));
}

Journal::Journal(std::unique_ptr<JournalWriter> writer, std::int64_t last_sequence)
    : writer_(std::move(writer)), last_sequence_(last_sequence) {}

core::Status Journal::AppendLocked(const journal::JournalRecord& record) {
  core::Result<std::int64_t> end = writer_->Append(record);
  return end.ok() ? core::Status::Ok() : end.status();
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

core::Status Journal::Commit() {
  std::lock_guard lock(mutex_);
  return writer_->MaybeSync(JournalWriter::Clock::now());
}

core::Status Journal::Sync() {
  std::lock_guard lock(mutex_);
  return writer_->Sync();
}

std::int64_t Journal::offset() const {
  std::lock_guard lock(mutex_);
  return writer_->offset();
}
std::int64_t Journal::durable_offset() const {
  std::lock_guard lock(mutex_);
  return writer_->durable_offset();
}
std::int64_t Journal::records() const {
  std::lock_guard lock(mutex_);
  return writer_->records();
}
std::int64_t Journal::last_sequence() const {
  std::lock_guard lock(mutex_);
  return last_sequence_;
}

}  // namespace slamd::server
