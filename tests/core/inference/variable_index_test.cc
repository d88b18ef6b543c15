#include "core/inference/variable_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

namespace slamd::core {
namespace {

std::vector<int> Sorted(std::span<const int> s) {
  std::vector<int> v(s.begin(), s.end());
  std::sort(v.begin(), v.end());
  return v;
}

TEST(VariableIndexTest, AddRemoveCollect) {
  VariableIndex index;
  ASSERT_TRUE(index.AddFactor(0, std::vector<int>{0}).ok());
  ASSERT_TRUE(index.AddFactor(1, std::vector<int>{0, 1}).ok());
  ASSERT_TRUE(index.AddFactor(2, std::vector<int>{1, 4}).ok());
  EXPECT_EQ(index.NumVariables(), 5);
  EXPECT_EQ(index.NumEntries(), 5);
  EXPECT_EQ(Sorted(index.FactorsOf(0)), (std::vector<int>{0, 1}));
  EXPECT_EQ(Sorted(index.FactorsOf(1)), (std::vector<int>{1, 2}));
  EXPECT_TRUE(index.FactorsOf(3).empty());
  EXPECT_TRUE(index.FactorsOf(99).empty());
  std::vector<int> out;
  index.CollectFactors(std::vector<int>{0, 1}, &out);
  EXPECT_EQ(out, (std::vector<int>{0, 1, 2}));

  ASSERT_TRUE(index.RemoveFactor(1, std::vector<int>{0, 1}).ok());
  EXPECT_EQ(Sorted(index.FactorsOf(0)), std::vector<int>{0});
  EXPECT_EQ(Sorted(index.FactorsOf(1)), std::vector<int>{2});
  EXPECT_EQ(index.NumEntries(), 3);
  // Removing again (or with the wrong variables) fails and changes nothing.
  EXPECT_EQ(index.RemoveFactor(1, std::vector<int>{0, 1}).code(), StatusCode::kNotFound);
  EXPECT_EQ(index.RemoveFactor(2, std::vector<int>{1, 0}).code(), StatusCode::kNotFound);
  EXPECT_EQ(Sorted(index.FactorsOf(1)), std::vector<int>{2});
  EXPECT_EQ(index.RemoveFactor(2, std::vector<int>{1, 1}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(index.AddFactor(3, std::vector<int>{2, 2}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(index.AddFactor(-1, std::vector<int>{2}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(index.AddFactor(3, std::vector<int>{-2}).code(), StatusCode::kInvalidArgument);
}

TEST(VariableIndexTest, RandomAgainstBruteForce) {
  std::mt19937 rng(8);
  VariableIndex index;
  std::vector<std::vector<int>> factors;
  std::set<int> live;
  for (int step = 0; step < 2000; ++step) {
    if (live.empty() || rng() % 3 != 0) {
      const int f = static_cast<int>(factors.size());
      const int a = static_cast<int>(rng() % 50);
      const int b = static_cast<int>(rng() % 50);
      factors.push_back(a == b ? std::vector<int>{a} : std::vector<int>{a, b});
      ASSERT_TRUE(index.AddFactor(f, factors.back()).ok());
      live.insert(f);
    } else {
      auto it = live.begin();
      std::advance(it, rng() % live.size());
      ASSERT_TRUE(index.RemoveFactor(*it, factors[*it]).ok());
      live.erase(it);
    }
  }
  for (int v = 0; v < index.NumVariables(); ++v) {
    std::vector<int> expected;
    for (int f : live) {
      if (std::find(factors[f].begin(), factors[f].end(), v) != factors[f].end()) {
        expected.push_back(f);
      }
    }
    EXPECT_EQ(Sorted(index.FactorsOf(v)), expected);
  }
  // CollectFactors on a few variables (sorted lists) and on most (a scan of all factor indices).
  for (const std::vector<int>& vars :
       {std::vector<int>{3, 7}, std::vector<int>{5}, std::vector<int>{}}) {
    std::set<int> expected;
    for (int v : vars) expected.insert(index.FactorsOf(v).begin(), index.FactorsOf(v).end());
    std::vector<int> out;
    index.CollectFactors(vars, &out);
    EXPECT_EQ(out, std::vector<int>(expected.begin(), expected.end()));
  }
  std::vector<int> most;
  for (int v = 0; v < 45; ++v) most.push_back(v);
  std::set<int> expected;
  for (int f : live) {
    for (int v : factors[f]) {
      if (v < 45) expected.insert(f);
    }
  }
  std::vector<int> out;
  index.CollectFactors(most, &out);
  EXPECT_EQ(out, std::vector<int>(expected.begin(), expected.end()));
}

}  // namespace
}  // namespace slamd::core
