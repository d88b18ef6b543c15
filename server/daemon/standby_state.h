// StandbyState: what the standby of a replicated pair keeps while it follows the stream
// (daemon_replication.cc): the followed stream and its replay (estimator thread), where it
// started, what intake heard from the robots (heard_mutex), and what the stream brought, so that
// a takeover journals only what the stream lacks.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "server/estimator/journal_replay.h"
#include "server/replication/stream_reader.h"
#include "server/snapshot/state_codec.h"

namespace slamd::server {

struct StandbyState {
  std::unique_ptr<StreamReader> reader;
  std::unique_ptr<JournalReplay> replay;
  // Started from a snapshot in NATS: its local position (the data directory's snapshot, whose
  // last_message_sequence is the last message it includes), and how many of the followed
  // records other than messages it still includes (FollowPoint::skip).
  std::optional<JournalPosition> start;
  std::int64_t skip = 0;

  struct Heard {
    std::string channel, type;
    std::vector<std::uint8_t> bytes;
    std::int64_t steady_us = 0;
  };
  std::mutex heard_mutex;
  std::deque<Heard> heard;
  std::int64_t hearing_since_us = 0;  // subscribed to the robots' channels [µs, steady clock]
  // The messages the followed stream brought (channel, NUL, LCM bytes) for as long as heard ones
  // are kept.
  std::unordered_multiset<std::string> streamed;
  std::deque<std::pair<std::int64_t, std::string>> streamed_order;  // (steady µs, key)
};

}  // namespace slamd::server
