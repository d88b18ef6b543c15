// The daemon's side of the replicated journal (server/replication): starting it, committing it
// after each update, and holding intake and estimates while the stream does not acknowledge.
#include <spdlog/spdlog.h>

#include <chrono>
#include <thread>

#include "server/daemon/daemon.h"
#include "server/replication/replicated_journal.h"

namespace slamd::server {

core::Result<std::unique_ptr<StreamJournal>> Daemon::StartReplica(const ServerParams& params,
                                                                  Journal* journal,
                                                                  spdlog::logger& log) {
  const ServerParams::Replication& r = params.replication;
  if (r.servers.empty()) return std::unique_ptr<StreamJournal>();
  if (journal == nullptr) {
    return core::InvalidArgument(
        "replication.servers is set and data_dir is not: the "
        "replicated journal is a copy of the local one");
  }
  const StreamJournalOptions options{.nats = {.servers = SplitServers(r.servers)},
                                     .stream = r.stream,
                                     .subject = r.subject,
                                     .replicas = r.replicas,
                                     .ack_timeout_ms = r.ack_timeout_ms};
  core::Result<std::unique_ptr<StreamJournal>> started =
      StartReplication(params.data_dir, options, journal);
  if (!started.ok()) {
    return core::Status(started.status().code(), "replication: " + started.status().message());
  }
  const StreamPosition end = started.value()->stream_end();
  log.info(
      "replication: journal in stream {} ({} replicas) on {}; it ends at message {} "
      "(journal offset {}, accepted message {})",
      r.stream, r.replicas, r.servers, end.sequence, end.journal_end, end.last_message);
  return started;
}

bool Daemon::CommitReplica() {
  if (!replica_) return true;
  const core::Status s = replica_->Commit();
  if (s.ok()) {
    if (replication_held_.exchange(false)) {
      log_->warn("replication: the stream acknowledges again; intake resumes");
    }
    return true;
  }
  if (!replication_held_.exchange(true)) {
    ++replication_holds_;
    log_->error(
        "replication: {}; intake is held and estimates wait until the stream "
        "acknowledges ({} bytes pending)",
        s.ToString(), replica_->pending_bytes());
  }
  return false;
}

bool Daemon::WaitForReplication(double timeout_s) const {
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::microseconds(static_cast<std::int64_t>(timeout_s * 1e6));
  while (replication_held_) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

}  // namespace slamd::server
