// ServerParams: everything slamd is configured with, as aggregate structs (style.md §2).
// Each field maps 1:1 to a field of msgs/proto/config.proto (same names and nesting); the
// config loader fills these in and calls Validate() once at startup.
#pragma once

#include <cstdint>
#include <string>

#include "core/base/status.h"
#include "core/isam/isam2_params.h"
#include "server/estimator/estimator_params.h"
#include "server/journal/journal_writer.h"

namespace slamd::server {

struct ServerParams {
  // LCM URL the daemon listens and publishes on ("memq://" for one process). Non-empty.
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0";
  // Prefix of every channel name (server/transport/channels.h); 1..40 chars of [A-Za-z0-9_].
  std::string channel_prefix = "SLAMD_";
  // Journal and snapshot directory (created if missing). "" = no journal: accepted messages
  // live only in memory and a restart starts empty.
  std::string data_dir = "";
  // Skip corrupt journal records at recovery instead of refusing to start (`slamd --salvage`;
  // not a config-file field: it is a one-off decision after reading the error).
  bool salvage = false;
  // spdlog level: trace, debug, info, warn, error, critical or off.
  std::string log_level = "info";
  // Optional rotating log file ("" = console only).
  std::string log_file = "";

  struct Queue {
    // Bound of the ingest queue [messages]; 1..10'000'000.
    int depth = 10000;
    // How long intake blocks on a full queue before it rejects (REASON_QUEUE_FULL) [s]; 0..10.
    // After such a reject, the next messages are rejected at once until the estimator takes the
    // queue: a blocked intake does not read the transport, which then loses messages unanswered.
    double block_timeout_s = 0.05;
    // The estimator takes a camera robot's messages that come within this long of each other
    // into one update (its odometry and a frame's observations, sent back to back), waiting
    // for the quiet at most four times this [s]; 0 = take what is queued at once; 0..0.01.
    // Robots that send no frames are not waited for.
    double coalesce_s = 0.0003;
    // An update takes at most this many of the queued messages, the rest the next updates
    // [messages]; 1..10'000'000. Under a sustained load the queue stays full, and updates that
    // each took all of it (up to `depth`) grew to seconds and gigabytes.
    int max_per_update = 1000;
  };
  Queue queue = {};

  struct Publish {
    // status_t rate [Hz]; 0 = never; 0..1000.
    double status_rate_hz = 1.0;
    // Periodic map_t (every robot's map, paged) rate [Hz]; 0 = never (maps on request only);
    // 0..100.
    double map_rate_hz = 0.0;
    // Periodic maps carry every variable's marginal covariance (one Bayes-tree pass each).
    bool map_covariance = false;
    // estimate_t carries the newest pose's marginal covariance (a few µs per update).
    bool estimate_covariance = true;
    // Time a query may spend on marginals before the rest are left out
    // (query_reply_t.STATUS_PARTIAL) [s]; (0, 10].
    double query_budget_s = 0.1;
    // status_t's latency percentiles cover the last this many updates (and published
    // estimates); 16..1048576. Larger windows describe a whole benchmark run.
    int latency_window = 1024;
  };
  Publish publish = {};

  struct Refine {
    // Run Isam2::Refine while the queue is empty, so the map converges between messages.
    bool enabled = true;
    // Time budget of one Refine call [s]; (0, 10].
    double budget_s = 0.005;
    // ... once no message has come for this long [s], or, in a steady stream, in a gap it is
    // predicted to end in (server/daemon/refine_schedule.h): a refinement round cannot be
    // interrupted and would delay the next message; 0..10.
    double idle_s = 0.02;
  };
  Refine refine = {};

  struct Journal {
    // When the journal is fdatasync'ed: ALWAYS once per solver update (group commit; estimates
    // are published after their messages are durable), INTERVAL every sync_interval_ms, or
    // NEVER (the OS decides; a process crash still loses nothing, a power failure may).
    SyncPolicy sync = SyncPolicy::kAlways;
    // [ms]; 1..60000.
    int sync_interval_ms = 50;
    // A snapshot after this many solver updates (0 = not by count) ... >= 0.
    int snapshot_every_updates = 500;
    // ... or this many seconds since the last one, if anything changed (0 = not by time) [s];
    // 0..1e6. Either way at most 5% of the time goes to snapshots: after one that took t, the
    // next waits at least 20 t (the cost grows with the map: 20000 poses ~30 ms, 4.4 MB).
    double snapshot_every_s = 300.0;
    // ... or once the journal grew this many bytes since the last one (0 = not by size)
    // [bytes]; >= 0. Bounds the journal on disk whatever the message and update rates: with
    // delete_covered_segments it holds about keep_snapshots x this, plus a segment.
    std::int64_t snapshot_every_bytes = std::int64_t{256} << 20;
    // Snapshots kept on disk (the newest and older ones, in case the newest is damaged); >= 1.
    // With 2 or more, the oldest goes just before a new one is written: never more on disk.
    int keep_snapshots = 2;
    // The journal is a sequence of segment files; a new one starts after this many bytes
    // [bytes]; >= 4096.
    std::int64_t segment_bytes = std::int64_t{64} << 20;
    // After each snapshot, delete the segments the oldest kept snapshot covers (recovery needs
    // none of them), so the journal on disk stays bounded by what came after it. false keeps
    // the whole history (an audit trail; `slamctl journal export` reads it).
    bool delete_covered_segments = true;
  };
  Journal journal = {};

  // The replicated journal (server/replication/stream_journal.h): every journal record also in
  // a NATS JetStream stream, acknowledged by its quorum before the estimates that include it are
  // published. Needs data_dir. While NATS does not acknowledge, intake is held (status_t).
  struct Replication {
    // The NATS servers, comma-separated ("nats://10.0.0.1:4222,nats://10.0.0.2:4222");
    // "" = no replication (the default).
    std::string servers;
    std::string stream = "SLAMD";           // the stream's name, [A-Za-z0-9_-]+
    std::string subject = "slamd.journal";  // the subject it captures
    int replicas = 3;                       // copies of each record in the cluster; 1..5
    // How long an update's records may wait for the stream's acknowledgement before intake is
    // held [ms]; 1..60000.
    int ack_timeout_ms = 1000;
    // A replicated pair (hot standby): > 0 = slamd contends for a lease of this length in the
    // JetStream key-value bucket `lease_bucket`; the holder leads (journals, publishes), the
    // other follows the stream as a standby and takes over once the lease lapses. 0 = no lease:
    // this slamd always leads [ms]; 0 or 100..60000.
    int lease_ttl_ms = 0;
    std::string lease_bucket = "SLAMD_LEADER";
    // What a standby hears directly from the robots is kept this long, and journaled when it
    // takes over (what the old leader accepted but never got into the stream) [s]; 0.1..600.
    double standby_keep_s = 30.0;
    // The leader's snapshots are also stored in the stream "<stream>_SNAPSHOTS", the newest
    // keep_snapshots of them, and the journal stream is truncated before the oldest kept one: it
    // holds what came after it (server/replication/stream_snapshots.h). A standby starts from
    // the newest. 0 = no snapshot in NATS, the stream keeps the whole history; 0..100.
    int keep_snapshots = 2;
  };
  Replication replication = {};

  // Map shards (docs/SCALING.md): which robots this slamd owns is estimator.shards; every
  // summary_every_ms it sends each neighbouring shard its summary on the poses they share (when
  // the estimate changed), over NATS (servers; subject <subject>.<shard>) or, without servers,
  // on the bus (channel <prefix>SHARD_SUMMARY).
  struct Shards {
    std::string servers;                   // NATS URLs, comma-separated; "" = the LCM bus
    std::string subject = "slamd.shards";  // NATS subject prefix, [A-Za-z0-9_-] parts
    int summary_every_ms = 1000;           // 10..600000
    // Shards on different LCM buses (needs servers): a query for another shard's robot is
    // forwarded to its owner on <subject>.<owner>.query; the owner's replies, map pages and
    // rejects come back on <subject>.<self>.reply and are published on this bus. Off: all
    // shards hear one bus and the owner answers there.
    bool forward_queries = false;
  };
  Shards shards = {};

  // The solver (core/isam/isam2_params.h); validated by Isam2Params::Validate.
  core::Isam2Params isam2 = {};

  // Stateful checks and new-robot anchoring (server/estimator/estimator_params.h).
  EstimatorParams estimator = {};

  // InvalidArgument naming the first violating field as its config path, e.g.
  // "queue.depth = 0; violates >= 1" or "isam2.relinearization.skip = 0; violates >= 1".
  core::Status Validate() const;
};

// Maps a spdlog level name to its number (0 trace .. 6 off); -1 when unknown.
int LogLevelNumber(const std::string& name);

}  // namespace slamd::server
