#include "server/messages/query.h"

#include "server/ingest/field_checks.h"
#include "slamd/key_t.hpp"
#include "slamd/query_t.hpp"

namespace slamd::server {
namespace {

using K = ::slamd::key_t;
static_assert(static_cast<int>(KeyKind::kPose) == K::KIND_POSE);
static_assert(static_cast<int>(KeyKind::kLandmark) == K::KIND_LANDMARK);
static_assert(static_cast<int>(KeyKind::kMapLandmark) == K::KIND_MAP_LANDMARK);

using internal::CheckCount;
using internal::CheckIndex;
using internal::CheckKindRange;
using internal::CheckName;
using internal::CheckUtime;
using internal::Reject;

}  // namespace

Verdict Validate(const slamd::query_t& msg, const Limits& limits) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("query_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("query_t.client", msg.client, limits.max_client_name_length, true));
  SLAMD_RETURN_IF_REJECTED(CheckCount("query_t.num_keys", msg.num_keys, msg.keys.size(), -1, ""));
  if (msg.num_keys > limits.max_query_keys) {
    return Reject(RejectReason::kTooManyElements, "query_t.keys",
                  std::to_string(msg.num_keys) + " keys, more than the limit of " +
                      std::to_string(limits.max_query_keys));
  }
  for (size_t i = 0; i < msg.keys.size(); ++i) {
    const slamd::key_t& key = msg.keys[i];
    const std::string field = "query_t.keys[" + std::to_string(i) + "]";
    SLAMD_RETURN_IF_REJECTED(CheckKindRange(
        (field + ".kind").c_str(), key.kind, slamd::key_t::KIND_POSE,
        slamd::key_t::KIND_MAP_LANDMARK, "1 (pose), 2 (landmark), 3 (map landmark)"));
    if (key.kind == slamd::key_t::KIND_MAP_LANDMARK) {
      if (!key.robot.empty()) {
        return Reject(RejectReason::kUnusedFieldSet, field + ".robot",
                      "'" + key.robot + "' for a map landmark, which belongs to no robot (\"\")");
      }
    } else {
      SLAMD_RETURN_IF_REJECTED(
          CheckName(field + ".robot", key.robot, limits.max_robot_name_length));
    }
    SLAMD_RETURN_IF_REJECTED(CheckIndex(field + ".index", key.index));
  }
  if (msg.want_joint_marginal && msg.num_keys > limits.max_joint_marginal_keys) {
    return Reject(RejectReason::kTooManyElements, "query_t.keys",
                  std::to_string(msg.num_keys) +
                      " keys for a joint marginal, more than the limit of " +
                      std::to_string(limits.max_joint_marginal_keys));
  }
  if (msg.map_robot != "*") {
    SLAMD_RETURN_IF_REJECTED(
        CheckName("query_t.map_robot", msg.map_robot, limits.max_robot_name_length, true));
  }
  return {};
}

Checked<QueryRequest> Convert(const slamd::query_t& msg, const Limits& limits) {
  Verdict verdict = Validate(msg, limits);
  if (!verdict.ok()) return verdict;
  QueryRequest query{.utime = msg.utime,
                     .client = msg.client,
                     .request_id = msg.request_id,
                     .keys = {},
                     .want_marginals = msg.want_marginals != 0,
                     .want_joint_marginal = msg.want_joint_marginal != 0,
                     .map_robot = msg.map_robot};
  query.keys.reserve(msg.keys.size());
  for (const slamd::key_t& key : msg.keys) {
    query.keys.push_back(WireKey{.robot = key.robot,
                                 .kind = static_cast<KeyKind>(key.kind),
                                 .index = static_cast<std::uint64_t>(key.index)});
  }
  return query;
}

void ToLcm(const QueryRequest& m, slamd::query_t* out) {
  out->utime = m.utime;
  out->client = m.client;
  out->request_id = m.request_id;
  out->keys.clear();
  for (const WireKey& key : m.keys) {
    slamd::key_t k;
    k.robot = key.robot;
    k.kind = static_cast<std::int8_t>(key.kind);
    k.index = static_cast<std::int64_t>(key.index);
    out->keys.push_back(std::move(k));
  }
  out->num_keys = static_cast<std::int32_t>(out->keys.size());
  out->want_marginals = m.want_marginals;
  out->want_joint_marginal = m.want_joint_marginal;
  out->map_robot = m.map_robot;
}

}  // namespace slamd::server
