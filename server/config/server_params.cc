#include "server/config/server_params.h"

#include <array>
#include <string>

#include "core/factors/robust_kernel.h"

namespace slamd::server {
namespace {

// SLAMD_PARAM_CHECK names fields "Struct::path"; the config speaks in plain paths.
#define SLAMD_CONFIG_CHECK(path, op, bound)                                          \
  do {                                                                               \
    if (!(path op bound)) {                                                          \
      return core::InvalidArgument(std::string(#path " = ") + std::to_string(path) + \
                                   "; violates " #op " " #bound);                    \
    }                                                                                \
  } while (false)

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

core::Status EstimatorParams::Validate() const {
  const EstimatorParams& estimator = *this;
  if (new_robot_anchor != AnchorPolicy::kHoldUntilConnected &&
      new_robot_anchor != AnchorPolicy::kAnchorAtOrigin) {
    return core::InvalidArgument(
        "estimator.new_robot_anchor = " + std::to_string(static_cast<int>(new_robot_anchor)) +
        "; not a known policy");
  }
  SLAMD_CONFIG_CHECK(estimator.anchor_sigma, >, 0.0);
  SLAMD_CONFIG_CHECK(estimator.anchor_sigma, <=, 1e3);
  SLAMD_CONFIG_CHECK(estimator.max_held_messages, >=, 0);
  SLAMD_CONFIG_CHECK(estimator.max_hold_updates, >=, 1);
  SLAMD_CONFIG_CHECK(estimator.chi2_interval_s, >=, 0.0);
  SLAMD_CONFIG_CHECK(estimator.background_relinearization_above, >=, 0);
  SLAMD_CONFIG_CHECK(estimator.rebuild_catch_up_rounds, >=, 0);
  SLAMD_CONFIG_CHECK(estimator.rebuild_catch_up_rounds, <=, 64);
  const core::Result<core::RobustKernel::Kind> kind =
      core::RobustKernel::ParseKind(loop_closure_kernel);
  if (!kind.ok()) {
    return core::InvalidArgument("estimator.loop_closure_kernel = \"" + loop_closure_kernel +
                                 "\"; not one of none huber cauchy gemanmcclure dcs");
  }
  if (kind.value() != core::RobustKernel::Kind::kNone &&
      !core::RobustKernel::Create(kind.value(), loop_closure_kernel_parameter).ok()) {
    return core::InvalidArgument("estimator.loop_closure_kernel_parameter = " +
                                 std::to_string(loop_closure_kernel_parameter) +
                                 "; must be positive and finite");
  }
  return core::Status::Ok();
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
  SLAMD_CONFIG_CHECK(journal.sync_interval_ms, >=, 1);
  SLAMD_CONFIG_CHECK(journal.sync_interval_ms, <=, 60000);
  SLAMD_CONFIG_CHECK(journal.snapshot_every_updates, >=, 0);
  SLAMD_CONFIG_CHECK(journal.snapshot_every_s, >=, 0.0);
  SLAMD_CONFIG_CHECK(journal.snapshot_every_s, <=, 1e6);
  SLAMD_CONFIG_CHECK(journal.keep_snapshots, >=, 1);
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
