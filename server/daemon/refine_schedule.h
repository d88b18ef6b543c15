// RefineSchedule: when the estimator thread may start an idle-time refinement (Isam2::Refine)
// without delaying the next message of a steady stream.
//
// A refinement call cannot be interrupted, and one round can outlast its time budget (a camera
// map's round re-eliminates its whole changed part: 10-20 ms). Started at a fixed idle time it
// lands on the next frame of a 30 Hz stream, which then waits for it. So the schedule learns
// the stream's rhythm (the median gap between bursts of messages) and how long refinement calls
// take (the longest of the last few), and lets one start only when it is predicted to end well
// before the next burst is due: right after an update when the gap has room, not at all while
// the gap is too short for it. When the stream pauses (no message for twice its period) or has
// no rhythm yet, the fixed rule applies: refine after `idle_s` without a message.
//
// Times are microseconds on one steady clock, passed in (deterministic tests). Estimator thread
// only.
#pragma once

#include <array>
#include <cstdint>

namespace slamd::server {

class RefineSchedule {
 public:
  // Messages closer than this are one burst (a frame's pages and odometry) [µs].
  static constexpr std::int64_t kBurstMicros = 2000;
  // A refinement must be predicted to end within this fraction of the period after a burst.
  static constexpr double kPeriodMargin = 0.8;

  explicit RefineSchedule(double idle_s);

  // A message received (by intake) at `received_us` was popped by the estimator at
  // `popped_us`: the rhythm is read from receipts, idleness counts from the pop (a message
  // that waited for a long update does not make the estimator idle).
  void OnInput(std::int64_t received_us, std::int64_t popped_us);
  // A refinement call took this long.
  void OnRefine(std::int64_t duration_us);

  // How long from `now_us` until a refinement may start; 0 = now.
  std::int64_t WaitMicros(std::int64_t now_us) const;

  // The stream's period as learnt (median gap between bursts) [µs]; 0 = no rhythm yet.
  std::int64_t PeriodMicros() const;

 private:
  static constexpr int kGaps = 16;      // gaps remembered (the period is their median)
  static constexpr int kMinGaps = 8;    // a rhythm needs this many
  static constexpr int kDurations = 4;  // refinement calls remembered (the longest counts)

  const std::int64_t idle_us_;
  std::int64_t last_receipt_us_ = -1;  // -1 = none yet
  std::int64_t burst_start_us_ = -1;   // first receipt of the newest burst
  std::int64_t last_pop_us_ = -1;
  std::array<std::int64_t, kGaps> gaps_{};
  int num_gaps_ = 0, next_gap_ = 0;
  std::array<std::int64_t, kDurations> durations_{};
  int next_duration_ = 0;
};

}  // namespace slamd::server
