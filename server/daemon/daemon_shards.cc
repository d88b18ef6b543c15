// Map shards (docs/SCALING.md): the daemon's side. Which messages a shard takes is decided at
// intake (ForThisShard); the estimator keeps the shared poses and applies neighbours' summaries
// (shard_summary_t, journaled like any message); here summaries come in from NATS and go out,
// and, for shards on different buses (shards.forward_queries), queries go to their owner and
// its answers come back.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <random>

#include "server/daemon/daemon.h"
#include "server/transport/typed_subscribe.h"

namespace slamd::server {
namespace {

// Whether `next` says more than `last` did: other poses, a pose moved by more than
// `pose_tolerance` (m or rad), or its information or gradient changed by more than 1e-3 of their
// largest entry. A itself is defined only up to a rotation of its rows, so what is compared is
// invariant to that: the information along the coordinate axes (A's column norms) and along a
// few fixed directions (|A·r|²), and the gradient Aᵀb; O(rows x columns), where comparing AᵀA
// whole cost two O(n³) products every summary_every_ms. Settled shards then stop sending.
bool SummaryChanged(const ShardSummaryMessage& last, const ShardSummaryMessage& next,
                    double pose_tolerance) {
  if (last.keys != next.keys || last.map_landmarks != next.map_landmarks ||
      last.x0.size() != next.x0.size() || last.A.cols() != next.A.cols()) {
    return true;
  }
  for (std::size_t i = 0; i < next.x0.size(); ++i) {
    if (last.x0[i].index() != next.x0[i].index() ||
        core::LocalCoordinates(last.x0[i], next.x0[i]).cwiseAbs().maxCoeff() > pose_tolerance) {
      return true;
    }
  }
  constexpr int kDirections = 4;
  std::mt19937_64 rng(1);  // the same directions for both
  std::normal_distribution<double> normal;
  Eigen::MatrixXd directions(next.A.cols(), kDirections);
  for (int k = 0; k < directions.size(); ++k) directions.data()[k] = normal(rng);
  const auto invariants = [&](const ShardSummaryMessage& m) {
    Eigen::VectorXd out(2 * m.A.cols() + kDirections);
    out << m.A.colwise().squaredNorm().transpose(), m.A.transpose() * m.b,
        (m.A * directions).colwise().squaredNorm().transpose();
    return out;
  };
  const Eigen::VectorXd a = invariants(last), b = invariants(next);
  return (a - b).cwiseAbs().maxCoeff() > 1e-3 * std::max(1.0, b.cwiseAbs().maxCoeff());
}

}  // namespace

core::Status Daemon::StartShards() {
  const ShardMap& shards = params_.estimator.shards;
  if (!shards.sharded() || params_.shards.servers.empty()) return core::Status::Ok();
  core::Result<std::unique_ptr<NatsClient>> client =
      NatsClient::Connect({.servers = SplitServers(params_.shards.servers)});
  if (!client.ok()) return client.status();
  shard_exchange_.nats = std::move(client).value();
  const std::string subject = params_.shards.subject + "." + shards.self;
  SLAMD_RETURN_IF_ERROR(shard_exchange_.nats->Subscribe(
      subject, [this, subject](std::span<const std::uint8_t> chunk) {
        const std::string channel = "nats:" + subject;
        core::Result<std::optional<std::vector<std::uint8_t>>> whole =
            shard_exchange_.summary_chunks.Add(chunk);
        if (!whole.ok()) {
          OnDecodeError(channel, whole.status());
          return;
        }
        if (!whole.value()) return;  // more chunks to come
        slamd::shard_summary_t msg;
        const core::Status decoded = internal::DecodeAs(*whole.value(), &msg);
        if (!decoded.ok()) {
          OnDecodeError(channel, decoded);
          return;
        }
        OnInbound(channel, msg);
        std::lock_guard lock(intake_mutex_);  // no PumpIntake burst to wait for
        QueueHeldLocked();
      }));
  log_->info("shard '{}': summaries on NATS {} ({})", shards.self, subject, params_.shards.servers);
  if (!params_.shards.forward_queries) return core::Status::Ok();
  for (const std::string& neighbour : shards.Neighbours()) {
    shard_exchange_.relays[neighbour] = std::make_unique<RelayBus>(
        shard_exchange_.nats.get(), params_.shards.subject + "." + neighbour + ".reply",
        channels_.prefix);
  }
  const std::string queries = subject + ".query", replies = subject + ".reply";
  SLAMD_RETURN_IF_ERROR(shard_exchange_.nats->Subscribe(
      queries, [this, queries](std::span<const std::uint8_t> payload) {
        OnForwardedQuery(queries, payload);
      }));
  SLAMD_RETURN_IF_ERROR(shard_exchange_.nats->Subscribe(
      replies, [this, replies](std::span<const std::uint8_t> payload) {
        OnRelayedReply(replies, payload);
      }));
  log_->info("shard '{}': other shards' queries forwarded to them, theirs taken on NATS {}",
             shards.self, queries);
  return core::Status::Ok();
}

void Daemon::ForwardQuery(std::string_view channel, const slamd::query_t& msg,
                          const std::string& owner) {
  const ShardMap& shards = params_.estimator.shards;
  std::vector<std::uint8_t> bytes;
  core::Status s = Encode(msg, &bytes);
  if (s.ok()) {
    s = shard_exchange_.nats->Publish(params_.shards.subject + "." + owner + ".query",
                                      Frame(shards.self, bytes));
  }
  if (s.ok()) {
    ++shard_exchange_.queries_forwarded;
    return;
  }
  RejectQuery({RejectReason::kShardUnavailable,
               "query_t: for shard '" + owner + "', which could not be reached: " + s.message()},
              channel, msg, *bus_, owner);
}

void Daemon::OnForwardedQuery(const std::string& subject, std::span<const std::uint8_t> payload) {
  const std::string channel = "nats:" + subject;
  const std::optional<Framed> framed = Unframe(payload);
  const std::vector<std::string> neighbours = params_.estimator.shards.Neighbours();
  if (!framed || std::find(neighbours.begin(), neighbours.end(), framed->tag) == neighbours.end()) {
    OnDecodeError(channel, core::InvalidArgument("a forwarded query_t from no known shard ('" +
                                                 std::string(framed ? framed->tag : "") + "')"));
    return;
  }
  slamd::query_t msg;
  const core::Status decoded = internal::DecodeAs(framed->body, &msg);
  if (!decoded.ok()) {
    OnDecodeError(channel, decoded);
    return;
  }
  OnInbound(channel, msg, std::string(framed->tag));
  std::lock_guard lock(intake_mutex_);  // no PumpIntake burst to wait for
  QueueHeldLocked();
}

void Daemon::OnRelayedReply(const std::string& subject, std::span<const std::uint8_t> payload) {
  // What an owner answers: these channels (suffixes) only, published with this bus's prefix.
  const ChannelNames suffix{.prefix = ""};
  const std::optional<Framed> framed = Unframe(payload);
  if (!framed || (framed->tag != suffix.QueryReply() && framed->tag != suffix.Map() &&
                  framed->tag != suffix.Reject())) {
    log_->warn("NATS {}: a relayed answer on no answer channel ('{}'): dropped", subject,
               framed ? framed->tag : "");
    return;
  }
  const core::Status s = bus_->Publish(channels_.prefix + std::string(framed->tag), framed->body);
  if (!s.ok()) log_->warn("cannot publish a relayed {}: {}", framed->tag, s.ToString());
}

Bus& Daemon::ReplyBus(const std::string& reply_shard) {
  if (reply_shard.empty()) return *bus_;
  const auto it = shard_exchange_.relays.find(reply_shard);
  SLAMD_CHECK(it != shard_exchange_.relays.end())
      << "a query forwarded by unknown shard '" << reply_shard << "'";
  return *it->second;
}

void Daemon::MaybeSendSummaries() {
  const ShardMap& shards = params_.estimator.shards;
  if (!shards.sharded()) return;
  const std::int64_t now = SteadyMicros();
  const std::int64_t sequence = estimator_->snapshot()->update_sequence;
  if (sequence == shard_exchange_.last_sent_sequence ||
      now - shard_exchange_.last_sent_us < params_.shards.summary_every_ms * std::int64_t{1000}) {
    return;
  }
  shard_exchange_.last_sent_us = now;
  shard_exchange_.last_sent_sequence = sequence;
  core::Result<std::optional<ShardSummaryMessage>> summary = estimator_->ShardSummary(WallMicros());
  if (!summary.ok()) {
    log_->warn("shard summary: {}", summary.status().ToString());
    return;
  }
  // Estimates are solved to the wildfire threshold: closer than that is no news.
  if (!summary->has_value() ||
      !SummaryChanged(shard_exchange_.last_sent, **summary, params_.isam2.wildfire_threshold)) {
    return;
  }
  SendSummaries(**summary);
  shard_exchange_.last_sent = std::move(**summary);
}

void Daemon::SendSummaries(const ShardSummaryMessage& summary) {
  slamd::shard_summary_t msg;
  ToLcm(summary, &msg);  // once: only to_shard differs between the copies
  std::vector<std::uint8_t> bytes;
  for (const std::string& neighbour : params_.estimator.shards.Neighbours()) {
    msg.to_shard = neighbour;
    core::Status s = Encode(msg, &bytes);
    if (s.ok() && shard_exchange_.nats) {
      // In chunks below NATS's default max_payload (1 MiB), in order on one subject.
      constexpr std::size_t kChunkBytes = 512 << 10;
      const std::string subject = params_.shards.subject + "." + neighbour;
      for (const std::vector<std::uint8_t>& chunk :
           SplitIntoChunks(params_.estimator.shards.self, ++shard_exchange_.summaries_numbered,
                           bytes, kChunkBytes)) {
        s = shard_exchange_.nats->Publish(subject, chunk);
        if (!s.ok()) break;  // the rest would be dropped by the receiver anyway
      }
    } else if (s.ok()) {
      s = bus_->Publish(channels_.Inbound<ShardSummarySpec>(), bytes);
    }
    if (!s.ok()) {
      log_->warn("shard summary for '{}' ({} variables, {} bytes): {}", neighbour,
                 summary.keys.size(), bytes.size(), s.ToString());
      continue;
    }
    ++shard_exchange_.summaries_sent;
    shard_exchange_.summary_bytes += static_cast<std::int64_t>(bytes.size());
  }
}

}  // namespace slamd::server
