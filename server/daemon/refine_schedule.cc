#include "server/daemon/refine_schedule.h"

#include <algorithm>
#include <cmath>

namespace slamd::server {

RefineSchedule::RefineSchedule(double idle_s)
    : idle_us_(static_cast<std::int64_t>(std::llround(idle_s * 1e6))) {}

void RefineSchedule::OnInput(std::int64_t received_us, std::int64_t popped_us) {
  // A message within kBurstMicros of the previous one continues its burst, so a frame's pages
  // do not shorten the gap to the next frame.
  if (last_receipt_us_ < 0 || received_us - last_receipt_us_ >= kBurstMicros) {
    if (burst_start_us_ >= 0) {
      gaps_[next_gap_] = received_us - burst_start_us_;
      next_gap_ = (next_gap_ + 1) % kGaps;
      num_gaps_ = std::min(num_gaps_ + 1, kGaps);
    }
    burst_start_us_ = received_us;
  }
  last_receipt_us_ = std::max(last_receipt_us_, received_us);
  last_pop_us_ = std::max(last_pop_us_, popped_us);
}

void RefineSchedule::OnRefine(std::int64_t duration_us) {
  durations_[next_duration_] = std::max<std::int64_t>(duration_us, 0);
  next_duration_ = (next_duration_ + 1) % kDurations;
}

std::int64_t RefineSchedule::PeriodMicros() const {
  if (num_gaps_ < kMinGaps) return 0;
  std::array<std::int64_t, kGaps> sorted = gaps_;
  std::nth_element(sorted.begin(), sorted.begin() + num_gaps_ / 2, sorted.begin() + num_gaps_);
  return sorted[num_gaps_ / 2];
}

std::int64_t RefineSchedule::WaitMicros(std::int64_t now_us) const {
  if (last_pop_us_ < 0) return 0;  // nothing received yet: nothing to delay
  const std::int64_t idle = now_us - last_pop_us_;
  const std::int64_t period = PeriodMicros();
  if (period == 0) return std::max<std::int64_t>(idle_us_ - idle, 0);
  const std::int64_t longest = *std::max_element(durations_.begin(), durations_.end());
  const std::int64_t since_burst = now_us - burst_start_us_;
  if (static_cast<double>(since_burst + longest) <= kPeriodMargin * static_cast<double>(period)) {
    return 0;
  }
  // Not in this gap: once the stream has paused (the next burst overdue) or idle_s has passed.
  return std::max<std::int64_t>(std::max(idle_us_, 2 * period) - idle, 0);
}

}  // namespace slamd::server
