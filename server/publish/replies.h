// query_reply_t and map_t from the query service's answers (server/query). map_t is paged so
// each encoded message stays under a byte budget (UDP multicast fragments datagrams above the
// MTU and LCM refuses messages above ~64 kB on udpm): a client holds a whole map when it has pages
// 0 .. page_count-1 with the same (robot, update_sequence, request_id).
#pragma once

#include <cstdint>
#include <vector>

#include "server/query/query_service.h"
#include "slamd/map_t.hpp"
#include "slamd/query_reply_t.hpp"

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

}  // namespace slamd::server
