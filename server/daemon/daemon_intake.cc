// Daemon: the intake side (see daemon.h): subscriptions, a message from decoding to the queue
// (validated, journaled, held for the burst), rejects, and queueing what a burst took in.
#include <spdlog/spdlog.h>

#include "server/daemon/daemon.h"
#include "server/messages/inbound.h"
#include "server/publish/replies.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/query_reply_t.hpp"
#include "slamd/reject_t.hpp"

namespace slamd::server {

template <typename Msg>
core::Status Daemon::SubscribeInbound(const std::string& channel) {
  core::Result<Subscription> sub = server::Subscribe<Msg>(
      *bus_, channel, [this](std::string_view ch, const Msg& msg) { OnInbound(ch, msg); },
      [this](std::string_view ch, const core::Status& error) { OnDecodeError(ch, error); });
  if (!sub.ok()) return sub.status();
  subscriptions_.push_back(std::move(sub).value());
  return core::Status::Ok();
}

core::Status Daemon::Subscribe() {
  core::Status status;
  InboundSpecs::ForEach([&](auto spec) {
    using Spec = typename decltype(spec)::type;
    if (status.ok()) status = SubscribeInbound<typename Spec::Lcm>(channels_.Inbound<Spec>());
  });
  return status;
}

template <typename Msg>
void Daemon::OnInbound(std::string_view channel, const Msg& msg, const std::string& reply_shard) {
  using Spec = SpecOfLcm<Msg>;
  ++received_;
  const ShardMap& shards = params_.estimator.shards;
  // Forwarded once, by the leader of a pair (a standby does not answer).
  const bool forwards = params_.shards.forward_queries && reply_shard.empty() && !standby_;
  if constexpr (Spec::kRole == MessageRole::kQuery) {
    if (forwards) {  // to the other shards that answer it
      for (const std::string& shard : QuerySpec::AnsweringShards(shards, msg)) {
        if (shard != shards.self) ForwardQuery(channel, msg, shard);
      }
    }
  }
  if (!ForThisShard<Spec>(shards, msg)) {  // another shard's robot
    if (Spec::kRole != MessageRole::kQuery || !forwards) ++shard_exchange_.not_owned;
    return;
  }
  const char* type = Spec::kType;
  auto checked = Convert(msg, Limits{});
  Verdict verdict;
  if (!checked.ok()) {
    verdict = checked.verdict();
  } else {
    const Verdict full{RejectReason::kQueueFull, std::string(type) +
                                                     ": ingest queue full (queue.depth = " +
                                                     std::to_string(params_.queue.depth) + ")"};
    auto value = std::move(checked).value();
    if constexpr (Spec::kRole == MessageRole::kQuery) value.reply_shard = reply_shard;
    Inbound in{std::move(value), SteadyMicros()};
    constexpr bool kJournaled = Spec::kRole != MessageRole::kQuery;
    if (standby_) {  // the leader answers; kept in case this slamd takes over
      // A query is the leader's, unless this slamd is taking over: then it is answered after
      // what was heard before it.
      if (!kJournaled && !taking_over_) return;
      std::vector<std::uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
      msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
      if (Hear(channel, type, std::move(bytes))) return;
      // It took over meanwhile: this message goes the leader's way.
    }
    if (kJournaled && !WaitForReplication(params_.queue.block_timeout_s)) {
      // A deposed leader says nothing: the new one, which heard the message too, answers it.
      if (deposed_) return;
      PublishReject({RejectReason::kReplicationUnavailable,
                     std::string(type) + ": the replicated journal (NATS stream " +
                         params_.replication.stream + ") has not acknowledged: intake held"},
                    channel, type, Spec::Robot(msg), msg.utime);
      return;
    }
    // Held until the end of this PumpIntake, so that a burst it takes in (see PumpIntake) is
    // queued together and makes one update.
    std::lock_guard lock(intake_mutex_);
    const int held = static_cast<int>(intake_held_.size());
    if (held > 0 && !queue_.WaitForRoom(0.0, held + 1)) QueueHeldLocked();
    if (!queue_.WaitForRoom(params_.queue.block_timeout_s,
                            static_cast<int>(intake_held_.size()) + 1)) {
      verdict = full;
    } else if (!journal_ || !kJournaled) {
      intake_held_.push_back(std::move(in));
      return;
    } else {
      std::vector<std::uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
      msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
      const core::Result<std::int64_t> seq =
          journal_->AppendMessage(channel, type, bytes, WallMicros());
      if (seq.ok()) {
        in.journal_sequence = seq.value();
        intake_held_.push_back(std::move(in));
        return;
      }
      NoteJournalError(seq.status());
      verdict = {RejectReason::kStorageError,
                 std::string(type) + ": the journal could not take it: " + seq.status().message()};
    }
  }
  if constexpr (Spec::kRole == MessageRole::kQuery) {
    RejectQuery(verdict, channel, msg, ReplyBus(reply_shard));
  } else {
    PublishReject(verdict, channel, type, Spec::Robot(msg), msg.utime);
  }
}

void Daemon::RejectQuery(const Verdict& verdict, std::string_view channel,
                         const slamd::query_t& msg, Bus& out, const std::string& shard) {
  PublishReject(verdict, channel, QuerySpec::kType, msg.client, msg.utime, &out);
  // The asker waits for a reply, not for a reject_t.
  slamd::query_reply_t reply;
  FillRejectedQueryReply(QueryRequest{.client = msg.client, .request_id = msg.request_id},
                         verdict.message, WallMicros(), &reply);
  const ShardMap& shards = params_.estimator.shards;
  SignReply(QuerySpec::AnsweringShards(shards, msg), shard.empty() ? shards.self : shard, &reply);
  const core::Status s = server::Publish(out, channels_.QueryReply(), reply);
  if (!s.ok()) log_->warn("cannot publish query_reply_t: {}", s.ToString());
}

void Daemon::OnDecodeError(std::string_view channel, const core::Status& error) {
  ++received_;
  ++decode_errors_;
  PublishReject({RejectReason::kDecodeError, error.message()}, channel, "", "", 0);
}

void Daemon::PublishReject(const Verdict& verdict, std::string_view channel, std::string_view type,
                           std::string_view robot, std::int64_t utime, Bus* out) {
  ++intake_rejected_;
  ++intake_rejects_by_reason_[static_cast<int>(verdict.reason)];
  slamd::reject_t msg;
  FillReject(verdict, channel, type, robot, utime, WallMicros(), &msg);
  NoteReject(type, verdict);
  const core::Status s = server::Publish(out ? *out : *bus_, channels_.Reject(), msg);
  if (!s.ok()) log_->warn("cannot publish reject_t: {}", s.ToString());
}

core::Result<int> Daemon::PumpIntake(int timeout_ms) {
  core::Result<int> r = bus_->HandleOnce(timeout_ms);
  // Under journal.sync ALWAYS, the rest of a burst that has arrived meanwhile (without waiting),
  // then all of it at once: each update costs an fdatasync before its estimate goes out, so a
  // pose's odometry and loop closures are cheaper in one update than in two (at 1 kHz,
  // ingest-to-publish p99 lower in 18 of 26 interleaved manhattan runs and 4 of 4 on
  // victoriaPark). Without that cost the smaller updates publish sooner (manhattan: p99 higher
  // in 8 of 8 when coalesced). Measured as the server publish p99 of interleaved pairs of
  // `SLAMD_BENCH_RATES=1000 [SLAMD_BENCH_SYNC=NEVER] scripts/bench-server`.
  constexpr int kMaxBurst = 16;
  const bool coalesce = journal_ && params_.journal.sync == SyncPolicy::kAlways;
  int dispatched = r.ok() ? r.value() : 0;
  while (coalesce && r.ok() && r.value() > 0 && dispatched < kMaxBurst) {
    r = bus_->HandleOnce(0);
    if (r.ok()) dispatched += r.value();
  }
  {
    std::lock_guard lock(intake_mutex_);
    QueueHeldLocked();
  }
  if (!r.ok()) return r.status();
  return dispatched;
}

void Daemon::QueueHeldLocked() {
  for (Inbound& in : intake_held_) {
    const std::int64_t sequence = in.journal_sequence;
    // Room for every held message was there when it was taken in (one producer), and Stop
    // closes the queue only after the intake has stopped and queued what it held.
    if (!queue_.Push(std::move(in), 0.0)) {
      SLAMD_CHECK(sequence > 0) << "an unjournaled message was held until the queue closed";
      log_->error("message {} journaled but the queue closed: it is replayed at restart", sequence);
    }
    ++queued_;
  }
  intake_held_.clear();
}

// Taken in from NATS by daemon_shards.cc as well as from the bus.
template void Daemon::OnInbound(std::string_view, const slamd::shard_summary_t&,
                                const std::string&);
template void Daemon::OnInbound(std::string_view, const slamd::query_t&, const std::string&);

}  // namespace slamd::server
