// ReplayTracker: the bookkeeping of `slamctl replay`, apart from any transport so it can be
// tested alone. It learns what was sent (OnSent) and what the server said (OnEstimate,
// OnReject, OnStatus) and answers the pacing questions (how many poses of a robot are not yet
// acknowledged) and the summary ones (rejects per reason, latency percentiles, settled).
//
// Acknowledgement: an estimate_t of robot r with pose_index p acknowledges every pose of r sent
// with index <= p (the server publishes only a robot's newest pose; updates coalesce). The
// latency of a pose is from its send to the first estimate_t that acknowledges it (client
// clock, seconds from any fixed origin).
// Not thread-safe (slamctl is single-threaded).
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "clients/slamctl/replay_sources.h"
#include "slamd/reject_t.hpp"
#include "slamd/status_t.hpp"

namespace slamd::clients {

struct LatencySummary {
  std::size_t count = 0;  // acknowledged poses
  double p50_ms = 0, p90_ms = 0, p99_ms = 0, max_ms = 0;
};

// The nearest-rank percentile q in [0, 1] of `values` (sorted in place); 0 when empty.
double Percentile(std::vector<double>* values, double q);

class ReplayTracker {
 public:
  // `robots`: the robots whose reject_t count as ours (a reject of another sender is ignored).
  explicit ReplayTracker(std::set<std::string> robots) : robots_(std::move(robots)) {}

  // The server's counters before we sent anything (from a status_t seen first), so that
  // "received everything" and "already held" can be judged on a server that had traffic.
  void SetBaseline(const slamd::status_t& status) {
    baseline_ = status.messages_received;
    already_held_baseline_ = status.messages_already_held;
  }

  void OnSent(const ReplayItem& item, double now_s);
  // A message sent again (refused as queue_full): counted as sent, its pose already pending.
  void OnResent() { ++sent_; }
  void OnEstimate(const std::string& robot, std::int64_t pose_index, double now_s);
  void OnReject(const slamd::reject_t& reject);
  void OnStatus(const slamd::status_t& status);

  std::int64_t sent() const { return sent_; }
  // Poses of `robot` sent and not acknowledged yet.
  std::size_t Unacked(const std::string& robot) const;
  bool AllAcked() const;
  // The newest acknowledged pose of `robot`, -1 when none.
  std::int64_t Acked(const std::string& robot) const;

  // The latest status_t says: everything we sent was received (messages_received - baseline >=
  // sent), nothing is queued, and the estimate settled; and every sent pose is acknowledged (or
  // something was rejected, since a rejected pose never will be).
  bool Settled() const;
  // The latest status_t has received everything we sent (settled or not).
  bool ReceivedAll() const;
  const std::optional<slamd::status_t>& last_status() const { return last_status_; }
  std::int64_t status_count() const { return status_count_; }

  std::int64_t rejected() const { return rejected_; }
  // Messages the server held already (re-sent data it had), from the latest status_t: they are
  // acknowledged by the robots' estimates, neither applied again nor rejected.
  std::int64_t already_held() const {
    return last_status_ ? last_status_->messages_already_held - already_held_baseline_ : 0;
  }
  // reason name (server::RejectReasonName) -> count, for our robots.
  const std::map<std::string, std::int64_t>& rejected_by_reason() const { return by_reason_; }
  // The first few reject details, for the summary.
  const std::vector<std::string>& reject_details() const { return details_; }

  LatencySummary Latency() const;

 private:
  struct Pending {
    std::int64_t pose;
    double sent_s;
  };
  std::set<std::string> robots_;
  std::int64_t baseline_ = 0;
  std::int64_t already_held_baseline_ = 0;
  std::int64_t sent_ = 0;
  std::map<std::string, std::deque<Pending>> pending_;  // per robot, in send order
  std::map<std::string, std::int64_t> acked_;
  std::vector<double> latencies_ms_;
  std::int64_t rejected_ = 0;
  std::map<std::string, std::int64_t> by_reason_;
  std::vector<std::string> details_;
  std::optional<slamd::status_t> last_status_;
  std::int64_t status_count_ = 0;
};

}  // namespace slamd::clients
