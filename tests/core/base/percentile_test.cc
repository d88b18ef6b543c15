// core::Percentile (core/base/percentile.h) against the sorted sample.
#include "core/base/percentile.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace slamd::core {
namespace {

TEST(PercentileTest, IsTheValueAtTheRoundedRankOfTheSortedSample) {
  EXPECT_EQ(Percentile({}, 0.5), 0.0);
  EXPECT_EQ(Percentile({7.0}, 0.99), 7.0);
  std::vector<double> v(1001);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 10.0);
  for (double& x : v) x = u(rng);
  std::vector<double> sorted = v;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(Percentile(v, 0.0), sorted.front());
  EXPECT_EQ(Percentile(v, 0.5), sorted[500]);
  EXPECT_EQ(Percentile(v, 0.9), sorted[900]);
  EXPECT_EQ(Percentile(v, 0.99), sorted[990]);
  EXPECT_EQ(Percentile(v, 1.0), sorted.back());
  EXPECT_EQ(Percentile({1.0, 2.0, 3.0, 4.0}, 0.5), 3.0);  // rank round(1.5) = 2
}

}  // namespace
}  // namespace slamd::core
