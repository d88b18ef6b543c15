#include "core/inference/subtree_split.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace slamd::core {
namespace {

// A random SLAM-like tree: a spine from the root 0 with branches (chains of cliques) hanging
// off it, heavier towards the root as clique sizes are.
struct Tree {
  std::vector<int> parent;
  std::vector<std::vector<int>> children;
  std::vector<double> work, subtree_work;
};

Tree MakeTree(int spine, unsigned seed) {
  std::mt19937 rng(seed);
  Tree t;
  auto add = [&](int parent, double work) {
    const int id = static_cast<int>(t.parent.size());
    t.parent.push_back(parent);
    t.children.emplace_back();
    t.work.push_back(work);
    if (parent >= 0) t.children[parent].push_back(id);
    return id;
  };
  int prev = -1;
  for (int i = 0; i < spine; ++i) {
    const int s = add(prev, 100.0 + 10.0 * (spine - i));
    for (int b = 1 + static_cast<int>(rng() % 2); b > 0; --b) {
      int at = s;
      for (int d = 5 + static_cast<int>(rng() % 35); d >= 0; --d) at = add(at, 50.0 + rng() % 100);
    }
    prev = s;
  }
  t.subtree_work = t.work;
  for (int c = static_cast<int>(t.parent.size()) - 1; c >= 0; --c) {  // children have larger ids
    if (t.parent[c] >= 0) t.subtree_work[t.parent[c]] += t.subtree_work[c];
  }
  return t;
}

SubtreeSplit Split(const Tree& t, int threads) {
  SubtreeSplit split;
  const std::vector<int> roots = {0};
  SplitSubtrees(
      roots, t.work, t.subtree_work,
      [&](int c, auto&& f) {
        for (int child : t.children[c]) f(child);
      },
      threads, &split);
  return split;
}

// Every clique is in the top or under exactly one subtree root; the top is closed towards the
// root; each subtree root hangs off the top; and two threads get loads within 10% of each other
// with a top that is a small part of the work.
TEST(SubtreeSplitTest, CoversTheTreeOnceAndBalancesTwoThreads) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const Tree t = MakeTree(60, seed);
    const int n = static_cast<int>(t.parent.size());
    const SubtreeSplit split = Split(t, 2);
    ASSERT_EQ(split.subtrees.size(), 2u);
    std::vector<int> owner(n, -2);
    for (int c : split.top) owner[c] = -1;
    for (int c : split.top) {
      EXPECT_TRUE(t.parent[c] < 0 || owner[t.parent[c]] == -1) << "top not closed at " << c;
    }
    double load[2] = {0.0, 0.0};
    for (int th = 0; th < 2; ++th) {
      for (int c : split.subtrees[th]) {
        ASSERT_EQ(owner[c], -2) << "clique " << c << " given twice";
        EXPECT_TRUE(t.parent[c] >= 0 && owner[t.parent[c]] == -1) << c;
        owner[c] = th;
        load[th] += t.subtree_work[c];
      }
    }
    double top_work = 0.0;
    for (int c = 0; c < n; ++c) {
      if (owner[c] == -2) {
        ASSERT_GE(t.parent[c], 0) << "root " << c << " not covered";
        owner[c] = owner[t.parent[c]];  // parents have smaller ids
        ASSERT_GE(owner[c], 0) << "clique " << c << " under the top but in no subtree";
      }
      if (owner[c] == -1) top_work += t.work[c];
    }
    EXPECT_NEAR(load[0], load[1], 0.1 * std::max(load[0], load[1])) << "seed " << seed;
    EXPECT_LT(top_work, 0.2 * t.subtree_work[0]) << "seed " << seed;
  }
}

// One thread: nothing to gain from a top, so the whole tree is one subtree.
TEST(SubtreeSplitTest, OneThreadTakesTheWholeTree) {
  const SubtreeSplit split = Split(MakeTree(50, 7), 1);
  EXPECT_TRUE(split.top.empty());
  ASSERT_EQ(split.subtrees.size(), 1u);
  EXPECT_EQ(split.subtrees[0], std::vector<int>{0});
}

}  // namespace
}  // namespace slamd::core
