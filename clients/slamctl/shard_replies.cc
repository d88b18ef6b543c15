#include "clients/slamctl/shard_replies.h"

#include <algorithm>

namespace slamd::clients {

bool ShardReplies::Add(const slamd::query_reply_t& reply) {
  if (reply.request_id != request_id_ || (!client_.empty() && reply.client != client_)) {
    return false;
  }
  if (!shards_.insert(reply.shard).second) return false;
  expected_ = std::max(expected_, reply.shards_answering);
  if (shards_.size() == 1) {
    merged_ = reply;
    if (!reply.shard.empty() && !reply.error.empty()) {
      merged_.error = "shard " + reply.shard + ": " + reply.error;
    }
    return true;
  }
  // Each key from the shard that found it (its owner; the others answer it not found).
  if (reply.results.size() == merged_.results.size()) {
    for (std::size_t i = 0; i < reply.results.size(); ++i) {
      if (!merged_.results[i].found && reply.results[i].found)
        merged_.results[i] = reply.results[i];
    }
  }
  merged_.map_pages += reply.map_pages;
  merged_.status = std::max(merged_.status, reply.status);  // OK < PARTIAL < REJECTED
  if (!reply.error.empty()) {
    merged_.error +=
        (merged_.error.empty() ? "" : "; ") + ("shard " + reply.shard + ": ") + reply.error;
  }
  return true;
}

std::string ShardReplies::Missing() const {
  if (!any()) return "query_reply_t for request " + std::to_string(request_id_);
  if (complete()) return "";
  std::string heard;
  for (const std::string& s : shards_) heard += (heard.empty() ? "" : ", ") + s;
  return "query_reply_t from " + std::to_string(expected_ - static_cast<int>(shards_.size())) +
         " more of " + std::to_string(expected_) + " shards (heard: " + heard + ")";
}

}  // namespace slamd::clients
