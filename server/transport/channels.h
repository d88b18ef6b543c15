// Channel names: every channel is a configurable prefix (default "SLAMD_") plus a fixed suffix,
// so several slamd instances (or a test and a live system) can share one LCM network.
//
//   inbound:  each message type's spec names its suffix (server/messages/<type>.h kChannel):
//             ODOMETRY, LANDMARK, LOOP_CLOSURE, PRIOR, REMOVE_FACTOR, QUERY
//   outbound: ESTIMATE (estimate_t), MAP (map_t), STATUS (status_t), REJECT (reject_t),
//             QUERY_REPLY (query_reply_t)
#pragma once

#include <string>

namespace slamd::server {

struct ChannelNames {
  // Prepended to every suffix; at most 40 chars so the longest name stays within LCM's 63.
  std::string prefix = "SLAMD_";

  // The channel of an inbound message type: Inbound<OdometrySpec>() = prefix + "ODOMETRY".
  template <typename Spec>
  std::string Inbound() const {
    return prefix + Spec::kChannel;
  }
  std::string Estimate() const { return prefix + "ESTIMATE"; }
  std::string Map() const { return prefix + "MAP"; }
  std::string Status() const { return prefix + "STATUS"; }
  std::string Reject() const { return prefix + "REJECT"; }
  std::string QueryReply() const { return prefix + "QUERY_REPLY"; }
};

}  // namespace slamd::server
