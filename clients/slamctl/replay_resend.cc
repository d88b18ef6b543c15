// ReplayResender (see replay_resend.h).
#include "clients/slamctl/replay_resend.h"

#include <algorithm>
#include <cmath>

#include "server/ingest/reject_reason.h"

namespace slamd::clients {

void ReplayResender::OnSent(std::size_t index, const ReplayItem& item, double now_s) {
  Forget(now_s);
  if (params_.give_up_after_s <= 0 || item.robot.empty()) return;
  const Key key{item.robot, item.utime};
  auto [last, first_send] = last_sent_.try_emplace(index, now_s);
  last->second = now_s;
  if (first_send) by_key_[key].emplace_back(item.channel, index);
  sent_.push_back({now_s, key, index});
}

void ReplayResender::Forget(double now_s) {
  while (!sent_.empty() && sent_.front().at_s < now_s - params_.remember_s) {
    const Sent s = sent_.front();
    sent_.pop_front();
    auto last = last_sent_.find(s.index);
    // Sent again since, or waiting to go again: still remembered.
    if (last == last_sent_.end() || last->second != s.at_s) continue;
    if (Queued(s.index)) continue;
    last_sent_.erase(last);
    refused_.erase(s.index);
    auto it = by_key_.find(s.key);
    std::erase_if(it->second, [&](const auto& c) { return c.second == s.index; });
    if (it->second.empty()) by_key_.erase(it);
  }
}

bool ReplayResender::Queued(std::size_t index) const {
  return std::any_of(queue_.begin(), queue_.end(),
                     [&](const auto& q) { return q.second == index; });
}

bool ReplayResender::OnReject(const slamd::reject_t& reject, double now_s) {
  if (reject.reason != static_cast<int>(server::RejectReason::kQueueFull)) return false;
  auto it = by_key_.find(Key{reject.robot, reject.message_utime});
  if (it == by_key_.end()) return false;
  bool ours = false, again = false;
  for (const auto& [channel, index] : it->second) {
    if (channel != reject.channel) continue;
    ours = true;
    if (Queued(index)) {
      again = true;  // refused twice in one burst (messages sharing the key): queued once
      continue;
    }
    Refused& r = refused_.try_emplace(index, Refused{now_s, 0}).first->second;
    if (now_s - r.first_s > params_.give_up_after_s) continue;
    ++r.count;
    const double delay =
        std::min(params_.max_delay_s, params_.first_delay_s * std::ldexp(1.0, r.count - 1));
    queue_.emplace_back(now_s + delay, index);
    again = true;
  }
  if (ours && !again) ++given_up_;
  return again;
}

std::vector<std::size_t> ReplayResender::TakeDue(double now_s) {
  std::vector<std::size_t> due;
  std::erase_if(queue_, [&](const auto& q) {
    if (q.first > now_s) return false;
    due.push_back(q.second);
    return true;
  });
  resent_ += static_cast<std::int64_t>(due.size());
  return due;
}

}  // namespace slamd::clients
