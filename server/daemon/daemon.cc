#include "server/daemon/daemon.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "core/base/check.h"
#include "core/base/thread_name.h"
#include "core/base/timing.h"
#include "server/estimator/recovery.h"
#include "server/journal/file_util.h"
#include "server/messages/inbound.h"
#include "server/messages/wire_values.h"
#include "server/publish/replies.h"
#include "server/snapshot/estimator_state.h"
#include "server/snapshot/state_codec.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/reject_t.hpp"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {

std::string Daemon::InboundChannel(const Inbound& in) const {
  return VisitSpec(in, [&](auto spec, const auto&) {
    return channels_.Inbound<typename decltype(spec)::type>();
  });
}

std::int64_t SteadyMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

JournalOptions JournalOptionsOf(const ServerParams& params) {
  return {.writer = {.sync_policy = params.journal.sync,
                     .interval_ms = params.journal.sync_interval_ms},
          .segment_bytes = params.journal.segment_bytes};
}

core::Result<std::unique_ptr<Daemon>> Daemon::Create(const ServerParams& params, Bus* bus) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  if (bus == nullptr) return core::InvalidArgument("Daemon::Create: null bus");
  std::shared_ptr<spdlog::logger> log = spdlog::get("slamd");
  if (!log) log = spdlog::default_logger();
  std::unique_ptr<Estimator> estimator;
  std::unique_ptr<Journal> journal;
  std::vector<Inbound> pending;
  std::optional<JournalPosition> recovered_snapshot;  // its position, when one was loaded
  if (params.data_dir.empty()) {
    log->warn("no data_dir: accepted messages are not journaled and a restart starts empty");
    core::Result<std::unique_ptr<Estimator>> made =
        Estimator::Create(params.estimator, params.isam2);
    if (!made.ok()) return made.status();
    estimator = std::move(made).value();
  } else {
    bool loose = false;
    if (const core::Status made = internal::CreateDataDirectory(params.data_dir, &loose);
        !made.ok()) {
      return core::IoError("data_dir '" + params.data_dir + "': " + made.message());
    }
    if (loose) {
      log->warn(
          "data_dir '{}' is open to group or others: the journal and snapshots in it are "
          "owner-only (0600), the directory slamd creates is 0700",
          params.data_dir);
    }
    core::Result<RecoveryResult> recovered =
        Recover(params.data_dir, params.estimator, params.isam2, params.salvage);
    if (!recovered.ok()) return recovered.status();
    RecoveryResult& r = recovered.value();
    for (const std::string& note : r.notes) log->warn("recovery: {}", note);
    if (r.torn_tail_offset >= 0) {
      log->warn("recovery: torn journal tail at offset {} ({}), truncated", r.torn_tail_offset,
                r.torn_tail_reason);
    }
    if (r.salvaged_bytes > 0) log->warn("recovery: skipped {} corrupt bytes", r.salvaged_bytes);
    log->info(
        "recovered '{}' in {:.3f} s: snapshot '{}' (message {}), then {} messages in {} updates "
        "and {} refinements and {} rebuild swaps from the journal; {} accepted messages still to "
        "process",
        params.data_dir, r.seconds, r.snapshot_path, r.snapshot_sequence, r.replayed_messages,
        r.replayed_updates, r.replayed_refinements, r.replayed_rebuild_swaps, r.pending.size());
    estimator = std::move(r.estimator);
    pending = std::move(r.pending);
    if (!r.snapshot_path.empty()) {
      recovered_snapshot = JournalPosition{.last_message_sequence = r.snapshot_sequence,
                                           .journal_offset = r.snapshot_journal_offset};
    }
    core::Result<std::unique_ptr<Journal>> opened = Journal::Open(
        params.data_dir, JournalOptionsOf(params), std::move(r.segments), r.last_sequence);
    if (!opened.ok()) return opened.status();
    journal = std::move(opened).value();
  }
  std::unique_ptr<Daemon> daemon(new Daemon(params, bus, std::move(estimator), std::move(journal)));
  bool superseded = false;
  SLAMD_RETURN_IF_ERROR(daemon->StartReplication(&superseded));
  if (superseded || daemon->follow_.start) {  // a standby: the recovered state was moved aside
    pending.clear();
    recovered_snapshot = daemon->follow_.start;
  }
  if (!pending.empty()) {
    // Accepted and journaled before the restart but never processed: first, as one update.
    // Their senders never heard back: their rejections go out now.
    daemon->processed_sequence_ = pending.back().journal_sequence;
    const ProcessResult r = daemon->estimator_->Process(pending);
    daemon->JournalUpdate(pending);
    for (const Rejection& rej : r.rejections) daemon->PublishRejection(rej);
  } else if (daemon->follow_.start) {
    daemon->processed_sequence_ = daemon->follow_.start->last_message_sequence;
  } else if (daemon->journal_) {
    daemon->processed_sequence_ = daemon->journal_->last_sequence();
  }
  daemon->snapshot_ = daemon->estimator_->snapshot();
  if (daemon->journal_) {
    daemon->snapshot_writer_ = std::make_unique<SnapshotWriter>(
        params.data_dir, params.journal, daemon->journal_.get(), daemon->log_,
        daemon->snapshot_->update_sequence, recovered_snapshot ? &*recovered_snapshot : nullptr,
        SteadyMicros());
  }
  SLAMD_RETURN_IF_ERROR(daemon->Subscribe());
  SLAMD_RETURN_IF_ERROR(daemon->StartShards());
  daemon->follow_.hearing_since_us = SteadyMicros();
  return daemon;
}

Daemon::Daemon(const ServerParams& params, Bus* bus, std::unique_ptr<Estimator> estimator,
               std::unique_ptr<Journal> journal)
    : params_(params),
      bus_(bus),
      channels_{params.channel_prefix},
      estimator_(std::move(estimator)),
      journal_(std::move(journal)),
      queue_(params.queue.depth),
      refine_schedule_(params.refine.idle_s),
      snapshot_(estimator_->snapshot()) {
  log_ = spdlog::get("slamd");
  if (!log_) log_ = spdlog::default_logger();
}

Daemon::~Daemon() { Stop(); }

int Daemon::StepEstimator(double timeout_s) {
  std::vector<Inbound> popped, batch;
  std::vector<QueryRequest> queries;
  int n = queue_.Pop(&popped, timeout_s, params_.queue.max_per_update);
  if (n > 0 && params_.queue.coalesce_s > 0.0 && FromCameraRobot(popped)) {
    // The rest of a camera robot's burst (a frame's odometry and observations) joins this
    // update: otherwise the observations wait for the odometry's update.
    n += queue_.PopRestOfBurst(&popped, params_.queue.coalesce_s, 4 * params_.queue.coalesce_s,
                               params_.queue.max_per_update);
  }
  if (n > 0) {
    const std::int64_t now = SteadyMicros();
    for (const Inbound& in : popped) {
      refine_schedule_.OnInput(in.received_us > 0 ? in.received_us : now, now);
    }
  }
  for (Inbound& in : popped) {
    if (QueryRequest* q = std::get_if<QueryRequest>(&in.measurement)) {
      queries.push_back(std::move(*q));
    } else {
      batch.push_back(std::move(in));
    }
  }
  std::shared_ptr<const EstimateSnapshot> snap;
  bool journaled_refinement = false;
  if (!batch.empty()) {
    for (const Inbound& in : batch) {
      processed_sequence_ = std::max(processed_sequence_, in.journal_sequence);
    }
    // The newest poses go out as soon as they are solved (and journaled); the rest of the map's
    // back-substitution after them, before anything else reads the solver.
    ProcessResult r = estimator_->Process(batch, /*finish_later=*/true);
    unpublished_received_us_.insert(unpublished_received_us_.end(), r.applied_received_us.begin(),
                                    r.applied_received_us.end());
    if (JournalUpdate(batch)) PublishUnpublished();  // else once the replicated journal has it
    if (!r.already_held_robots.empty() && !replication_held_) {
      AcknowledgeAlreadyHeld(*ShareSnapshot(), r.already_held_robots, SteadyMicros());
    }
    core::Stopwatch finish;
    estimator_->FinishUpdate();
    const double finish_us = finish.Seconds() * 1e6;
    for (size_t k = 0; k < r.updates.size(); ++k) {
      // The last update's time includes the back-substitution it left for FinishUpdate.
      const double extra = k + 1 == r.updates.size() ? finish_us : 0.0;
      update_latency_.Record(r.updates[k].seconds.total * 1e6 + extra);
      log_->debug("update: {}", r.updates[k].Brief());
    }
    if (!r.status.ok()) log_->warn("solver update failed: {}", r.status.ToString());
    for (const Rejection& rej : r.rejections) PublishRejection(rej);
    ApplyPoseWindow();
  } else if (queries.empty() && RefineDue() && refine_schedule_.WaitMicros(SteadyMicros()) == 0) {
    core::Stopwatch refine_time;
    const core::Isam2::RefineResult r = estimator_->Refine(params_.refine.budget_s);
    refine_schedule_.OnRefine(static_cast<std::int64_t>(refine_time.Seconds() * 1e6));
    if (!r.status.ok()) log_->warn("refine failed: {}", r.status.ToString());
    if (journal_ && r.rounds > 0) {
      const core::Status s = journal_->AppendRefinement(r.rounds);
      if (!s.ok()) NoteJournalError(s);
      journaled_refinement = true;
    }
  }
  // No update committed the replica in this step: the refinement's record, or a retry while
  // held (whose success releases the held estimates).
  const bool was_held = replication_held_;
  if (batch.empty() && (journaled_refinement || was_held) && CommitReplica() && was_held) {
    PublishUnpublished();
  }
  if (journal_ && params_.journal.sync == SyncPolicy::kInterval) {
    const core::Status s = journal_->Commit();
    if (!s.ok()) log_->error("journal sync: {}", s.ToString());
  }
  MaybeSnapshot();
  snap = ShareSnapshot();
  if (!replication_held_) {
    PublishEstimates(*snap, SteadyMicros());  // a refinement's (an update's went out above)
  }
  for (const QueryRequest& q : queries) AnswerAndPublish(q, snap->update_sequence);
  if (!replication_held_) MaybePublishMaps(*snap);
  MaybePublishStatus(*snap);
  if (!replication_held_) MaybeSendSummaries();
  // After this step's estimates went out: bringing a rebuilt solver up to date takes an update.
  if (estimator_->RebuildReady()) SwapRebuild();
  return n;
}

bool Daemon::FromCameraRobot(const std::vector<Inbound>& popped) {
  bool camera_robot = false;
  for (const Inbound& in : popped) {
    if (std::holds_alternative<FrameObservations>(in.measurement)) {
      camera_robots_.insert(MessageRobot(in));
    }
    camera_robot = camera_robot || camera_robots_.contains(MessageRobot(in));
  }
  return camera_robot;
}

void Daemon::ApplyPoseWindow() {
  // The window waits for a rebuild in flight; once it fell behind, the rebuild is swapped in
  // now (journaled as any swap), so that the graph stays bounded under a sustained load.
  if (estimator_->Rebuilding() && estimator_->WindowBehind()) {
    estimator_->HurryRebuild();
    SwapRebuild();
  }
  const NodeRemovalRecord removed = estimator_->ApplyPoseWindow();
  if (removed.keys.empty()) return;
  log_->debug("lifelong window: removed {} variables", removed.keys.size());
  if (!journal_) return;
  journal::Removal record;
  record.set_update_sequence(estimator_->snapshot()->update_sequence);
  record.mutable_keys()->Add(removed.keys.begin(), removed.keys.end());
  EncodeValues(removed.at, record.mutable_at());
  record.mutable_roots()->Add(removed.roots.begin(), removed.roots.end());
  for (const auto& [pose, alias] : removed.aliases) {
    EncodeAlias(pose, alias, record.add_aliases());
  }
  const core::Status s = journal_->AppendRemoval(record);
  if (!s.ok()) NoteJournalError(s);
}

void Daemon::PublishEstimatesAndLatencies(std::span<const std::int64_t> applied_received_us) {
  const std::int64_t published_us = SteadyMicros();
  PublishEstimates(*ShareSnapshot(), published_us);
  // Ingest-to-publish latency of every message that took effect: the first of several that
  // shared an update waited longest.
  for (std::int64_t received_us : applied_received_us) {
    if (received_us > 0) {
      publish_latency_.Record(static_cast<double>(published_us - received_us));
    }
  }
}

void Daemon::SwapRebuild() {
  const std::int64_t sequence = estimator_->snapshot()->update_sequence;
  core::Stopwatch timer;
  const core::Result<bool> swapped = estimator_->FinishRebuild();
  if (!swapped.ok()) log_->warn("{}", swapped.status().ToString());
  log_->debug("rebuilt solver swapped in after update {}: {:.3f} ms", sequence,
              timer.Seconds() * 1e3);
  // Journaled failed or not: a replay fails the same way, and relinearises the same way after.
  if (journal_) {
    const core::Status s = journal_->AppendRebuildSwap(sequence, estimator_->last_swap_rounds());
    if (!s.ok()) NoteJournalError(s);
  }
  PublishEstimates(*ShareSnapshot(), SteadyMicros());
}

std::shared_ptr<const EstimateSnapshot> Daemon::ShareSnapshot() {
  std::shared_ptr<const EstimateSnapshot> snap = estimator_->snapshot();
  std::lock_guard lock(snapshot_mutex_);
  snapshot_ = snap;
  return snap;
}

void Daemon::NoteReject(std::string_view type, const Verdict& verdict) {
  log_->debug("reject {}: {}", type, verdict.message);
  constexpr std::int64_t kPeriodUs = 10'000'000;
  std::lock_guard lock(reject_log_mutex_);
  ++rejects_unlogged_;
  const std::int64_t now = SteadyMicros();
  if (reject_logged_us_ != 0 && now - reject_logged_us_ < kPeriodUs) return;
  log_->warn("{} message(s) rejected since the last warning; latest: {} ({}): {}",
             rejects_unlogged_, type, RejectReasonName(verdict.reason), verdict.message);
  rejects_unlogged_ = 0;
  reject_logged_us_ = now;
}

void Daemon::PublishRejection(const Rejection& rej) {
  // Stateful rejects are counted by the estimator (not by PublishReject's intake counters).
  slamd::reject_t out;
  FillReject(rej.verdict, InboundChannel(rej.message), MessageTypeName(rej.message),
             MessageRobot(rej.message), MessageUtime(rej.message), WallMicros(), &out);
  NoteReject(MessageTypeName(rej.message), rej.verdict);
  const core::Status s = server::Publish(*bus_, channels_.Reject(), out);
  if (!s.ok()) log_->warn("cannot publish reject_t: {}", s.ToString());
}

void Daemon::PublishUnpublished() {
  PublishEstimatesAndLatencies(unpublished_received_us_);
  unpublished_received_us_.clear();
}

bool Daemon::JournalUpdate(const std::vector<Inbound>& batch) {
  if (!journal_) return true;
  int count = 0;
  std::int64_t last = 0;
  for (const Inbound& in : batch) {
    if (in.journal_sequence == 0) continue;
    ++count;
    last = std::max(last, in.journal_sequence);
  }
  if (count == 0) return CommitReplica();
  core::Status s = journal_->AppendBoundary(estimator_->snapshot()->update_sequence, last, count);
  if (s.ok()) s = journal_->Commit();
  // The messages are in the journal; without the boundary a replay merges them into the next
  // update.
  if (!s.ok()) NoteJournalError(s);
  return CommitReplica();
}

void Daemon::NoteJournalError(const core::Status& s) {
  ++journal_errors_;
  log_->error("journal: {}", s.ToString());
}

void Daemon::MaybeSnapshot() {
  if (!snapshot_writer_) return;
  const std::int64_t sequence = estimator_->snapshot()->update_sequence;
  const std::int64_t now = SteadyMicros();
  if (!snapshot_writer_->Due(sequence, now, journal_->offset())) return;
  snapshot_writer_->Join();  // before the export: it may still be reading the last state
  auto state = std::make_shared<const EstimatorState>(estimator_->ExportState());
  const JournalPosition position{.last_message_sequence = processed_sequence_,
                                 .journal_offset = journal_->offset()};
  // Into NATS too when leading, once the stream holds every record the state includes.
  std::optional<SnapshotWriter::ToStream> to_stream;
  if (stream_snapshots_ && !replication_held_ && !deposed_ && CommitReplica()) {
    const core::Result<FollowPoint> follow =
        replica_->FollowPointFor(position.last_message_sequence);
    if (follow.ok()) {
      to_stream = SnapshotWriter::ToStream{
          .snapshots = stream_snapshots_.get(), .source = replica_->source(), .follow = *follow};
    } else {
      log_->warn("replication: this snapshot stays local: {}", follow.status().ToString());
    }
  }
  snapshot_writer_->Write(std::move(state), position, sequence, now, SteadyMicros() - now,
                          std::move(to_stream));
}

std::shared_ptr<const EstimateSnapshot> Daemon::snapshot() const {
  std::lock_guard lock(snapshot_mutex_);
  return snapshot_;
}

void Daemon::IntakeLoop() {
  while (!stop_intake_) {
    const core::Result<int> r = PumpIntake(50);
    if (!r.ok()) log_->error("transport: {}", r.status().ToString());
  }
}

void Daemon::EstimatorLoop() {
  // Waits at most 50 ms for messages so status keeps going when idle; not at all while a
  // refinement is still due, so the map converges between messages.
  while (!stop_estimator_) {
    if (standby_) {
      StandbyStep();
      continue;
    }
    double wait_s = estimator_->Rebuilding() ? 0.001 : 0.05;  // a rebuild is swapped in promptly
    if (RefineDue()) {
      wait_s = std::clamp(refine_schedule_.WaitMicros(SteadyMicros()) * 1e-6, 0.0, wait_s);
    }
    StepEstimator(wait_s);
  }
  // Intake has stopped and the queue is closed: finish what is queued.
  while (StepEstimator(0.0) > 0) {
  }
}

bool Daemon::RefineDue() const {
  // Not while a rebuild is in flight: the swap would discard the refinement.
  return params_.refine.enabled && !estimator_->snapshot()->settled && !estimator_->Rebuilding();
}

void Daemon::Start() {
  if (intake_thread_.joinable() || stopped_) return;
  estimator_thread_ = std::thread([this] {
    core::NameThisThread("slamd-estimator");
    EstimatorLoop();
  });
  intake_thread_ = std::thread([this] {
    core::NameThisThread("slamd-intake");
    IntakeLoop();
  });
  log_->info("slamd running: prefix '{}', queue {}, refine {}", params_.channel_prefix,
             params_.queue.depth, params_.refine.enabled ? "on" : "off");
}

void Daemon::Stop() {
  if (stopped_) return;
  stopped_ = true;
  stop_intake_ = true;
  if (intake_thread_.joinable()) intake_thread_.join();
  subscriptions_.clear();
  shard_exchange_.nats.reset();  // no more summaries from NATS
  {  // driven by hand, a caller's own bus.HandleOnce may have left messages held
    std::lock_guard lock(intake_mutex_);
    QueueHeldLocked();
  }
  queue_.Close();
  stop_estimator_ = true;
  if (estimator_thread_.joinable()) estimator_thread_.join();
  snapshot_writer_.reset();  // waits for the snapshot being written
  if (journal_) {
    const core::Status s = journal_->Sync();
    if (!s.ok()) log_->error("journal sync at shutdown: {}", s.ToString());
    if (replica_ && !CommitReplica()) {
      log_->error(
          "replication: {} journal bytes not in the stream at shutdown (sent at the next "
          "start from this data directory)",
          replica_->pending_bytes());
    }
    if (estimator_->held_messages() > 0) {
      log_->info("{} held messages stay in the journal and wait again after a restart",
                 estimator_->held_messages());
    }
  } else {
    // Nothing would keep them: answer them now.
    for (const Rejection& rej :
         estimator_->RejectHeld("still waiting for a pose when slamd stopped (no data_dir)")) {
      PublishRejection(rej);
    }
    ShareSnapshot();
  }
  ReleaseLease();
  const std::shared_ptr<const EstimateSnapshot> snap = snapshot();
  if (!standby_) PublishStatus(*snap);
  if (params_.estimator.shards.sharded()) {
    log_->info("shard '{}': {} summaries sent ({} bytes), {} messages for other shards",
               params_.estimator.shards.self, shard_exchange_.summaries_sent.load(),
               shard_exchange_.summary_bytes.load(), shard_exchange_.not_owned.load());
  }
  log_->info("slamd stopped after {} updates; {} messages received", snap->counters.updates,
             received_.load());
  log_->flush();
}

}  // namespace slamd::server
