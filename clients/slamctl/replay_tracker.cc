// ReplayTracker (see replay_tracker.h).
#include "clients/slamctl/replay_tracker.h"

#include <algorithm>
#include <cmath>

#include "server/ingest/reject_reason.h"

namespace slamd::clients {

double Percentile(std::vector<double>* values, double q) {
  if (values->empty()) return 0.0;
  std::sort(values->begin(), values->end());
  // Nearest rank: the smallest value with at least q of the values at or below it.
  const double rank = std::ceil(q * static_cast<double>(values->size()));
  const size_t i = rank < 1.0 ? 0 : static_cast<size_t>(rank) - 1;
  return (*values)[std::min(i, values->size() - 1)];
}

void ReplayTracker::OnSent(const ReplayItem& item, double now_s) {
  ++sent_;
  if (item.new_pose < 0 || item.robot.empty()) return;
  auto it = acked_.find(item.robot);
  if (it != acked_.end() && item.new_pose <= it->second) {
    latencies_ms_.push_back(0.0);  // already acknowledged (an estimate of a later pose came)
    return;
  }
  pending_[item.robot].push_back({item.new_pose, now_s});
}

void ReplayTracker::OnEstimate(const std::string& robot, std::int64_t pose_index, double now_s) {
  auto& acked = acked_.try_emplace(robot, -1).first->second;
  acked = std::max(acked, pose_index);
  auto it = pending_.find(robot);
  if (it == pending_.end()) return;
  // Poses are sent in increasing index per robot (dataset steps; logs as recorded), but do not
  // rely on it: acknowledge every pending pose at or below the estimate's.
  std::deque<Pending>& q = it->second;
  for (auto p = q.begin(); p != q.end();) {
    if (p->pose <= pose_index) {
      latencies_ms_.push_back(std::max(0.0, (now_s - p->sent_s) * 1e3));
      p = q.erase(p);
    } else {
      ++p;
    }
  }
}

void ReplayTracker::OnReject(const slamd::reject_t& reject) {
  if (!robots_.count(reject.robot)) return;
  ++rejected_;
  ++by_reason_[server::RejectReasonName(static_cast<server::RejectReason>(reject.reason))];
  if (details_.size() < 10) {
    details_.push_back(reject.message_type + " (" + reject.robot + ", utime " +
                       std::to_string(reject.message_utime) + "): " + reject.detail);
  }
}

void ReplayTracker::OnStatus(const slamd::status_t& status) {
  last_status_ = status;
  ++status_count_;
}

std::size_t ReplayTracker::Unacked(const std::string& robot) const {
  auto it = pending_.find(robot);
  return it == pending_.end() ? 0 : it->second.size();
}

bool ReplayTracker::AllAcked() const {
  for (const auto& [robot, q] : pending_) {
    if (!q.empty()) return false;
  }
  return true;
}

std::int64_t ReplayTracker::Acked(const std::string& robot) const {
  auto it = acked_.find(robot);
  return it == acked_.end() ? -1 : it->second;
}

bool ReplayTracker::ReceivedAll() const {
  return last_status_ && last_status_->messages_received - baseline_ >= sent_;
}

bool ReplayTracker::Settled() const {
  // A rejected pose is never acknowledged: with rejects, the server's word is enough.
  return ReceivedAll() && last_status_->queue_depth == 0 && last_status_->settled &&
         (AllAcked() || rejected_ > 0);
}

LatencySummary ReplayTracker::Latency() const {
  std::vector<double> v = latencies_ms_;
  LatencySummary s;
  s.count = v.size();
  if (v.empty()) return s;
  s.p50_ms = Percentile(&v, 0.50);
  s.p90_ms = Percentile(&v, 0.90);
  s.p99_ms = Percentile(&v, 0.99);
  s.max_ms = v.back();
  return s;
}

}  // namespace slamd::clients
