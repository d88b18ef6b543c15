// The daemon's side of replication (server/replication): the replicated journal, committed after
// each update, with intake and estimates held while the stream does not acknowledge; and a
// replicated pair, where the slamd holding the lease leads and the other follows the stream as
// a hot standby (the same updates, in the same order, from the stream's records), keeps what it
// hears from the robots, and takes over when the lease lapses.
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "core/base/thread_name.h"
#include "server/daemon/daemon.h"
#include "server/journal/journal_segments.h"
#include "server/journal/snapshot_file.h"
#include "server/messages/inbound_codec.h"
#include "server/replication/replicated_journal.h"
#include "server/snapshot/state_codec.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {
namespace {

StreamJournalOptions StreamOptions(const ServerParams::Replication& r) {
  return {.nats = {.servers = SplitServers(r.servers)},
          .stream = r.stream,
          .subject = r.subject,
          .replicas = r.replicas,
          .ack_timeout_ms = r.ack_timeout_ms};
}

}  // namespace

core::Status Daemon::StartReplication(bool* superseded) {
  const ServerParams::Replication& r = params_.replication;
  if (r.servers.empty()) return core::Status::Ok();
  if (!journal_) {
    return core::InvalidArgument(
        "replication.servers is set and data_dir is not: the "
        "replicated journal is a copy of the local one");
  }
  if (r.lease_ttl_ms > 0) {
    core::Result<std::string> id = DataDirectoryId(params_.data_dir);
    if (!id.ok()) return id.status();
    core::Result<std::unique_ptr<LeaderLease>> lease =
        LeaderLease::Open({.nats = {.servers = SplitServers(r.servers)},
                           .bucket = r.lease_bucket,
                           .ttl_ms = r.lease_ttl_ms,
                           .replicas = r.replicas,
                           .holder = id.value()});
    if (!lease.ok())
      return core::Status(lease.status().code(), "replication: " + lease.status().message());
    lease_ = std::move(lease).value();
    core::Result<bool> taken = lease_->TryAcquire();
    if (!taken.ok()) return taken.status();
    if (!taken.value()) return Follow(superseded);
    StartLeaseThread();  // now: creating the stream may take longer than the lease lasts
  }
  core::Result<std::unique_ptr<StreamJournal>> started =
      server::StartReplication(params_.data_dir, StreamOptions(r), journal_.get());
  if (lease_ && started.status().code() == core::StatusCode::kFailedPrecondition) {
    // Holding the lease but behind the stream (another slamd wrote it last): follow it to its
    // end first, then take over (StandbyStep, at once: the lease is held).
    log_->warn("replication: {}", started.status().message());
    return Follow(superseded);
  }
  if (!started.ok()) {
    return core::Status(started.status().code(), "replication: " + started.status().message());
  }
  replica_ = std::move(started).value();
  SLAMD_RETURN_IF_ERROR(OpenStreamSnapshots());
  const StreamPosition end = replica_->stream_end();
  log_->info(
      "replication: {}journal in stream {} ({} replicas) on {}; it ends at message {} "
      "(journal offset {}, accepted message {})",
      lease_ ? "leader, " : "", r.stream, r.replicas, r.servers, end.sequence, end.journal_end,
      end.last_message);
  return core::Status::Ok();
}

core::Status Daemon::OpenStreamSnapshots() {
  const ServerParams::Replication& r = params_.replication;
  if (r.keep_snapshots == 0 || stream_snapshots_) return core::Status::Ok();
  core::Result<std::unique_ptr<StreamSnapshots>> opened =
      StreamSnapshots::Open(replica_->options(), r.keep_snapshots);
  if (!opened.ok()) {
    return core::Status(opened.status().code(), "replication: " + opened.status().message());
  }
  stream_snapshots_ = std::move(opened).value();
  return core::Status::Ok();
}

core::Result<bool> Daemon::StartFromStreamSnapshot(FollowPoint* from) {
  const ServerParams::Replication& r = params_.replication;
  StreamJournalOptions options = StreamOptions(r);
  core::Result<std::string> id = DataDirectoryId(params_.data_dir);
  if (!id.ok()) return id.status();
  options.source = id.value();
  core::Result<std::unique_ptr<StreamSnapshots>> snapshots =
      StreamSnapshots::Open(options, r.keep_snapshots);
  if (!snapshots.ok()) return snapshots.status();
  core::Result<StreamSnapshot> newest = snapshots.value()->LoadNewest();
  if (newest.status().code() == core::StatusCode::kNotFound) return false;
  if (!newest.ok()) return newest.status();
  const StreamSnapshot& snapshot = newest.value();
  const std::string where = "the snapshot at journal offset " +
                            std::to_string(snapshot.journal_offset) + " in stream " +
                            StreamSnapshots::StreamName(r.stream);
  JournalPosition position;
  core::Result<EstimatorState> state = DecodeState(snapshot.bytes, &position);
  if (!state.ok()) return core::DataLoss(where + ": " + state.status().message());
  core::Result<std::unique_ptr<Estimator>> restored =
      Estimator::Restore(params_.estimator, params_.isam2, state.value());
  if (!restored.ok()) return core::DataLoss(where + ": " + restored.status().message());
  // The data directory (no accepted message in it: superseded or new) starts from the snapshot:
  // a new journal that continues its message numbers, and the state as its snapshot file at
  // the journal's start.
  journal_.reset();
  core::Result<std::vector<JournalSegment>> segments = ListJournalSegments(params_.data_dir);
  if (!segments.ok()) return segments.status();
  for (const JournalSegment& segment : segments.value()) std::remove(segment.path.c_str());
  core::Result<std::unique_ptr<Journal>> opened = Journal::Open(
      params_.data_dir, JournalOptionsOf(params_), {}, position.last_message_sequence);
  if (!opened.ok()) return opened.status();
  journal_ = std::move(opened).value();
  const JournalPosition local{.last_message_sequence = position.last_message_sequence,
                              .journal_offset = journal_->offset()};
  core::Result<std::string> file =
      WriteSnapshotFile(params_.data_dir, local.journal_offset, EncodeState(state.value(), local),
                        {.keep = params_.journal.keep_snapshots});
  if (!file.ok()) return file.status();
  estimator_ = std::move(restored).value();
  follow_.start = local;
  follow_.skip = snapshot.follow.skip;
  *from = snapshot.follow;
  log_->info(
      "replication: standby starts from {} (message {}), following the journal stream from its "
      "message {}",
      where, position.last_message_sequence, from->sequence);
  return true;
}

core::Status Daemon::Follow(bool* superseded) {
  const ServerParams::Replication& r = params_.replication;
  if (journal_->last_sequence() > 0) {
    SLAMD_RETURN_IF_ERROR(SupersedeLocalState());
    *superseded = true;
  }
  FollowPoint from{.sequence = 1};
  if (r.keep_snapshots > 0) {
    const core::Result<bool> started = StartFromStreamSnapshot(&from);
    if (!started.ok()) {
      return core::Status(started.status().code(), "replication: " + started.status().message());
    }
  }
  // Creating the consumer can time out on a loaded cluster (its answer lost although the
  // consumer was made, seen in the failover tests): tried three times.
  core::Result<std::unique_ptr<StreamReader>> follower = core::Unavailable("not tried");
  for (int attempt = 0; attempt < 3 && follower.status().code() == core::StatusCode::kUnavailable;
       ++attempt) {
    follower = StreamReader::Open(StreamOptions(r), from);
    if (!follower.ok()) log_->warn("replication: {}", follower.status().ToString());
  }
  if (!follower.ok()) return follower.status();
  follow_.reader = std::move(follower).value();
  follow_.replay = std::make_unique<JournalReplay>(
      estimator_.get(), follow_.start ? follow_.start->last_message_sequence : 0);
  // Rebuilds started in the replay catch up as the stream's swap records say (as in recovery).
  estimator_->SetReplaying(true);
  standby_ = true;
  const core::Result<std::string> holder = lease_->Holder();
  log_->info("replication: standby, following stream {} (the lease is held by '{}')", r.stream,
             holder.ok() ? holder.value() : "?");
  return core::Status::Ok();
}

core::Status Daemon::SupersedeLocalState() {
  namespace fs = std::filesystem;
  const std::int64_t messages = journal_->last_sequence();
  journal_.reset();
  const fs::path dir = fs::path(params_.data_dir) / ("superseded-" + std::to_string(WallMicros()));
  std::error_code ec;
  fs::create_directory(dir, ec);
  if (!ec) fs::permissions(dir, fs::perms::owner_all, ec);
  for (const fs::directory_entry& e : fs::directory_iterator(params_.data_dir, ec)) {
    const std::string name = e.path().filename().string();
    const bool state =
        e.is_regular_file() && (name.rfind("journal", 0) == 0 || name.rfind("snapshot-", 0) == 0 ||
                                name.rfind(".snapshot-", 0) == 0);
    if (state) fs::rename(e.path(), dir / name, ec);
    if (ec) break;
  }
  if (ec) {
    return core::IoError("replication: cannot move the state of " + params_.data_dir + " to " +
                         dir.string() + ": " + ec.message());
  }
  core::Result<std::unique_ptr<Journal>> opened =
      Journal::Open(params_.data_dir, JournalOptionsOf(params_), {}, 0);
  if (!opened.ok()) return opened.status();
  journal_ = std::move(opened).value();
  core::Result<std::unique_ptr<Estimator>> made =
      Estimator::Create(params_.estimator, params_.isam2);
  if (!made.ok()) return made.status();
  estimator_ = std::move(made).value();
  log_->warn(
      "replication: another slamd leads: this data directory's state ({} messages) is "
      "moved to {}; following the stream from its start",
      messages, dir.string());
  return core::Status::Ok();
}

bool Daemon::CommitReplica() {
  if (!replica_) return true;
  if (deposed_) return false;
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
  if (s.code() == core::StatusCode::kFailedPrecondition && !deposed_.exchange(true)) {
    log_->critical("replication: another slamd writes the stream: this one stops leading");
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

bool Daemon::Hear(std::string_view channel, std::string_view type,
                  std::vector<std::uint8_t> bytes) {
  const std::int64_t now = SteadyMicros();
  const auto keep_us = static_cast<std::int64_t>(params_.replication.standby_keep_s * 1e6);
  std::lock_guard lock(follow_.heard_mutex);
  if (!standby_) return false;  // TakeOver took what was heard under this lock
  while (!follow_.heard.empty() && follow_.heard.front().steady_us < now - keep_us)
    follow_.heard.pop_front();
  follow_.heard.push_back({std::string(channel), std::string(type), std::move(bytes), now});
  return true;
}

bool Daemon::ApplyFollowed(const journal::JournalRecord& record) {
  const std::string where = "stream " + params_.replication.stream + " after message " +
                            std::to_string(follow_.reader->position().sequence);
  // What the state this standby started from includes is neither applied nor journaled.
  bool included = false;
  if (record.has_message()) {
    included = follow_.start && record.message().sequence() <= follow_.start->last_message_sequence;
  } else if (follow_.skip > 0) {
    included = true;
    --follow_.skip;
  }
  core::Status s = included ? core::Status::Ok() : follow_.replay->Apply(record, where, false);
  if (s.ok() && !included) s = journal_->AppendCopy(record);
  if (s.ok() && record.has_boundary() && !included) {
    processed_sequence_ = record.boundary().last_message_sequence();
  }
  if (s.ok() && record.has_message()) {  // remembered as long as what intake hears
    const std::int64_t now = SteadyMicros();
    const auto keep_us = static_cast<std::int64_t>(params_.replication.standby_keep_s * 1e6);
    while (!follow_.streamed_order.empty() &&
           follow_.streamed_order.front().first < now - keep_us) {
      follow_.streamed.erase(follow_.streamed.find(follow_.streamed_order.front().second));
      follow_.streamed_order.pop_front();
    }
    std::string key = record.message().channel() + '\0' + record.message().lcm_payload();
    follow_.streamed.insert(key);
    follow_.streamed_order.emplace_back(now, std::move(key));
  }
  if (!s.ok()) {
    log_->critical("replication: standby cannot follow: {}", s.ToString());
    deposed_ = true;
  }
  return s.ok();
}

void Daemon::StandbyStep() {
  journal::JournalRecord record;
  for (int n = 0; n < 1000 && !deposed_; ++n) {  // then a look at the lease
    core::Result<bool> got = follow_.reader->Next(&record, n == 0 ? 50 : 0);
    if (!got.ok() && got.status().code() == core::StatusCode::kDataLoss) {
      // Records it never had are gone (the stream was truncated past it, or is corrupt): it
      // can no longer become the leader's equal. Restarted, it starts from a snapshot.
      log_->critical("replication: standby cannot follow: {}", got.status().ToString());
      deposed_ = true;
      break;
    }
    if (!got.ok()) {
      log_->error("replication: standby: {}", got.status().ToString());
      break;
    }
    if (!got.value() || !ApplyFollowed(record)) break;
  }
  const core::Status committed = journal_->Commit();
  if (!committed.ok()) NoteJournalError(committed);
  if (deposed_) return;
  MaybeSnapshot();  // local only (a standby has no replica): its journal's segments go too
  // What the old leader accepted and never got into the stream exists only in what standbys
  // heard: one that has not heard the robots for two lease lengths leaves the lease to one that
  // has (unless it holds the lease already, or no one else takes it).
  const bool heard_enough = SteadyMicros() - follow_.hearing_since_us >=
                            std::int64_t{2000} * params_.replication.lease_ttl_ms;
  if (!lease_->held() && !heard_enough) return;
  core::Result<bool> taken = lease_->TryAcquire();
  if (!taken.ok() || !taken.value()) return;
  StartLeaseThread();  // renewed from now on: taking over may take longer than a lease lasts
  TakeOver();
}

void Daemon::TakeOver() {
  const ServerParams::Replication& r = params_.replication;
  const std::int64_t t0 = SteadyMicros();
  taking_over_ = true;
  journal::JournalRecord record;
  // The rest of the stream; then the replicated journal continues from this data directory.
  // Reading stops at the first pause of 5 ms: TakeOverReplication refuses while the stream holds
  // more than was read (records still on their way), and the next attempt reads on. (A 100 ms
  // pause was 100 ms more of every failover.)
  core::Result<std::unique_ptr<StreamJournal>> replica = core::Unavailable("not tried");
  for (int attempt = 0; attempt < 100 && !replica.ok() && !deposed_; ++attempt) {
    core::Result<bool> got = true;
    while (got.ok() && got.value()) {
      got = follow_.reader->Next(&record, 5);
      if (got.ok() && got.value() && !ApplyFollowed(record)) return;
    }
    replica = TakeOverReplication(params_.data_dir, StreamOptions(r), journal_.get(),
                                  follow_.reader->position().sequence);
    if (!replica.ok()) log_->warn("replication: taking over: {}", replica.status().ToString());
  }
  if (!replica.ok()) {
    log_->critical("replication: cannot take over the stream: {}", replica.status().ToString());
    deposed_ = true;
    return;
  }
  replica_ = std::move(replica).value();
  const core::Status snapshots = OpenStreamSnapshots();
  if (!snapshots.ok()) log_->error("{}: snapshots stay local", snapshots.ToString());
  const std::int64_t stream_end = follow_.reader->position().sequence;
  follow_.reader.reset();
  std::vector<Inbound> pending = follow_.replay->TakePending();
  follow_.replay.reset();
  estimator_->SetReplaying(false);
  processed_sequence_ = journal_->last_sequence();
  // The old leader's accepted, unprocessed messages first, as one update (as after a restart).
  if (!pending.empty()) {
    estimator_->Process(pending);
    JournalUpdate(pending);
  }
  // What the robots sent while this slamd followed and the stream did not bring (had the stream
  // brought it, it was applied; a re-sent copy would be recognised as held), in the order it was
  // heard: intake keeps adding to follow_.heard while this journals and queues it, in chunks the
  // queue has room for, and takes the leader's way only once none is left (so nothing heard later
  // is queued before what was heard earlier: a closure before its pose would be refused).
  const int chunk = std::max(1, queue_.capacity() / 2);
  size_t journaled = 0, heard_count = 0;
  for (;;) {
    std::deque<StandbyState::Heard> heard;
    {
      std::lock_guard lock(follow_.heard_mutex);
      if (follow_.heard.empty()) {
        standby_ = false;  // intake queues from now on
        break;
      }
      heard.swap(follow_.heard);
    }
    heard_count += heard.size();
    while (!heard.empty()) {
      {
        std::lock_guard lock(intake_mutex_);
        for (int n = 0; n < chunk && !heard.empty(); ++n, heard.pop_front()) {
          const StandbyState::Heard& h = heard.front();
          std::string key = h.channel + '\0';
          key.append(h.bytes.begin(), h.bytes.end());
          if (follow_.streamed.count(key) != 0) continue;  // the stream had it: applied already
          core::Result<Inbound> in = DecodeInbound(h.type, h.bytes);
          if (!in.ok()) continue;  // it was valid when heard
          in.value().received_us = h.steady_us;
          if (std::holds_alternative<QueryRequest>(in.value().measurement)) {
            intake_held_.push_back(std::move(in).value());  // asked during the takeover
            continue;
          }
          const core::Result<std::int64_t> seq =
              journal_->AppendMessage(h.channel, h.type, h.bytes, WallMicros());
          if (!seq.ok()) {
            NoteJournalError(seq.status());
            continue;
          }
          in.value().journal_sequence = seq.value();
          intake_held_.push_back(std::move(in).value());
          ++journaled;
        }
        QueueHeldLocked();
      }
      StepEstimator(0.0);
    }
  }
  follow_.streamed.clear();  // a standby's
  follow_.streamed_order.clear();
  published_sequence_ = 0;  // every robot's estimate, now
  PublishEstimates(*ShareSnapshot(), SteadyMicros());
  log_->warn(
      "replication: took over as leader in {:.3f} s: stream at message {}, {} updates "
      "replayed, {} old-leader messages still to process, {} of {} heard messages journaled "
      "(the others were in the stream)",
      (SteadyMicros() - t0) * 1e-6, stream_end, estimator_->snapshot()->update_sequence,
      pending.size(), journaled, heard_count);
  // An update of the outage's backlog relinearises in a background rebuild, and until that is
  // swapped in the estimate can be far off: live updates meanwhile start new poses from it (a
  // failover settled in a worse minimum that way). The first estimates are out: swap it now.
  if (estimator_->Rebuilding()) {
    const std::int64_t swap_t0 = SteadyMicros();
    SwapRebuild();
    log_->info("replication: the takeover's relinearisation swapped in after {:.3f} s",
               (SteadyMicros() - swap_t0) * 1e-6);
  }
}

void Daemon::StartLeaseThread() {
  if (!lease_ || lease_thread_.joinable()) return;
  lease_thread_ = std::thread([this] {
    core::NameThisThread("slamd-lease");
    const auto period = std::chrono::milliseconds(params_.replication.lease_ttl_ms / 4);
    auto next = std::chrono::steady_clock::now() + period;
    while (!stop_lease_) {
      if (std::chrono::steady_clock::now() < next) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        continue;
      }
      next += period;
      const core::Status s = lease_->Renew();
      if (s.code() == core::StatusCode::kFailedPrecondition) {
        log_->critical("replication: {}: this slamd stops leading", s.ToString());
        replication_held_ = true;  // nothing more is accepted or published
        deposed_ = true;
        return;
      }
      if (!s.ok()) log_->warn("replication: {}", s.ToString());
    }
  });
}

void Daemon::ReleaseLease() {
  stop_lease_ = true;
  if (lease_thread_.joinable()) lease_thread_.join();
  if (lease_ && lease_->held()) {
    const core::Status s = lease_->Release();
    if (!s.ok()) log_->warn("replication: {}", s.ToString());
  }
}

}  // namespace slamd::server
