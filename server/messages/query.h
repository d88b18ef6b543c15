// query_t (msgs/lcm/query_t.lcm): a client asks for estimates, marginals and maps. Queued with the
// measurements (so it sees everything sent before it) but never journaled; the daemon answers it
// after the update of its batch.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "server/ingest/conversion.h"
#include "server/ingest/measurements.h"
#include "server/messages/message_spec.h"
#include "slamd/query_t.hpp"

namespace slamd::server {

struct QueryRequest {
  std::int64_t utime = 0;
  std::string client;
  std::int64_t request_id = 0;
  std::vector<WireKey> keys = {};
  bool want_marginals = false;
  bool want_joint_marginal = false;
  std::string map_robot = "";  // "" none, "*" all, or a robot name
  // Not on the wire: the shard that forwarded this query (shards.forward_queries), where its
  // answer goes; "" = this slamd's bus.
  std::string reply_shard = "";
};

Verdict Validate(const slamd::query_t& msg, const Limits& limits = {});
Checked<QueryRequest> Convert(const slamd::query_t& msg, const Limits& limits = {});
void ToLcm(const QueryRequest& m, slamd::query_t* out);

struct QuerySpec {
  using Lcm = slamd::query_t;
  using Value = QueryRequest;
  static constexpr const char* kType = "query_t";
  static constexpr const char* kChannel = "QUERY";
  static constexpr MessageRole kRole = MessageRole::kQuery;

  template <typename M>
  static const std::string& Robot(const M& m) {
    return m.client;
  }
  // Whose shard answers (ShardMap): the robot of its first key, else map_robot ("" and "*"
  // belong to no robot: the first shard answers).
  template <typename M>
  static const std::string& ShardRobot(const M& m) {
    return m.keys.empty() ? m.map_robot : m.keys.front().robot;
  }
  // Every shard answers a fleet-wide map (map_robot "*") with its own robots' maps.
  template <typename M>
  static bool AllShards(const M& m) {
    return m.map_robot == "*";
  }
};

}  // namespace slamd::server
