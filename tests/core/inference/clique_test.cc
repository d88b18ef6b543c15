#include "core/inference/clique.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <thread>
#include <vector>

namespace slamd::core {
namespace {

TEST(CliqueTest, ResetShapesTheViews) {
  Clique c;
  c.Reset(std::vector<int>{4, 2}, std::vector<int>{3, 1}, std::vector<int>{7, 0},
          std::vector<int>{6, 2});
  EXPECT_EQ(c.num_frontals(), 2);
  EXPECT_EQ(c.frontal(1), 2);
  EXPECT_EQ(c.frontal_offset(1), 3);
  EXPECT_EQ(c.frontal_dim(1), 1);
  EXPECT_EQ(c.FrontalDim(), 4);
  EXPECT_EQ(c.num_separator(), 2);
  EXPECT_EQ(c.separator()[0], 7);
  EXPECT_EQ(c.separator_offset(1), 6);
  EXPECT_EQ(c.separator_dim(1), 2);
  EXPECT_EQ(c.SeparatorDim(), 8);
  EXPECT_EQ(c.conditional().rows(), 4);
  EXPECT_EQ(c.conditional().cols(), 13);
  EXPECT_EQ(c.cached_factor().Info().rows(), 9);
  EXPECT_EQ(c.parent(), Clique::kNone);
  EXPECT_TRUE(c.children().empty());

  // R, S, d are the column ranges of [R S d].
  auto cond = c.mutable_conditional();
  for (int j = 0; j < cond.cols(); ++j) cond.col(j).setConstant(j);
  EXPECT_EQ(c.R()(0, 3), 3.0);
  EXPECT_EQ(c.S()(2, 0), 4.0);
  EXPECT_EQ(c.S()(1, 7), 11.0);
  EXPECT_EQ(c.d()(3), 12.0);
  EXPECT_EQ(c.R().cols(), 4);
  EXPECT_EQ(c.S().cols(), 8);

  // Re-shaping zeroes everything.
  c.Reset(std::vector<int>{1}, std::vector<int>{2}, {}, {});
  EXPECT_EQ(c.SeparatorDim(), 0);
  EXPECT_EQ(c.conditional().cols(), 3);
  EXPECT_EQ(c.conditional().cwiseAbs().maxCoeff(), 0.0);
}

TEST(CliqueTest, GenerationIsRenewedByEveryResetAndKeptByACopy) {
  Clique a, b;
  EXPECT_NE(a.generation(), 0u);
  EXPECT_NE(a.generation(), b.generation());  // default-constructed cliques differ too
  const std::vector<int> frontals = {3}, dims = {2}, separator = {5}, separator_dims = {3};
  a.Reset(frontals, dims, separator, separator_dims);
  const std::uint64_t g1 = a.generation();
  EXPECT_NE(g1, b.generation());
  // Same structure, new content: the stamp must change (readers cannot see numbers change).
  a.ResetForElimination(frontals, dims, separator, separator_dims);
  const std::uint64_t g2 = a.generation();
  EXPECT_NE(g2, g1);
  a.Reset(frontals, dims, separator, separator_dims);
  EXPECT_NE(a.generation(), g2);
  EXPECT_NE(a.generation(), g1);
  // Writing through the mutable views does not renew it (writers reset first, see clique.h).
  const std::uint64_t g3 = a.generation();
  a.mutable_conditional()(0, 0) = 2.0;
  EXPECT_EQ(a.generation(), g3);
  // A copy has the same content, so the same stamp; resetting either separates them.
  Clique copy = a;
  EXPECT_EQ(copy.generation(), g3);
  EXPECT_EQ(copy.conditional()(0, 0), 2.0);
  copy.Reset(frontals, dims, separator, separator_dims);
  EXPECT_NE(copy.generation(), g3);
  EXPECT_EQ(a.generation(), g3);
  b = a;
  EXPECT_EQ(b.generation(), g3);
}

// Two threads resetting disjoint cliques (parallel elimination) never draw the same stamp.
TEST(CliqueTest, ConcurrentResetsGiveDistinctGenerations) {
  constexpr int kResets = 20000;
  const std::vector<int> frontals = {0}, dims = {3};
  std::vector<std::uint64_t> seen[2];
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t) {
    threads.emplace_back([&, t] {
      Clique c;
      seen[t].reserve(kResets);
      for (int i = 0; i < kResets; ++i) {
        c.ResetForElimination(frontals, dims, {}, {});
        seen[t].push_back(c.generation());
      }
    });
  }
  for (std::thread& th : threads) th.join();
  std::vector<std::uint64_t> all = seen[0];
  all.insert(all.end(), seen[1].begin(), seen[1].end());
  std::sort(all.begin(), all.end());
  EXPECT_EQ(std::adjacent_find(all.begin(), all.end()), all.end()) << "a stamp was drawn twice";
  // Each thread's stamps increase (one counter, fetched in program order).
  for (int t = 0; t < 2; ++t) EXPECT_TRUE(std::is_sorted(seen[t].begin(), seen[t].end()));
}

}  // namespace
}  // namespace slamd::core
