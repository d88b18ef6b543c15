#include "core/inference/symbolic_elimination.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <vector>

namespace slamd::core::internal {
namespace {

// A factor graph on positions (factors listed by their variables' positions).
using Factors = std::vector<std::vector<int>>;

struct Built {
  SymbolicForest forest;
  std::vector<int> ptr, pos, hessian_ptr;
};

// The rules under test: one clique per variable, fundamental supernodes, relaxed supernodes.
const SupernodeRule kNoMerge{.merge = false};
const SupernodeRule kFundamental{};
const SupernodeRule kRelaxed{.relaxed_new_variables = 1, .relaxed_max_frontals = 4};

Built Build(int k, const Factors& factors, const SupernodeRule& rule,
            const std::vector<int>& hessians_at = {}) {
  Built b;
  std::vector<std::vector<int>> structure(k);
  for (const auto& f : factors) {
    const int first = *std::min_element(f.begin(), f.end());
    structure[first].insert(structure[first].end(), f.begin(), f.end());
  }
  b.ptr.push_back(0);
  b.hessian_ptr.assign(k + 1, 0);
  for (int j = 0; j < k; ++j) {
    b.pos.insert(b.pos.end(), structure[j].begin(), structure[j].end());
    b.ptr.push_back(static_cast<int>(b.pos.size()));
  }
  for (int j : hessians_at) {
    for (int i = j + 1; i <= k; ++i) ++b.hessian_ptr[i];
  }
  SymbolicWorkspace ws;
  BuildSymbolicForest(k, b.ptr, b.pos, b.hessian_ptr, rule, &b.forest, &ws);
  return b;
}

std::vector<int> Frontals(const SymbolicForest& f, int c) {
  std::vector<int> out;
  for (int p = f.first_frontal[c]; p != -1; p = f.next_frontal[p]) out.push_back(p);
  return out;
}

std::vector<int> Separator(const SymbolicForest& f, int c) {
  return {f.sep_data.begin() + f.sep_begin[c], f.sep_data.begin() + f.sep_end[c]};
}

// Independent reference: the filled graph by brute-force symbolic elimination; sep(j) = the
// neighbours of j eliminated after it.
std::vector<std::set<int>> ReferenceSeparators(int k, const Factors& factors) {
  std::vector<std::set<int>> adj(k);
  for (const auto& f : factors) {
    for (int a : f) {
      for (int b : f) {
        if (a != b) adj[a].insert(b);
      }
    }
  }
  std::vector<std::set<int>> sep(k);
  for (int j = 0; j < k; ++j) {
    for (int u : adj[j]) {
      if (u > j) sep[j].insert(u);
    }
    for (int a : sep[j]) {
      for (int b : sep[j]) {
        if (a != b) adj[a].insert(b);
      }
    }
  }
  return sep;
}

Factors Chain(int n) {
  Factors f = {{0}};
  for (int i = 0; i + 1 < n; ++i) f.push_back({i, i + 1});
  return f;
}

TEST(SymbolicEliminationTest, ChainInNaturalOrder) {
  // x0 - x1 - ... - x9: clique i = {x_i | x_{i+1}}; only the root pair is a fundamental
  // supernode ({x8, x9}), so n - 1 cliques.
  const int n = 10;
  const Built b = Build(n, Chain(n), kFundamental);
  ASSERT_EQ(b.forest.NumCliques(), n - 1);
  const int root = b.forest.NumCliques() - 1;
  EXPECT_EQ(Frontals(b.forest, root), (std::vector<int>{n - 2, n - 1}));
  EXPECT_TRUE(Separator(b.forest, root).empty());
  for (int c = 0; c < root; ++c) {
    EXPECT_EQ(Frontals(b.forest, c), std::vector<int>{c});
    EXPECT_EQ(Separator(b.forest, c), std::vector<int>{c + 1});
    EXPECT_EQ(b.forest.Parent(c), c + 1);
  }
  // Without merging: one clique per variable.
  EXPECT_EQ(Build(n, Chain(n), kNoMerge).forest.NumCliques(), n);
}

TEST(SymbolicEliminationTest, RelaxedSupernodesGroupAChainUpToTheFrontalCap) {
  // Each x_i brings x_{i+1} into the separator (one new variable): relaxed merging takes up to
  // 4 frontals per clique, then the root pair is a fundamental supernode.
  const int n = 10;
  const Built b = Build(n, Chain(n), kRelaxed);
  ASSERT_EQ(b.forest.NumCliques(), 3);
  EXPECT_EQ(Frontals(b.forest, 0), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(Separator(b.forest, 0), std::vector<int>{4});
  EXPECT_EQ(Frontals(b.forest, 1), (std::vector<int>{4, 5, 6, 7}));
  EXPECT_EQ(Separator(b.forest, 1), std::vector<int>{8});
  EXPECT_EQ(Frontals(b.forest, 2), (std::vector<int>{8, 9}));
  EXPECT_TRUE(Separator(b.forest, 2).empty());
  EXPECT_EQ(b.forest.Parent(0), 1);
  EXPECT_EQ(b.forest.Parent(1), 2);
  // x1 brings two new variables (x2, x3): over an allowance of one.
  const Factors two_new = {{0}, {0, 1}, {1, 2, 3}};
  EXPECT_EQ(Build(4, two_new, kRelaxed).forest.NumCliques(), 2);
  EXPECT_EQ(Build(4, two_new, {.relaxed_new_variables = 2, .relaxed_max_frontals = 4})
                .forest.NumCliques(),
            1);
  // A Hessian factor still blocks the merge.
  EXPECT_EQ(Build(n, Chain(n), kRelaxed, {1}).forest.num_frontals[0], 1);
}

TEST(SymbolicEliminationTest, ChainEliminatedFromBothEndsMeetsInTheMiddle) {
  // Order x0, x9, x1, x8, ...: two chains that meet at the last variable.
  const int n = 10;
  std::vector<int> position(n);
  for (int i = 0; i < n; ++i) position[i % 2 == 0 ? i / 2 : n - 1 - i / 2] = i;
  Factors f;
  for (int i = 0; i + 1 < n; ++i) f.push_back({position[i], position[i + 1]});
  f.push_back({position[0]});
  const Built b = Build(n, f, kFundamental);
  // Every variable adds its next neighbour to its separator, and the last one has two children
  // (one per half): nothing merges.
  EXPECT_EQ(b.forest.NumCliques(), n);
  EXPECT_EQ(b.forest.num_frontals[n - 1], 1);
}

TEST(SymbolicEliminationTest, DenseGraphIsOneClique) {
  Factors f;
  for (int a = 0; a < 6; ++a) {
    for (int b = a + 1; b < 6; ++b) f.push_back({a, b});
  }
  const Built b = Build(6, f, kFundamental);
  ASSERT_EQ(b.forest.NumCliques(), 1);
  EXPECT_EQ(Frontals(b.forest, 0), (std::vector<int>{0, 1, 2, 3, 4, 5}));
}

TEST(SymbolicEliminationTest, StarMergesOnlyTheHub) {
  // Leaves 0..4 each tied to the hub 5: five leaf cliques {i | 5}; the hub has five children,
  // so it is a clique of its own.
  Factors f;
  for (int i = 0; i < 5; ++i) f.push_back({i, 5});
  const Built b = Build(6, f, kFundamental);
  EXPECT_EQ(b.forest.NumCliques(), 6);
  // Landmark-like: a 3-variable factor merges a clique of 3.
  const Built t = Build(3, {{0, 1, 2}}, kFundamental);
  EXPECT_EQ(t.forest.NumCliques(), 1);
}

TEST(SymbolicEliminationTest, HessianFactorsBlockMerging) {
  // Chain with a Hessian factor assigned to the last-but-one position: it stands for another
  // child, so the root pair is not merged.
  const int n = 5;
  EXPECT_EQ(Build(n, Chain(n), kFundamental).forest.NumCliques(), n - 1);
  EXPECT_EQ(Build(n, Chain(n), kFundamental, {n - 1}).forest.NumCliques(), n);
}

TEST(SymbolicEliminationTest, RandomGraphsMatchBruteForce) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 50; ++trial) {
    const int k = 5 + static_cast<int>(rng() % 40);
    Factors f;
    for (int j = 0; j < k; ++j) f.push_back({j});
    const int m = static_cast<int>(rng() % (2 * k));
    for (int e = 0; e < m; ++e) {
      const int a = static_cast<int>(rng() % k), b = static_cast<int>(rng() % k);
      if (a != b) f.push_back({a, b});
      if (e % 7 == 0) f.push_back({a, b == a ? (a + 1) % k : b, static_cast<int>(rng() % k)});
    }
    for (auto& fac : f) {
      std::sort(fac.begin(), fac.end());
      fac.erase(std::unique(fac.begin(), fac.end()), fac.end());
    }
    const auto ref = ReferenceSeparators(k, f);
    for (const SupernodeRule& rule : {kNoMerge, kFundamental, kRelaxed}) {
      const Built b = Build(k, f, rule);
      const SymbolicForest& forest = b.forest;
      std::vector<int> seen(k, 0);
      for (int c = 0; c < forest.NumCliques(); ++c) {
        const std::vector<int> fr = Frontals(forest, c);
        ASSERT_EQ(static_cast<int>(fr.size()), forest.num_frontals[c]);
        // The clique's separator is that of its last frontal; consecutive frontals form a
        // fundamental supernode, sep(f_i) = {f_{i+1}} ∪ sep(f_{i+1}), or a relaxed one:
        // sep(f_i) ⊆ {f_{i+1}} ∪ sep(f_{i+1}), with at most relaxed_new_variables more, added
        // while the clique had fewer than relaxed_max_frontals frontals.
        const std::vector<int> sep = Separator(forest, c);
        EXPECT_EQ(std::set<int>(sep.begin(), sep.end()), ref[fr.back()]);
        EXPECT_TRUE(std::is_sorted(sep.begin(), sep.end()));
        for (size_t i = 0; i + 1 < fr.size(); ++i) {
          std::set<int> next = ref[fr[i + 1]];
          next.insert(fr[i + 1]);
          EXPECT_TRUE(
              std::includes(next.begin(), next.end(), ref[fr[i]].begin(), ref[fr[i]].end()));
          const int added = static_cast<int>(next.size() - ref[fr[i]].size());
          if (added > 0) {
            EXPECT_LE(added, rule.relaxed_new_variables);
            EXPECT_LT(static_cast<int>(i) + 1, rule.relaxed_max_frontals);
          }
        }
        for (int p : fr) {
          ++seen[p];
          EXPECT_EQ(forest.clique_of[p], c);
        }
        // Children come first; each child's separator starts at one of this clique's frontals.
        for (int ch = forest.first_child[c]; ch != -1; ch = forest.next_sibling[ch]) {
          EXPECT_LT(ch, c);
          EXPECT_EQ(forest.Parent(ch), c);
        }
        if (forest.Parent(c) >= 0) {
          EXPECT_GT(forest.Parent(c), c);
        }
      }
      for (int p = 0; p < k; ++p) EXPECT_EQ(seen[p], 1);
      if (!rule.merge) {
        EXPECT_EQ(forest.NumCliques(), k);
      }
    }
  }
}

}  // namespace
}  // namespace slamd::core::internal
