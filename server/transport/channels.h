// Channel names: every channel is a configurable prefix (default "SLAMD_") plus a fixed suffix,
// so several slamd instances (or a test and a live system) can share one LCM network.
//
//   inbound:  ODOMETRY (odometry_t), LANDMARK (landmark_observation_t), LOOP_CLOSURE
//             (loop_closure_t), PRIOR (prior_t), REMOVE_FACTOR (remove_factor_t), QUERY (query_t)
//   outbound: ESTIMATE (estimate_t), MAP (map_t), STATUS (status_t), REJECT (reject_t),
//             QUERY_REPLY (query_reply_t)
#pragma once

#include <string>

namespace slamd::server {

struct ChannelNames {
  // Prepended to every suffix; at most 40 chars so the longest name stays within LCM's 63.
  std::string prefix = "SLAMD_";

  std::string Odometry() const { return prefix + "ODOMETRY"; }
  std::string Landmark() const { return prefix + "LANDMARK"; }
  std::string LoopClosure() const { return prefix + "LOOP_CLOSURE"; }
  std::string Prior() const { return prefix + "PRIOR"; }
  std::string RemoveFactor() const { return prefix + "REMOVE_FACTOR"; }
  std::string Query() const { return prefix + "QUERY"; }
  std::string Estimate() const { return prefix + "ESTIMATE"; }
  std::string Map() const { return prefix + "MAP"; }
  std::string Status() const { return prefix + "STATUS"; }
  std::string Reject() const { return prefix + "REJECT"; }
  std::string QueryReply() const { return prefix + "QUERY_REPLY"; }
};

}  // namespace slamd::server
