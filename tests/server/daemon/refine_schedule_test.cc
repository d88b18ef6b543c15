#include "server/daemon/refine_schedule.h"

#include <gtest/gtest.h>

namespace slamd::server {
namespace {

constexpr std::int64_t kMs = 1000;

// A frame of two messages (odometry, then its observations 0.3 ms later) every 33 ms, popped at
// once; `frames` of them from t = 0.
void Stream(RefineSchedule* s, int frames, std::int64_t period = 33 * kMs) {
  for (int f = 0; f < frames; ++f) {
    const std::int64_t t = f * period;
    s->OnInput(t, t);
    s->OnInput(t + 300, t + 300);
  }
}

TEST(RefineScheduleTest, WithoutARhythmRefinesAfterTheIdleTime) {
  RefineSchedule s(0.02);
  EXPECT_EQ(s.WaitMicros(0), 0);  // nothing received: nothing to delay
  Stream(&s, 3);                  // too few gaps for a rhythm
  EXPECT_EQ(s.PeriodMicros(), 0);
  const std::int64_t last = 2 * 33 * kMs + 300;
  EXPECT_EQ(s.WaitMicros(last + 5 * kMs), 15 * kMs);
  EXPECT_EQ(s.WaitMicros(last + 20 * kMs), 0);
}

TEST(RefineScheduleTest, LearnsTheStreamsPeriodFromBurstsNotTheirMessages) {
  RefineSchedule s(0.02);
  Stream(&s, 20);
  EXPECT_EQ(s.PeriodMicros(), 33 * kMs);
}

// A refinement that fits in the gap runs right after the update; one that would run into the
// next frame waits until the stream pauses.
TEST(RefineScheduleTest, RefinesInTheGapOnlyWhenItEndsBeforeTheNextFrame) {
  RefineSchedule s(0.02);
  Stream(&s, 20);
  const std::int64_t burst = 19 * 33 * kMs;  // the newest frame's start
  const std::int64_t last = burst + 300;
  s.OnRefine(10 * kMs);
  // 3 ms after the frame (its update done): 3 + 10 <= 0.8 x 33 ms.
  EXPECT_EQ(s.WaitMicros(burst + 3 * kMs), 0);
  // Later in the gap it would not end in time: wait for a pause (2 periods after the frame).
  EXPECT_EQ(s.WaitMicros(burst + 20 * kMs), last + 66 * kMs - (burst + 20 * kMs));
  // The longest of the recent calls counts.
  s.OnRefine(25 * kMs);
  s.OnRefine(1 * kMs);
  EXPECT_GT(s.WaitMicros(burst + 3 * kMs), 0);
  // Four short calls later the long one is forgotten.
  for (int i = 0; i < 4; ++i) s.OnRefine(2 * kMs);
  EXPECT_EQ(s.WaitMicros(burst + 3 * kMs), 0);
  // The stream paused: refine whatever the duration.
  s.OnRefine(500 * kMs);
  EXPECT_EQ(s.WaitMicros(last + 66 * kMs), 0);
}

// Idleness counts from when the estimator took the message: a message that waited behind a
// long update does not make a refinement due at once.
TEST(RefineScheduleTest, IdleTimeCountsFromThePop) {
  RefineSchedule s(0.02);
  s.OnInput(0, 50 * kMs);
  EXPECT_EQ(s.WaitMicros(51 * kMs), 19 * kMs);
}

}  // namespace
}  // namespace slamd::server
