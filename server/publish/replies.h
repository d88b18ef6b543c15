// query_reply_t and map_t from the query service's answers (server/query). map_t is paged so
// each encoded message stays under a byte budget (UDP multicast fragments datagrams above the
// MTU and LCM refuses messages above ~64 kB on udpm): a client holds a whole map when it has pages
// 0 .. page_count-1 with the same (shard, robot, update_sequence, request_id).
#pragma once

#include <cstdint>
#include <string_view>
#include <vector>

#include "server/ingest/validation.h"
#include "server/query/query_service.h"
#include "slamd/map_t.hpp"
#include "slamd/query_reply_t.hpp"
#include "slamd/reject_t.hpp"

namespace slamd::server {

inline constexpr int kMaxMapPageBytes = 60000;

// The reply to `query` (status OK or PARTIAL; REJECTED replies come from validation).
void FillQueryReply(const QueryRequest& query, const QueryAnswer& answer,
                    std::int64_t update_sequence, std::int32_t map_pages, std::int64_t now_utime,
                    slamd::query_reply_t* out);
// A query that failed validation: STATUS_REJECTED with `error`, no results.
void FillRejectedQueryReply(const QueryRequest& query, const std::string& error,
                            std::int64_t now_utime, slamd::query_reply_t* out);

// `map` as pages whose encoded size is at most max_bytes each (at least one page, even for an
// empty map; an entry never spans pages). Poses first, then landmarks, each in index order.
std::vector<slamd::map_t> MapPages(const RobotMap& map, std::int64_t update_sequence,
                                   std::int64_t request_id, std::int64_t now_utime,
                                   int max_bytes = kMaxMapPageBytes);

// Fills *out for a rejected message: `verdict` (not ok) gives reason and detail; `channel`,
// `message_type` (e.g. "odometry_t"), `robot` and `message_utime` name the message; `now_utime`
// is the rejection time [µs].
void FillReject(const Verdict& verdict, std::string_view channel, std::string_view message_type,
                std::string_view robot, std::int64_t message_utime, std::int64_t now_utime,
                slamd::reject_t* out);

}  // namespace slamd::server
