// LatencyWindow (server/daemon/latency_window.h): the last N samples and their quantiles,
// against a sort of the same samples.
#include "server/daemon/latency_window.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace slamd::server {
namespace {

TEST(LatencyWindowTest, QuantilesOfTheLastSamplesAgreeWithASort) {
  EXPECT_EQ(LatencyWindow(8).Percentiles<2>({0.5, 1.0}), (std::array<std::int64_t, 2>{0, 0}));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1e6);
  LatencyWindow window(100);
  std::vector<double> all;
  for (int i = 0; i < 250; ++i) {
    all.push_back(u(rng));
    window.Record(all.back());
  }
  std::vector<double> last(all.end() - 100, all.end());  // what the window keeps
  std::sort(last.begin(), last.end());
  const auto got = window.Percentiles<4>({0.0, 0.5, 0.99, 1.0});
  EXPECT_EQ(got[0], static_cast<std::int64_t>(last[0]));
  EXPECT_EQ(got[1], static_cast<std::int64_t>(last[50]));
  EXPECT_EQ(got[2], static_cast<std::int64_t>(last[99]));
  EXPECT_EQ(got[3], static_cast<std::int64_t>(last[99]));
  // Fewer samples than the window: all of them.
  LatencyWindow few(100);
  for (double v : {3.0, 1.0, 2.0}) few.Record(v);
  EXPECT_EQ(few.Percentiles<2>({0.0, 1.0}), (std::array<std::int64_t, 2>{1, 3}));
}

}  // namespace
}  // namespace slamd::server
