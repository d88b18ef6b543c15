// Daemon: what it publishes besides rejects: query replies, map pages, estimates (and the
// acknowledgement of messages held already) and status (see daemon.h).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <optional>

#include "core/base/memory_usage.h"
#include "server/daemon/daemon.h"
#include "server/messages/wire_values.h"
#include "server/publish/replies.h"
#include "server/query/query_service.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/map_t.hpp"
#include "slamd/query_reply_t.hpp"
#include "slamd/status_t.hpp"

namespace slamd::server {

void Daemon::AnswerAndPublish(const QueryRequest& query, std::int64_t update_sequence) {
  // Several shards answer (QuerySpec::AnsweringShards): each its own robots' keys and maps, and
  // none the joint marginal (not computed).
  const ShardMap& shards = params_.estimator.shards;
  const std::set<std::string> answering = QuerySpec::AnsweringShards(shards, query);
  std::optional<QueryRequest> without_joint;
  if (answering.size() > 1 && query.want_joint_marginal) {
    without_joint = query;
    without_joint->want_joint_marginal = false;
  }
  const QueryAnswer answer = AnswerQuery(*estimator_, without_joint ? *without_joint : query,
                                         params_.publish.query_budget_s);
  Bus& out = ReplyBus(query.reply_shard);
  int pages = 0;
  bool maps_partial = false;
  if (!query.map_robot.empty() && (query.map_robot == "*" || shards.Owns(query.map_robot))) {
    pages = PublishMaps(out, query.map_robot, query.want_marginals, query.request_id,
                        update_sequence, &maps_partial);
  }
  slamd::query_reply_t reply;
  FillQueryReply(query, answer, update_sequence, pages, WallMicros(), &reply);
  SignReply(answering, shards.self, &reply);
  if (answering.size() > 1) {
    // Another shard's key is its owner's to answer (here it may be a shared pose): not found.
    for (slamd::variable_t& v : reply.results) {
      if (shards.Owns(v.key.robot)) continue;
      slamd::variable_t not_found{};
      not_found.key = v.key;
      v = not_found;
    }
    if (without_joint) {
      reply.status = slamd::query_reply_t::STATUS_PARTIAL;
      reply.error = "no joint marginal of keys of several shards";
    }
  }
  if (maps_partial && reply.status == slamd::query_reply_t::STATUS_OK) {
    reply.status = slamd::query_reply_t::STATUS_PARTIAL;
    reply.error = "map marginals not ready within the query budget";
  }
  const core::Status s = server::Publish(out, channels_.QueryReply(), reply);
  if (!s.ok()) log_->warn("cannot publish query_reply_t: {}", s.ToString());
}

void Daemon::SignReply(const std::set<std::string>& answering, const std::string& shard,
                       slamd::query_reply_t* reply) const {
  reply->shard = shard;
  reply->shards_answering = std::max<std::int32_t>(1, static_cast<std::int32_t>(answering.size()));
}

int Daemon::PublishMaps(Bus& out, const std::string& robot, bool marginals, std::int64_t request_id,
                        std::int64_t update_sequence, bool* partial) {
  const std::vector<RobotMap> maps =
      CollectMaps(*estimator_, robot, marginals, params_.publish.query_budget_s, partial);
  int pages = 0;
  const std::int64_t now = WallMicros();
  for (const RobotMap& map : maps) {
    for (slamd::map_t& page : MapPages(map, update_sequence, request_id, now)) {
      page.shard = params_.estimator.shards.self;
      const core::Status s = server::Publish(out, channels_.Map(), page);
      if (!s.ok()) log_->warn("cannot publish map_t: {}", s.ToString());
      ++pages;
    }
  }
  return pages;
}

void Daemon::MaybePublishMaps(const EstimateSnapshot& snap) {
  if (params_.publish.map_rate_hz <= 0.0 || snap.update_sequence == last_map_sequence_) return;
  const std::int64_t now = SteadyMicros();
  const auto period = static_cast<std::int64_t>(1e6 / params_.publish.map_rate_hz);
  if (last_map_us_ != 0 && now - last_map_us_ < period) return;
  last_map_us_ = now;
  last_map_sequence_ = snap.update_sequence;
  bool partial = false;
  PublishMaps(*bus_, "*", params_.publish.map_covariance, 0, snap.update_sequence, &partial);
}

void Daemon::PublishEstimates(const EstimateSnapshot& snap, std::int64_t now_steady) {
  if (snap.update_sequence <= published_sequence_) return;
  const std::int64_t now = WallMicros();
  for (const RobotEstimate& r : snap.robots) {
    if (r.moved_sequence > published_sequence_) {
      PublishEstimate(r, snap.update_sequence, now, now_steady);
    }
  }
  published_sequence_ = snap.update_sequence;
}

void Daemon::AcknowledgeAlreadyHeld(const EstimateSnapshot& snap,
                                    const std::set<std::string>& robots, std::int64_t now_steady) {
  const std::int64_t now = WallMicros();
  for (const RobotEstimate& r : snap.robots) {
    if (robots.count(r.name) != 0) PublishEstimate(r, snap.update_sequence, now, now_steady);
  }
}

void Daemon::PublishEstimate(const RobotEstimate& r, std::int64_t update_sequence, std::int64_t now,
                             std::int64_t now_steady) {
  slamd::estimate_t out;
  out.utime = now;
  out.robot = r.name;
  out.update_sequence = update_sequence;
  out.pose_index = static_cast<std::int64_t>(r.pose_index);
  if (const core::Pose2* p2 = std::get_if<core::Pose2>(&r.pose)) {
    out.dimension = slamd::estimate_t::DIMENSION_2D;
    out.values = ToValues(*p2);
  } else {
    out.dimension = slamd::estimate_t::DIMENSION_3D;
    out.values = ToValues(std::get<core::Pose3>(r.pose));
  }
  out.num_values = static_cast<std::int32_t>(out.values.size());
  if (params_.publish.estimate_covariance) {
    Eigen::MatrixXd cov;
    const core::Key key = core::MakeKey('x', r.pose_index, r.id);
    if (estimator_->Marginal(key, &cov).ok()) out.covariance = ToRowMajor(cov);
  }
  out.num_covariance = static_cast<std::int32_t>(out.covariance.size());
  out.measurement_utime = r.measurement_utime;
  out.latency_us = r.received_us > 0 ? now_steady - r.received_us : 0;
  const core::Status s = server::Publish(*bus_, channels_.Estimate(), out);
  if (!s.ok()) log_->warn("cannot publish estimate_t: {}", s.ToString());
}

void Daemon::MaybePublishStatus(const EstimateSnapshot& snap) {
  if (params_.publish.status_rate_hz <= 0.0) return;
  const std::int64_t now = SteadyMicros();
  const auto period = static_cast<std::int64_t>(1e6 / params_.publish.status_rate_hz);
  // Also at once when the estimate has just settled: clients wait for that.
  const bool just_settled = snap.settled && !last_status_settled_;
  last_status_settled_ = snap.settled;
  if (!just_settled && last_status_us_ != 0 && now - last_status_us_ < period) return;
  last_status_us_ = now;
  PublishStatus(snap);
}

void Daemon::PublishStatus(const EstimateSnapshot& snap) {
  slamd::status_t out;
  out.utime = WallMicros();
  out.update_sequence = snap.update_sequence;
  out.rebuilds = snap.counters.rebuilds;
  out.num_robots = static_cast<std::int32_t>(snap.robots.size());
  out.num_variables = snap.num_variables;
  out.num_factors = snap.num_factors;
  out.messages_received = received_;
  out.messages_accepted = queued_;
  out.messages_rejected = intake_rejected_ + snap.counters.rejected;
  out.messages_already_held = snap.counters.already_held;
  out.decode_errors = decode_errors_;
  out.landmark_tracks = snap.landmark_tracks;
  out.track_observations = snap.track_observations;
  out.landmarks_dropped = snap.counters.landmarks_dropped;
  out.removed_variables = snap.counters.removed_variables;
  out.merged_poses = snap.counters.merged_poses;
  out.reduced_left_out = snap.counters.reduced_left_out;
  out.rss_bytes = core::ResidentBytes();
  out.heap_in_use_bytes = core::AllocatorInUseBytes();
  out.num_rejects_by_reason = kNumRejectReasonCodes;
  out.rejects_by_reason.resize(kNumRejectReasonCodes);
  for (int i = 0; i < kNumRejectReasonCodes; ++i) {
    out.rejects_by_reason[i] = intake_rejects_by_reason_[i] + snap.counters.rejects_by_reason[i];
  }
  out.queue_depth = queue_.size();
  out.queue_peak = queue_.peak();
  out.queue_capacity = queue_.capacity();
  const auto update = update_latency_.Percentiles<4>({0.5, 0.9, 0.99, 1.0});
  out.update_latency_p50_us = update[0];
  out.update_latency_p90_us = update[1];
  out.update_latency_p99_us = update[2];
  out.update_latency_max_us = update[3];
  const auto publish = publish_latency_.Percentiles<2>({0.5, 0.99});
  out.publish_latency_p50_us = publish[0];
  out.publish_latency_p99_us = publish[1];
  out.journal_records = journal_ ? journal_->records() : 0;
  out.journal_bytes = journal_ ? journal_->durable_offset() : 0;
  out.journal_disk_bytes = journal_ ? journal_->disk_bytes() : 0;
  out.journal_segments = journal_ ? journal_->segments() : 0;
  out.replication_held = replication_held_;
  out.replication_holds = replication_holds_;
  out.replicated_batches = replica_ ? replica_->batches_published() : 0;
  out.replication_pending_bytes = replica_ ? replica_->pending_bytes() : 0;
  out.shard_not_owned = shard_exchange_.not_owned;
  out.shard_summaries_sent = shard_exchange_.summaries_sent;
  out.shard_queries_forwarded = shard_exchange_.queries_forwarded;
  out.shard_summary_bytes = shard_exchange_.summary_bytes;
  out.shard_summaries_incomplete = shard_exchange_.summary_chunks.dropped();
  out.chi2 = snap.chi2;
  out.residual_dimension = snap.residual_dimension;
  out.settled = snap.settled;
  const core::Status s = server::Publish(*bus_, channels_.Status(), out);
  if (!s.ok()) log_->warn("cannot publish status_t: {}", s.ToString());
}

}  // namespace slamd::server
