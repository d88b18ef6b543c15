#include "server/daemon/snapshot_writer.h"

#include <spdlog/spdlog.h>

#include <utility>

#include "core/base/memory_usage.h"
#include "core/base/thread_name.h"
#include "core/base/timing.h"
#include "server/journal/snapshot_file.h"

namespace slamd::server {

SnapshotWriter::SnapshotWriter(std::string data_dir, const ServerParams::Journal& params,
                               Journal* journal, std::shared_ptr<spdlog::logger> log,
                               std::int64_t last_sequence, const JournalPosition* recovered,
                               std::int64_t now_us)
    : data_dir_(std::move(data_dir)),
      params_(params),
      journal_(journal),
      log_(std::move(log)),
      last_sequence_(last_sequence),
      last_us_(now_us),
      last_offset_(recovered ? recovered->journal_offset : 0) {
  if (recovered) known_[recovered->journal_offset] = recovered->last_message_sequence;
  thread_ = std::thread([this] { Run(); });
}

SnapshotWriter::~SnapshotWriter() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();  // after the job handed over, if any
}

void SnapshotWriter::Run() {
  core::NameThisThread("slamd-snapshot");
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return job_.has_value() || stop_; });
    if (!job_) return;
    lock.unlock();  // job_ is this thread's until reset: Write hands over the next after Join
    WriteNow(*job_);
    job_->state.reset();  // the state is let go here, outside the lock
    // A stream that never lets the estimator rest never trims (Refine): what the allocator
    // keeps beyond the live heap goes back here, every snapshot.
    core::TrimFreedMemoryBeyondUse();
    lock.lock();
    job_.reset();
    busy_ = false;
    wake_.notify_all();
  }
}

bool SnapshotWriter::Due(std::int64_t sequence, std::int64_t now_us,
                         std::int64_t journal_offset) const {
  if (busy_ || sequence == last_sequence_) return false;
  const bool by_count = params_.snapshot_every_updates > 0 &&
                        sequence - last_sequence_ >= params_.snapshot_every_updates;
  const bool by_time =
      params_.snapshot_every_s > 0 && now_us - last_us_ >= params_.snapshot_every_s * 1e6;
  const bool by_size = params_.snapshot_every_bytes > 0 &&
                       journal_offset - last_offset_ >= params_.snapshot_every_bytes;
  if (!by_count && !by_time && !by_size) return false;
  // A snapshot of a large map costs (export on the estimator thread, encoding and writing
  // here): at most kMaxLoad of the time goes to them, whatever snapshot_every_* ask for.
  constexpr double kMaxLoad = 0.05;
  return static_cast<double>(now_us - last_us_) * kMaxLoad >= static_cast<double>(cost_us_);
}

void SnapshotWriter::Write(std::shared_ptr<const EstimatorState> state,
                           const JournalPosition& position, std::int64_t sequence,
                           std::int64_t now_us, std::int64_t export_us,
                           std::optional<ToStream> to_stream) {
  Join();
  last_sequence_ = sequence;
  last_us_ = now_us;
  last_offset_ = position.journal_offset;
  busy_ = true;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = Job{std::move(state), position, export_us, std::move(to_stream)};
  }
  wake_.notify_all();
}

void SnapshotWriter::WriteNow(const Job& job) {
  const JournalPosition& position = job.position;
  core::Stopwatch timer;
  std::string bytes = EncodeState(*job.state, position);
  MakeRoom();
  const core::Result<std::string> path = WriteSnapshotFile(data_dir_, position.journal_offset,
                                                           bytes, {.keep = params_.keep_snapshots});
  cost_us_ = job.export_us + static_cast<std::int64_t>(timer.Seconds() * 1e6);
  if (path.ok()) {
    log_->info("snapshot {} ({} bytes, message {}) in {:.3f} s", path.value(), bytes.size(),
               position.last_message_sequence, timer.Seconds());
    known_[position.journal_offset] = position.last_message_sequence;
    if (params_.delete_covered_segments) DeleteCoveredSegments();
  } else {
    log_->error("snapshot: {}", path.status().ToString());
  }
  if (!job.to_stream) return;
  const ToStream& to = *job.to_stream;
  core::Stopwatch put_timer;
  const std::int64_t size = static_cast<std::int64_t>(bytes.size());
  const core::Status put = to.snapshots->Put({.bytes = std::move(bytes),
                                              .source = to.source,
                                              .journal_offset = position.journal_offset,
                                              .last_message = position.last_message_sequence,
                                              .follow = to.follow});
  if (put.ok()) {
    log_->info(
        "replication: snapshot of message {} ({} bytes) stored in the stream in {:.3f} s; the "
        "journal stream is kept from where its oldest kept snapshot is followed",
        position.last_message_sequence, size, put_timer.Seconds());
  } else {
    log_->error("replication: snapshot not stored in the stream: {}", put.ToString());
  }
}

void SnapshotWriter::MakeRoom() {
  if (params_.keep_snapshots < 2) return;  // its one snapshot stays until the next is durable
  const core::Status pruned = PruneSnapshots(data_dir_, params_.keep_snapshots - 1);
  if (!pruned.ok()) log_->error("snapshot: {}", pruned.ToString());
  if (params_.delete_covered_segments) DeleteCoveredSegments();
}

void SnapshotWriter::DeleteCoveredSegments() {
  const core::Result<std::vector<SnapshotFileInfo>> kept = ListSnapshots(data_dir_);
  if (!kept.ok() || kept.value().empty()) return;
  // Forget the positions of snapshots no longer on disk.
  std::map<std::int64_t, std::int64_t> still;
  for (const SnapshotFileInfo& s : kept.value()) {
    if (auto it = known_.find(s.sequence); it != known_.end()) still.insert(*it);
  }
  known_ = std::move(still);
  const auto oldest = known_.find(kept.value().back().sequence);
  if (oldest == known_.end()) return;  // its position is unknown: keep everything
  const core::Result<int> deleted = journal_->DeleteCovered(oldest->second, oldest->first);
  if (!deleted.ok()) {
    log_->error("journal: {}", deleted.status().ToString());
  } else if (deleted.value() > 0) {
    log_->info("journal: deleted {} segment(s) covered by the snapshot at offset {}",
               deleted.value(), oldest->first);
  }
}

void SnapshotWriter::Join() {
  std::unique_lock<std::mutex> lock(mutex_);
  wake_.wait(lock, [this] { return !job_.has_value(); });
}

}  // namespace slamd::server
