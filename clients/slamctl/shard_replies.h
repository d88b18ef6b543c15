// The query_reply_t messages that answer one query, merged into one. A sharded slamd answers a
// fleet-wide map (map_robot "*") from every shard, each with its own reply and its own robots'
// map_t pages (query_reply_t.shard, shards_answering), and a query of keys of several shards'
// robots from each of them (each key found by its owner only); an unsharded slamd with one
// reply. The merged reply has each key's result from the reply that found it, the sum of the
// map_pages, the worst status, and every shard's error.
#pragma once

#include <cstdint>
#include <set>
#include <string>

#include "slamd/query_reply_t.hpp"

namespace slamd::clients {

class ShardReplies {
 public:
  // Replies to request_id (and from client, unless it is "").
  ShardReplies(std::int64_t request_id, std::string client)
      : request_id_(request_id), client_(std::move(client)) {}

  // Merges `reply` when it answers this query and comes from a shard not heard from yet; true
  // when merged.
  bool Add(const slamd::query_reply_t& reply);

  bool any() const { return !shards_.empty(); }
  // A reply from every shard the replies say answer.
  bool complete() const { return any() && static_cast<int>(shards_.size()) >= expected_; }
  const slamd::query_reply_t& merged() const { return merged_; }
  // What is missing, "" when complete: "query_reply_t for request 42", or "query_reply_t from
  // 1 more of 2 shards (heard: a)".
  std::string Missing() const;

 private:
  std::int64_t request_id_;
  std::string client_;
  std::set<std::string> shards_;  // heard from
  int expected_ = 1;
  slamd::query_reply_t merged_;
};

}  // namespace slamd::clients
