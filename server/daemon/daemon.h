// Daemon: slamd's runtime — the transport (intake) thread, the bounded ingest queue and the
// estimator thread, wired to a Bus (server/transport). main.cc is a thin shell around it.
//
//   intake thread:    bus.HandleOnce -> decode -> Convert (validate) -> queue.Push; under
//                     journal.sync ALWAYS a burst of messages that arrived together is pushed
//                     together (a bad message, or a full queue after queue.block_timeout_s, gets
//                     a reject_t at once; nothing is dropped silently)
//   estimator thread: queue.Pop -> Estimator::Process (ONE Isam2 update for what is queued,
//                     up to queue.max_per_update) -> reject_t for stateful rejections, estimate_t
//                     for each robot whose newest pose moved, status_t at publish.status_rate_hz;
//                     while refine.enabled, Isam2::Refine(refine.budget_s) until settled, when the
//                     RefineSchedule sees room: in a steady stream's gaps, else after refine.idle_s
//                     without a message.
//
// Inbound channels: one per message spec (server/messages/inbound.h), all through the queue;
// measurements and retractions into Estimator::Process, queries (so a query sees everything
// sent before it) answered on QUERY_REPLY, maps on MAP, after the update of its batch, within
// publish.query_budget_s for marginals). An invalid query gets a reject_t and a
// STATUS_REJECTED reply. estimate_t carries the newest pose's marginal covariance when
// publish.estimate_covariance; map_t pages of every robot go out at publish.map_rate_hz.
//
// Durability (params.data_dir set; server/journal, server/estimator/recovery.h): Create()
// recovers the directory's snapshot and journal before subscribing. Intake appends every
// accepted message to the journal before queueing it (a message the journal cannot take is
// rejected with REASON_STORAGE_ERROR: nothing unjournaled is ever accepted); the estimator
// appends an update boundary after each update and commits (journal.sync) before publishing;
// refinements are journaled by round count, swaps of a solver rebuilt in the background
// (Estimator::FinishRebuild) by a record; the SnapshotWriter writes snapshots from an
// exported copy of the estimator every journal.snapshot_every_updates / _s / _bytes.
//
// Threads, each named and owned by one object, started and stopped in this order:
//   slamd-estimator  Daemon (Start; Stop joins it after slamd-intake, once the queue is drained)
//   slamd-intake     Daemon (Start; Stop joins it first: nothing new is taken in)
//   slamd-rebuild    BackgroundRebuild, owned by the Estimator (joined by the swap or its end)
//   slamd-retire     the Estimator (frees a solver a swap replaced)
//   slamd-snapshot   SnapshotWriter (joined before the next snapshot and by Stop)
//   slamd-worker     the solver's parallel steps (core/base/worker_pool.h)
//
// Either Start() the two threads, or drive the same steps by hand (no threads) with
// PumpIntake / StepEstimator, as deterministic tests do; do not mix the two.
// Stop(): stop intake, finish the update in progress and whatever is queued, publish a last
// status_t, join. Idempotent; the destructor calls it.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <set>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "server/config/server_params.h"
#include "server/daemon/ingest_queue.h"
#include "server/daemon/latency_window.h"
#include "server/daemon/refine_schedule.h"
#include "server/daemon/shard_exchange.h"
#include "server/daemon/snapshot_writer.h"
#include "server/daemon/standby_state.h"
#include "server/estimator/estimator.h"
#include "server/journal/journal.h"
#include "server/replication/leader_lease.h"
#include "server/replication/stream_journal.h"
#include "server/replication/stream_snapshots.h"
#include "server/transport/bus.h"
#include "server/transport/channels.h"
#include "slamd/query_reply_t.hpp"

namespace spdlog {
class logger;
}  // namespace spdlog

namespace slamd::server {

class Daemon {
 public:
  // `bus` is not owned and must outlive the Daemon. Subscribes to the inbound channels (so
  // messages published after Create are seen). InvalidArgument when params do not validate.
  static core::Result<std::unique_ptr<Daemon>> Create(const ServerParams& params, Bus* bus);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  // Starts the intake and estimator threads.
  void Start();
  // See the file comment. Safe to call more than once and without Start().
  void Stop();

  // Manual drive. One bus.HandleOnce(timeout_ms) on the calling thread (under journal.sync
  // ALWAYS then up to 15 more that do not wait: the rest of a burst), then the accepted messages
  // are queued together: returns the number of messages dispatched (to every subscriber of the
  // bus, not only the daemon).
  core::Result<int> PumpIntake(int timeout_ms);
  // Waits up to timeout_s for queued messages and processes all of them in one update (or
  // refines when none came and refinement is due); publishes. Returns the messages processed.
  int StepEstimator(double timeout_s);

  std::shared_ptr<const EstimateSnapshot> snapshot() const;
  // This slamd of a replicated pair may no longer act: it lost the lease or found another
  // writer on the stream while leading, or could not follow the stream as a standby. It holds
  // intake and publishes nothing; main() stops it.
  bool deposed() const { return deposed_; }
  // The estimator, for tests that drive the daemon by hand (no threads running).
  const Estimator& estimator_for_tests() const { return *estimator_; }
  const Journal* journal_for_tests() const { return journal_.get(); }  // null without data_dir
  int queue_depth() const { return queue_.size(); }

 private:
  Daemon(const ServerParams& params, Bus* bus, std::unique_ptr<Estimator> estimator,
         std::unique_ptr<Journal> journal);

  // Replication (daemon_replication.cc). When params.replication.servers is set: the replicated
  // journal, or with a lease (lease_ttl_ms) either that (lease taken) or the standby's follower.
  // A standby whose data directory held a journal moves it aside first (*superseded: the
  // recovered state is gone; the stream is the truth).
  core::Status StartReplication(bool* superseded);
  // Moves the journal and snapshots of data_dir into data_dir/superseded-<µs>/ and starts over
  // empty (journal, estimator).
  core::Status SupersedeLocalState();
  // Becomes a standby (superseding a non-empty data directory): follows the stream from the
  // newest snapshot in NATS (StartFromStreamSnapshot), or from its start when there is none.
  core::Status Follow(bool* superseded);
  // A standby's start from the newest snapshot in NATS: the estimator restored from it, the
  // data directory holding it as its snapshot and a journal that begins where the stream is
  // followed (*from). False when NATS holds no snapshot.
  core::Result<bool> StartFromStreamSnapshot(FollowPoint* from);
  // The leader's snapshot stream (replication.keep_snapshots > 0), opened once leading.
  core::Status OpenStreamSnapshots();
  // Commits the replica (true without one). A failure holds intake and the estimates until a
  // later commit succeeds.
  bool CommitReplica();
  // Intake's wait while replication is held: true once it is not, false after timeout_s.
  bool WaitForReplication(double timeout_s) const;
  // Standby: keeps a message heard from a robot (replication.standby_keep_s).
  // False when this slamd is no longer a standby (it took over meanwhile): nothing kept.
  bool Hear(std::string_view channel, std::string_view type, std::vector<std::uint8_t> bytes);
  // Standby (estimator thread): applies what the stream brought, copies it into the local
  // journal, and takes over once the lease is free.
  void StandbyStep();
  // One record of the followed stream, applied and copied; false when it could not be.
  bool ApplyFollowed(const journal::JournalRecord& record);
  // The rest of the stream, then the replicated journal from this data directory, the old
  // leader's unprocessed messages, what this slamd heard, and every robot's estimate.
  void TakeOver();
  void StartLeaseThread();  // slamd-lease: renews the lease every lease_ttl_ms / 4
  void ReleaseLease();      // joins slamd-lease; a held lease is released (clean hand-over)
  // Swaps in the estimator's rebuilt solver (ready), journals the swap, publishes.
  void SwapRebuild();
  // Whether `popped` holds a message of a robot that sends camera frames (noting the robots of
  // its frame_observations_t): their bursts are popped whole (queue.coalesce_s).
  bool FromCameraRobot(const std::vector<Inbound>& popped);
  void ApplyPoseWindow();  // the lifelong window (EstimatorParams::window), journaled
  // The estimator's latest snapshot, made the one queries and snapshot() see.
  std::shared_ptr<const EstimateSnapshot> ShareSnapshot();
  // The estimates, and the ingest-to-publish latencies of unpublished_received_us_ (cleared).
  void PublishUnpublished();
  // Journals what the estimator did (no-op without a journal); false while the replicated
  // journal does not have it (its estimates must wait).
  bool JournalUpdate(const std::vector<Inbound>& batch);
  // Counts and logs a journal failure (the estimator goes on: see JournalUpdate).
  void NoteJournalError(const core::Status& s);
  void PublishRejection(const Rejection& rejection);  // a stateful (estimator) rejection
  // Logs every rejection at debug level and a warning at most every 10 s (with the count since
  // the last one), so a flood of bad input cannot flood the log.
  void NoteReject(std::string_view type, const Verdict& verdict);
  void MaybeSnapshot();

  // Map shards (daemon_shards.cc): subscribes to <shards.subject>.<self> on NATS (without
  // servers, summaries come on the bus like any message); every shards.summary_every_ms, sends
  // every other shard its summary when it changed.
  core::Status StartShards();
  void MaybeSendSummaries();
  void SendSummaries(const ShardSummaryMessage& summary);  // to every other shard
  // shards.forward_queries: sends a query to another shard that answers it (the owner of one of
  // its robots; QuerySpec::AnsweringShards); takes a query forwarded to this shard into intake
  // (its answer goes back through a relay); publishes on the bus what an owner sent back.
  void ForwardQuery(std::string_view channel, const slamd::query_t& msg, const std::string& owner);
  void OnForwardedQuery(const std::string& subject, std::span<const std::uint8_t> payload);
  void OnRelayedReply(const std::string& subject, std::span<const std::uint8_t> payload);
  // Where the answer to a query goes: the bus, or the relay to the shard that forwarded it.
  Bus& ReplyBus(const std::string& reply_shard);

  core::Status Subscribe();
  template <typename Msg>
  core::Status SubscribeInbound(const std::string& channel);
  // reply_shard: the shard that forwarded this query ("" = heard on the bus).
  template <typename Msg>
  void OnInbound(std::string_view channel, const Msg& msg, const std::string& reply_shard = "");
  void OnDecodeError(std::string_view channel, const core::Status& error);
  // Queues what intake_held_ holds, in order; intake_mutex_ held.
  void QueueHeldLocked();
  // On `out` (null: the bus).
  void PublishReject(const Verdict& verdict, std::string_view channel, std::string_view type,
                     std::string_view robot, std::int64_t utime, Bus* out = nullptr);
  // A query that gets no answer: its reject_t and the query_reply_t its asker waits for, as
  // `shard`'s reply ("": this one's).
  void RejectQuery(const Verdict& verdict, std::string_view channel, const slamd::query_t& msg,
                   Bus& out, const std::string& shard = "");
  // query_reply_t.shard and shards_answering (QuerySpec::AnsweringShards).
  void SignReply(const std::set<std::string>& answering, const std::string& shard,
                 slamd::query_reply_t* reply) const;
  std::string InboundChannel(const Inbound& in) const;
  // now_steady: the publication time that latency_us counts to.
  void PublishEstimates(const EstimateSnapshot& snap, std::int64_t now_steady);
  // The estimates of `robots` whatever moved: the answer to messages the graph held already
  // (a robot re-sending after a restart waits for its poses to be acknowledged).
  void AcknowledgeAlreadyHeld(const EstimateSnapshot& snap, const std::set<std::string>& robots,
                              std::int64_t now_steady);
  // One robot's estimate_t (now: wall clock, now_steady: what latency_us counts to) [µs].
  void PublishEstimate(const RobotEstimate& r, std::int64_t update_sequence, std::int64_t now,
                       std::int64_t now_steady);
  // The current snapshot's estimates, now, and the ingest-to-publish latency of the messages
  // received at `applied_received_us` [µs, steady clock] that took effect in it.
  void PublishEstimatesAndLatencies(std::span<const std::int64_t> applied_received_us);
  void PublishStatus(const EstimateSnapshot& snap);
  void MaybePublishStatus(const EstimateSnapshot& snap);
  void MaybePublishMaps(const EstimateSnapshot& snap);
  void AnswerAndPublish(const QueryRequest& query, std::int64_t update_sequence);
  // Publishes the map_t pages of `robot` ("*" = all) on `out`; returns how many.
  int PublishMaps(Bus& out, const std::string& robot, bool marginals, std::int64_t request_id,
                  std::int64_t update_sequence, bool* partial);
  bool RefineDue() const;  // refinement enabled and the estimate not settled
  void IntakeLoop();
  void EstimatorLoop();

  ServerParams params_;
  Bus* bus_;
  ChannelNames channels_;
  std::unique_ptr<Estimator> estimator_;  // estimator thread only
  // The journal's replica (null without replication): declared before journal_, which points
  // to it, so it is destroyed after it.
  std::unique_ptr<StreamJournal> replica_;
  std::unique_ptr<Journal> journal_;  // null without data_dir
  // The replica's last commit failed: intake rejects, estimates wait (estimator thread writes).
  std::atomic<bool> replication_held_{false};
  std::atomic<std::int64_t> replication_holds_{0};
  // Receipt times of applied messages whose estimates have not gone out (they wait for the
  // replicated journal) [µs, steady clock].
  std::vector<std::int64_t> unpublished_received_us_;
  // A replicated pair: the lease (null without one), and while standby_, what it follows/hears.
  std::unique_ptr<LeaderLease> lease_;
  std::atomic<bool> standby_{false};
  std::atomic<bool> deposed_{false};  // the lease was lost while leading: this slamd must stop
  std::atomic<bool> taking_over_{false};  // TakeOver: intake keeps queries heard too
  StandbyState follow_;                   // while standby_
  std::atomic<bool> stop_lease_{false};
  std::thread lease_thread_;
  ShardExchange shard_exchange_;  // map shards (daemon_shards.cc)
  IngestQueue queue_;
  // Journal append + queue push, so journal order = queue order; and intake_held_.
  std::mutex intake_mutex_;
  // Accepted (and journaled) messages of the burst being taken in (PumpIntake), not yet queued.
  std::vector<Inbound> intake_held_;
  std::shared_ptr<spdlog::logger> log_;
  std::vector<Subscription> subscriptions_;

  // Intake counters (intake thread writes, status reads).
  std::atomic<std::int64_t> received_{0}, queued_{0}, intake_rejected_{0}, decode_errors_{0};
  std::atomic<std::int64_t> journal_errors_{0};
  std::mutex reject_log_mutex_;
  std::int64_t rejects_unlogged_ = 0, reject_logged_us_ = 0;
  std::array<std::atomic<std::int64_t>, kNumRejectReasonCodes> intake_rejects_by_reason_{};

  // Estimator-thread state.
  std::int64_t published_sequence_ = 0;
  std::int64_t last_status_us_ = 0;
  bool last_status_settled_ = true;
  // Recent update and ingest-to-publish latencies for status_t [µs].
  LatencyWindow update_latency_{static_cast<size_t>(params_.publish.latency_window)};
  LatencyWindow publish_latency_{static_cast<size_t>(params_.publish.latency_window)};
  std::int64_t last_map_us_ = 0, last_map_sequence_ = -1;
  RefineSchedule refine_schedule_;
  std::set<std::string> camera_robots_;  // robots whose frame_observations_t came
  std::int64_t processed_sequence_ = 0;  // last journal sequence handed to the estimator
  // The leader's snapshots in NATS (null when not leading or keep_snapshots = 0); declared
  // before the writer whose thread puts them, so destroyed after it.
  std::unique_ptr<StreamSnapshots> stream_snapshots_;
  std::unique_ptr<SnapshotWriter> snapshot_writer_;  // null without a journal

  mutable std::mutex snapshot_mutex_;
  std::shared_ptr<const EstimateSnapshot> snapshot_;

  std::atomic<bool> stop_intake_{false}, stop_estimator_{false};
  std::thread intake_thread_, estimator_thread_;
  bool stopped_ = false;
};

// The journal's options from the config.
JournalOptions JournalOptionsOf(const ServerParams& params);

// Microseconds on the steady clock (latency accounting) and since the Unix epoch (utime fields).
std::int64_t SteadyMicros();
std::int64_t WallMicros();

}  // namespace slamd::server
