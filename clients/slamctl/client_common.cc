// Shared pieces of the slamctl subcommands (see client_common.h).
#include "clients/slamctl/client_common.h"

#include <unistd.h>

#include <cstdio>

#include "server/ingest/reject_reason.h"

namespace slamd::clients {

void AddConnectionOptions(CLI::App* cmd, ConnectionOptions* options) {
  cmd->add_option("--lcm-url", options->lcm_url,
                  "LCM URL of slamd's bus (default: $LCM_DEFAULT_URL, else "
                  "udpm://239.255.76.67:7667?ttl=0)");
  cmd->add_option("--channel-prefix", options->channel_prefix,
                  "prefix of slamd's channel names (slamd's channel_prefix)")
      ->capture_default_str();
}

void CommandFail(const std::string& command, int code, const std::string& message) {
  std::fprintf(stderr, "slamctl %s: %s\n", command.c_str(), message.c_str());
  std::fflush(stderr);
  throw CommandExit{code};
}

core::Status CheckChannelPrefix(const std::string& prefix) {
  if (prefix.empty() || prefix.size() > 40) {
    return core::InvalidArgument("--channel-prefix '" + prefix + "': needs 1..40 characters");
  }
  for (const char c : prefix) {
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) {
      return core::InvalidArgument("--channel-prefix '" + prefix +
                                   "': only [A-Za-z0-9_] are allowed");
    }
  }
  return core::Status::Ok();
}

std::unique_ptr<LcmClient> ConnectOrFail(const std::string& command,
                                         const ConnectionOptions& options,
                                         server::ChannelNames* channels) {
  if (const core::Status ok = CheckChannelPrefix(options.channel_prefix); !ok.ok()) {
    CommandFail(command, kExitUsage, ok.message());
  }
  channels->prefix = options.channel_prefix;
  core::Result<std::unique_ptr<LcmClient>> client = LcmClient::Create(options.lcm_url);
  if (!client.ok()) CommandFail(command, kExitFailure, client.status().message());
  return std::move(client).value();
}

std::string FormatStatus(const slamd::status_t& s) {
  char buf[1024];
  std::string out;
  std::snprintf(
      buf, sizeof(buf),
      "update %lld  robots %d  variables %lld  factors %lld  %s  rebuilds %lld\n"
      "messages: received %lld  accepted %lld  rejected %lld  decode errors %lld\n"
      "queue %d / %d (peak %d)  update latency p50 %.2f ms  p90 %.2f ms  p99 %.2f ms  max %.2f ms\n"
      "publish latency p50 %.2f ms  p99 %.2f ms  journal %lld records, %lld bytes "
      "(%lld on disk in %d segments)\n"
      "chi2 %.6g  residual dimension %lld  (chi2/dim %.4g)\n",
      static_cast<long long>(s.update_sequence), s.num_robots,
      static_cast<long long>(s.num_variables), static_cast<long long>(s.num_factors),
      s.settled ? "settled" : "refining", static_cast<long long>(s.rebuilds),
      static_cast<long long>(s.messages_received), static_cast<long long>(s.messages_accepted),
      static_cast<long long>(s.messages_rejected), static_cast<long long>(s.decode_errors),
      s.queue_depth, s.queue_capacity, s.queue_peak, s.update_latency_p50_us / 1e3,
      s.update_latency_p90_us / 1e3, s.update_latency_p99_us / 1e3, s.update_latency_max_us / 1e3,
      s.publish_latency_p50_us / 1e3, s.publish_latency_p99_us / 1e3,
      static_cast<long long>(s.journal_records), static_cast<long long>(s.journal_bytes),
      static_cast<long long>(s.journal_disk_bytes), s.journal_segments, s.chi2,
      static_cast<long long>(s.residual_dimension),
      s.residual_dimension > 0 ? s.chi2 / static_cast<double>(s.residual_dimension) : 0.0);
  out = buf;
  if (s.replicated_batches > 0 || s.replication_holds > 0) {
    std::snprintf(buf, sizeof(buf),
                  "replication: %s  %lld batches acknowledged  %lld bytes pending  held %lld "
                  "times\n",
                  s.replication_held ? "HELD (the stream does not acknowledge)" : "ok",
                  static_cast<long long>(s.replicated_batches),
                  static_cast<long long>(s.replication_pending_bytes),
                  static_cast<long long>(s.replication_holds));
    out += buf;
  }
  if (s.shard_summaries_sent > 0 || s.shard_not_owned > 0 || s.shard_queries_forwarded > 0 ||
      s.shard_summaries_incomplete > 0) {
    std::snprintf(buf, sizeof(buf),
                  "shards: %lld summaries sent (%lld bytes)  %lld received incomplete  %lld "
                  "messages for other shards  %lld queries forwarded\n",
                  static_cast<long long>(s.shard_summaries_sent),
                  static_cast<long long>(s.shard_summary_bytes),
                  static_cast<long long>(s.shard_summaries_incomplete),
                  static_cast<long long>(s.shard_not_owned),
                  static_cast<long long>(s.shard_queries_forwarded));
    out += buf;
  }
  for (int code = 0;
       code < s.num_rejects_by_reason && code < static_cast<int>(s.rejects_by_reason.size());
       ++code) {
    if (s.rejects_by_reason[code] == 0) continue;
    std::snprintf(buf, sizeof(buf), "  rejected %s: %lld\n",
                  server::RejectReasonName(static_cast<server::RejectReason>(code)),
                  static_cast<long long>(s.rejects_by_reason[code]));
    out += buf;
  }
  return out;
}

JsonWriter StatusJson(const slamd::status_t& s) {
  JsonWriter reasons;
  for (int code = 0;
       code < s.num_rejects_by_reason && code < static_cast<int>(s.rejects_by_reason.size());
       ++code) {
    if (s.rejects_by_reason[code] == 0) continue;
    reasons.Add(server::RejectReasonName(static_cast<server::RejectReason>(code)),
                static_cast<long long>(s.rejects_by_reason[code]));
  }
  JsonWriter j;
  j.Add("utime", static_cast<long long>(s.utime))
      .Add("update_sequence", static_cast<long long>(s.update_sequence))
      .Add("rebuilds", static_cast<long long>(s.rebuilds))
      .Add("num_robots", s.num_robots)
      .Add("num_variables", static_cast<long long>(s.num_variables))
      .Add("num_factors", static_cast<long long>(s.num_factors))
      .Add("messages_received", static_cast<long long>(s.messages_received))
      .Add("messages_accepted", static_cast<long long>(s.messages_accepted))
      .Add("messages_rejected", static_cast<long long>(s.messages_rejected))
      .Add("decode_errors", static_cast<long long>(s.decode_errors))
      .Add("rejects_by_reason", reasons)
      .Add("queue_depth", s.queue_depth)
      .Add("queue_capacity", s.queue_capacity)
      .Add("queue_peak", s.queue_peak)
      .Add("update_latency_p50_us", static_cast<long long>(s.update_latency_p50_us))
      .Add("update_latency_p90_us", static_cast<long long>(s.update_latency_p90_us))
      .Add("update_latency_p99_us", static_cast<long long>(s.update_latency_p99_us))
      .Add("update_latency_max_us", static_cast<long long>(s.update_latency_max_us))
      .Add("publish_latency_p50_us", static_cast<long long>(s.publish_latency_p50_us))
      .Add("publish_latency_p99_us", static_cast<long long>(s.publish_latency_p99_us))
      .Add("journal_records", static_cast<long long>(s.journal_records))
      .Add("journal_bytes", static_cast<long long>(s.journal_bytes))
      .Add("journal_disk_bytes", static_cast<long long>(s.journal_disk_bytes))
      .Add("journal_segments", s.journal_segments)
      .Add("replication_held", static_cast<bool>(s.replication_held))
      .Add("replication_holds", static_cast<long long>(s.replication_holds))
      .Add("replicated_batches", static_cast<long long>(s.replicated_batches))
      .Add("replication_pending_bytes", static_cast<long long>(s.replication_pending_bytes))
      .Add("shard_not_owned", static_cast<long long>(s.shard_not_owned))
      .Add("shard_summaries_sent", static_cast<long long>(s.shard_summaries_sent))
      .Add("shard_summary_bytes", static_cast<long long>(s.shard_summary_bytes))
      .Add("shard_queries_forwarded", static_cast<long long>(s.shard_queries_forwarded))
      .Add("shard_summaries_incomplete", static_cast<long long>(s.shard_summaries_incomplete))
      .Add("removed_variables", static_cast<long long>(s.removed_variables))
      .Add("merged_poses", static_cast<long long>(s.merged_poses))
      .Add("reduced_left_out", static_cast<long long>(s.reduced_left_out))
      .Add("rss_bytes", static_cast<long long>(s.rss_bytes))
      .Add("heap_in_use_bytes", static_cast<long long>(s.heap_in_use_bytes))
      .Add("chi2", s.chi2)
      .Add("residual_dimension", static_cast<long long>(s.residual_dimension))
      .Add("settled", static_cast<bool>(s.settled));
  return j;
}

bool ParseSize(const std::string& text, int* width, int* height) {
  int consumed = 0;
  return std::sscanf(text.c_str(), "%dx%d%n", width, height, &consumed) == 2 &&
         consumed == static_cast<int>(text.size());
}

bool StderrIsTty() { return ::isatty(STDERR_FILENO) == 1; }
bool StdoutIsTty() { return ::isatty(STDOUT_FILENO) == 1; }

}  // namespace slamd::clients
