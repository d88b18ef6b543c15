#include "server/config/server_params.h"

#include <array>
#include <string>

#include "core/factors/robust_kernel.h"
#include "server/replication/nats_client.h"

namespace slamd::server {
namespace {

core::Status CheckPrefix(const std::string& prefix) {
  if (prefix.empty() || prefix.size() > 40) {
    return core::InvalidArgument("channel_prefix = \"" + prefix + "\"; needs 1..40 characters");
  }
  for (char c : prefix) {
    const bool ok =
        (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
    if (!ok) {
      return core::InvalidArgument("channel_prefix = \"" + prefix +
                                   "\"; only [A-Za-z0-9_] allowed");
    }
  }
  return core::Status::Ok();
}

}  // namespace

int LogLevelNumber(const std::string& name) {
  static constexpr std::array<const char*, 7> kNames = {"trace", "debug",    "info", "warn",
                                                        "error", "critical", "off"};
  for (int i = 0; i < static_cast<int>(kNames.size()); ++i) {
    if (name == kNames[i]) return i;
  }
  return -1;
}

core::Status ServerParams::Validate() const {
  if (lcm_url.empty()) return core::InvalidArgument("lcm_url = \"\"; must not be empty");
  SLAMD_RETURN_IF_ERROR(CheckPrefix(channel_prefix));
  if (LogLevelNumber(log_level) < 0) {
    return core::InvalidArgument("log_level = \"" + log_level +
                                 "\"; not one of trace debug info warn error critical off");
  }
  SLAMD_CONFIG_CHECK(queue.depth, >=, 1);
  SLAMD_CONFIG_CHECK(queue.depth, <=, 10000000);
  SLAMD_CONFIG_CHECK(queue.block_timeout_s, >=, 0.0);
  SLAMD_CONFIG_CHECK(queue.block_timeout_s, <=, 10.0);
  SLAMD_CONFIG_CHECK(queue.coalesce_s, >=, 0.0);
  SLAMD_CONFIG_CHECK(queue.coalesce_s, <=, 0.01);
  SLAMD_CONFIG_CHECK(queue.max_per_update, >=, 1);
  SLAMD_CONFIG_CHECK(queue.max_per_update, <=, 10000000);
  SLAMD_CONFIG_CHECK(publish.status_rate_hz, >=, 0.0);
  SLAMD_CONFIG_CHECK(publish.status_rate_hz, <=, 1000.0);
  SLAMD_CONFIG_CHECK(publish.map_rate_hz, >=, 0.0);
  SLAMD_CONFIG_CHECK(publish.map_rate_hz, <=, 100.0);
  SLAMD_CONFIG_CHECK(publish.query_budget_s, >, 0.0);
  SLAMD_CONFIG_CHECK(publish.query_budget_s, <=, 10.0);
  SLAMD_CONFIG_CHECK(publish.latency_window, >=, 16);
  SLAMD_CONFIG_CHECK(publish.latency_window, <=, 1048576);
  SLAMD_CONFIG_CHECK(refine.budget_s, >, 0.0);
  SLAMD_CONFIG_CHECK(refine.budget_s, <=, 10.0);
  SLAMD_CONFIG_CHECK(refine.idle_s, >=, 0.0);
  SLAMD_CONFIG_CHECK(refine.idle_s, <=, 10.0);
  SLAMD_CONFIG_CHECK(replication.replicas, >=, 1);
  SLAMD_CONFIG_CHECK(replication.replicas, <=, 5);
  SLAMD_CONFIG_CHECK(replication.ack_timeout_ms, >=, 1);
  SLAMD_CONFIG_CHECK(replication.ack_timeout_ms, <=, 60000);
  if (replication.lease_ttl_ms != 0) {
    SLAMD_CONFIG_CHECK(replication.lease_ttl_ms, >=, 100);
    SLAMD_CONFIG_CHECK(replication.lease_ttl_ms, <=, 60000);
  }
  SLAMD_CONFIG_CHECK(replication.standby_keep_s, >=, 0.1);
  SLAMD_CONFIG_CHECK(replication.standby_keep_s, <=, 600.0);
  SLAMD_CONFIG_CHECK(replication.keep_snapshots, >=, 0);
  SLAMD_CONFIG_CHECK(replication.keep_snapshots, <=, 100);
  if (!IsNatsSubject(shards.subject)) {
    return core::InvalidArgument("shards.subject = \"" + shards.subject +
                                 "\"; violates: [A-Za-z0-9_-]+ tokens joined by dots");
  }
  SLAMD_CONFIG_CHECK(shards.summary_every_ms, >=, 10);
  SLAMD_CONFIG_CHECK(shards.summary_every_ms, <=, 600000);
  if (shards.forward_queries && shards.servers.empty()) {
    return core::InvalidArgument(
        "shards.forward_queries = true needs shards.servers: queries are forwarded over NATS");
  }
  SLAMD_CONFIG_CHECK(journal.sync_interval_ms, >=, 1);
  SLAMD_CONFIG_CHECK(journal.sync_interval_ms, <=, 60000);
  SLAMD_CONFIG_CHECK(journal.snapshot_every_updates, >=, 0);
  SLAMD_CONFIG_CHECK(journal.snapshot_every_s, >=, 0.0);
  SLAMD_CONFIG_CHECK(journal.snapshot_every_s, <=, 1e6);
  SLAMD_CONFIG_CHECK(journal.snapshot_every_bytes, >=, 0);
  SLAMD_CONFIG_CHECK(journal.keep_snapshots, >=, 1);
  SLAMD_CONFIG_CHECK(journal.segment_bytes, >=, 4096);
  const core::Status isam2_ok = isam2.Validate();
  if (!isam2_ok.ok()) {
    // "Isam2Params::relinearization.skip = 0; ..." -> "isam2.relinearization.skip = 0; ..."
    std::string message = isam2_ok.message();
    const std::string prefix = "Isam2Params::";
    if (message.rfind(prefix, 0) == 0) message = "isam2." + message.substr(prefix.size());
    return core::InvalidArgument(message);
  }
  return estimator.Validate();
}

}  // namespace slamd::server
