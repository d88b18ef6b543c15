// The query side of slamctl: key parsing, one query_t -> query_reply_t (+ map_t pages) round
// trip over an LcmClient, and printing the answer. Works over any Bus, so it is tested against a
// fake server on InProcessBus.
//
// Keys are written ROBOT:xN (pose N) or ROBOT:lN (landmark N); with a default robot (--robot),
// plain xN / lN; mN is landmark N of the map all robots share. The robot name follows slamd's
// rule (1..64 chars of [A-Za-z0-9_.-]).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "clients/slamctl/lcm_client.h"
#include "core/base/status.h"
#include "server/messages/inbound.h"
#include "server/transport/channels.h"
#include "slamd/map_t.hpp"
#include "slamd/query_reply_t.hpp"
#include "slamd/query_t.hpp"

namespace slamd::clients {

// InvalidArgument naming the key and the expected form.
core::Result<server::WireKey> ParseKey(const std::string& text, const std::string& default_robot);
// "robot:x12", "robot:l3", or "m7" (a landmark of the shared map).
std::string WireKeyToString(const std::string& robot, std::int8_t kind, std::int64_t index);

struct QueryAnswer {
  slamd::query_reply_t reply;
  // map_t pages with the query's request_id, in arrival order (all robots asked for); complete
  // when their number equals reply.map_pages.
  std::vector<slamd::map_t> map_pages;
};

// Publishes `query` on the query channel and handles messages until the query_reply_t with the
// same request_id and client arrives (from every shard answering: shard_replies.h; `reply` is
// the merged one), then until its map_pages map_t pages arrived (all within timeout_s).
// OutOfRange("timed out ...") when the reply (or a page) does not come in time. Subscribes `client`
// to QUERY_REPLY and MAP for good (the client is meant for one query).
core::Result<QueryAnswer> RunQuery(LcmClient& client, const server::ChannelNames& channels,
                                   const slamd::query_t& query, double timeout_s);

// A random positive request id (std::random_device).
std::int64_t RandomRequestId();

// Human-readable answer: one line per key (values; covariance rows when present), the joint
// covariance, and the map pages (one line per pose / landmark).
std::string FormatAnswer(const QueryAnswer& answer);
// The answer as one JSON object: request_id, update_sequence, status ("ok" | "partial" |
// "rejected"), error, results [{key, found, values, covariance}], joint_covariance
// {dimension, values}, map [{robot, shard, page, poses [{index, values, covariance}],
// landmarks}].
std::string AnswerJson(const QueryAnswer& answer);

}  // namespace slamd::clients
