// query_t (msgs/lcm/query_t.lcm): a client asks for estimates, marginals and maps. Queued with the
// measurements (so it sees everything sent before it) but never journaled; the daemon answers it
// after the update of its batch.
#pragma once

#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include "server/ingest/conversion.h"
#include "server/ingest/measurements.h"
#include "server/ingest/shard_map.h"
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
  // The shards that answer it ({} when not sharded), each for its own robots: every shard for
  // a fleet-wide map (map_robot "*"); else the owners of its keys' robots and of map_robot (a
  // key of the shared map, robot "", and a query naming no robot go to the first shard).
  template <typename M>
  static std::set<std::string> AnsweringShards(const ShardMap& shards, const M& m) {
    std::set<std::string> out;
    if (!shards.sharded()) return out;
    if (m.map_robot == "*") {
      for (const ShardMap::Shard& s : shards.shards) out.insert(s.name);
      return out;
    }
    for (const auto& key : m.keys) out.insert(shards.OwnerOf(key.robot));
    if (!m.map_robot.empty() || out.empty()) out.insert(shards.OwnerOf(m.map_robot));
    return out;
  }
};

}  // namespace slamd::server
