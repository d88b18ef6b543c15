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
  if (merged_.num_results == 0 && reply.num_results > 0) {  // the reply that answered the keys
    merged_.results = reply.results;
    merged_.num_results = reply.num_results;
    merged_.joint_dimension = reply.joint_dimension;
    merged_.joint_covariance = reply.joint_covariance;
    merged_.num_joint_covariance = reply.num_joint_covariance;
    merged_.update_sequence = reply.update_sequence;
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
