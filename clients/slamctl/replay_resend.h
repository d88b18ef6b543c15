// ReplayResender: what `slamctl replay` sends again. A message slamd refuses with
// REASON_QUEUE_FULL (its ingest queue stayed full: nothing changed) is taken if sent later, and
// left unsent it would be lost: refused odometry leaves a gap that the robot's later poses wait
// for, then are rejected over (out_of_order_timeout, unknown_pose). So a refused message goes
// again after a back-off that doubles with each refusal of it (first_delay_s .. max_delay_s),
// for as long as the server keeps refusing it (each refusal says the server is there, busy: an
// update of a whole backlog can take seconds) up to give_up_after_s from its first refusal;
// after that its refusal stands.
//
// A reject_t names its message by channel, robot and utime. Several messages of one step can
// share the three (a step's loop closures): all of those go again, and the server answers the
// ones it had already taken as already held, without applying them twice. Only messages sent in
// the last remember_s seconds are matched (the server refuses at once, not minutes later), so
// the bookkeeping stays small on a long replay.
// Not thread-safe (slamctl is single-threaded).
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "clients/slamctl/replay_sources.h"
#include "slamd/reject_t.hpp"

namespace slamd::clients {

struct ResendParams {
  double give_up_after_s = 60.0;  // 0: nothing is sent again
  double first_delay_s = 0.02;
  double max_delay_s = 1.0;
  double remember_s = 30.0;
};

class ReplayResender {
 public:
  explicit ReplayResender(ResendParams params) : params_(params) {}

  // Item `index` of the replay's list, `item`, was sent at now_s (first time or again).
  void OnSent(std::size_t index, const ReplayItem& item, double now_s);
  // A reject_t came at now_s. True when it refused a message of ours that is to go again (every
  // item it may name that is not queued yet is queued), false when its rejection stands: not
  // queue_full, not ours, or a message first refused more than give_up_after_s ago.
  bool OnReject(const slamd::reject_t& reject, double now_s);
  // The items due to go again by now_s, in the order they were queued, taken off the queue.
  std::vector<std::size_t> TakeDue(double now_s);

  bool idle() const { return queue_.empty(); }  // nothing waits to go again
  std::int64_t resent() const { return resent_; }
  std::int64_t given_up() const { return given_up_; }

 private:
  using Key = std::pair<std::string, std::int64_t>;  // robot, utime (the channel checked apart)
  struct Sent {
    double at_s;
    Key key;
    std::size_t index;
  };
  void Forget(double now_s);  // what was sent more than remember_s ago, unless queued
  bool Queued(std::size_t index) const;

  ResendParams params_;
  std::map<Key, std::vector<std::pair<std::string, std::size_t>>> by_key_;  // channel, item
  std::deque<Sent> sent_;                              // every send, in order, for Forget
  std::map<std::size_t, double> last_sent_;            // per item remembered: its latest send
  struct Refused {
    double first_s;  // its first refusal
    int count;
  };
  std::map<std::size_t, Refused> refused_;  // per item remembered
  std::vector<std::pair<double, std::size_t>> queue_;  // due time, item
  std::int64_t resent_ = 0;
  std::int64_t given_up_ = 0;
};

}  // namespace slamd::clients
