#include "core/inference/bayes_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <span>
#include <vector>

#include "core/inference/consistency_check.h"
#include "tests/core/inference/random_linear_system.h"

namespace slamd::core {
namespace {

using testing::EliminateAll;
using testing::MakeRandomSystem;
using testing::NaturalOrder;
using testing::RandomLinearSystem;

std::set<int> AsSet(std::span<const int> v) { return {v.begin(), v.end()}; }

TEST(BayesTreeTest, NewAttachDetachFree) {
  BayesTree tree;
  const int a = tree.NewClique();
  const int b = tree.NewClique();
  const int c = tree.NewClique();
  EXPECT_EQ(tree.NumCliques(), 3);
  EXPECT_EQ(AsSet(tree.roots()), (std::set<int>{a, b, c}));
  tree.Attach(b, a);
  tree.Attach(c, a);
  EXPECT_EQ(tree.roots(), std::vector<int>{a});
  EXPECT_EQ(tree.clique(b).parent(), a);
  EXPECT_EQ(tree.clique(a).children(), (std::vector<int>{b, c}));
  EXPECT_EQ(tree.TopDownOrder(), (std::vector<int>{a, b, c}));
  tree.Detach(b);
  EXPECT_EQ(AsSet(tree.roots()), (std::set<int>{a, b}));
  EXPECT_EQ(tree.clique(a).children(), std::vector<int>{c});
  tree.Detach(b);  // no-op for a root
  EXPECT_EQ(tree.roots().size(), 2u);
  // Freeing a leaf unlinks it; its slot is reused by the next clique.
  tree.FreeClique(c);
  EXPECT_FALSE(tree.IsLive(c));
  EXPECT_TRUE(tree.clique(a).children().empty());
  EXPECT_EQ(tree.NumCliques(), 2);
  EXPECT_EQ(tree.NewClique(), c);
  EXPECT_EQ(tree.NumSlots(), 3);
}

TEST(BayesTreeTest, VariableMap) {
  BayesTree tree;
  EXPECT_EQ(tree.CliqueOf(5), BayesTree::kNone);
  EXPECT_EQ(tree.CliqueOf(-1), BayesTree::kNone);
  const int id = tree.NewClique();
  tree.SetCliqueOf(7, id);
  EXPECT_EQ(tree.NumVariables(), 8);
  EXPECT_EQ(tree.CliqueOf(7), id);
  EXPECT_EQ(tree.CliqueOf(3), BayesTree::kNone);
}

// The tree the RemoveTop tests cut: a random 25-variable system eliminated in natural order.
void EliminateExample(BayesTree* tree, EliminationResult* result) {
  const RandomLinearSystem s = MakeRandomSystem(25, 10, false, 9);
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, NaturalOrder(s.NumVars()), tree, result));
}

TEST(BayesTreeTest, RemoveTopReturnsAncestorsAndOrphans) {
  BayesTree tree;
  EliminationResult result;
  ASSERT_NO_FATAL_FAILURE(EliminateExample(&tree, &result));
  const BayesTree before = tree;

  const int v = 5;
  std::vector<int> removed, orphans;
  tree.RemoveTop(std::vector<int>{v, v}, &removed, &orphans);  // a repeat is harmless
  // Expected: the clique of v and all its ancestors.
  std::set<int> expected_cliques;
  for (int c = before.CliqueOf(v); c != BayesTree::kNone; c = before.clique(c).parent()) {
    expected_cliques.insert(c);
  }
  std::set<int> expected_vars, expected_orphans;
  for (int c : expected_cliques) {
    for (int f : before.clique(c).frontals()) expected_vars.insert(f);
    for (int ch : before.clique(c).children()) {
      if (!expected_cliques.count(ch)) expected_orphans.insert(ch);
    }
  }
  EXPECT_EQ(AsSet(removed), expected_vars);
  EXPECT_EQ(removed.size(), expected_vars.size());
  EXPECT_EQ(AsSet(orphans), expected_orphans);
  EXPECT_EQ(tree.NumCliques(), before.NumCliques() - static_cast<int>(expected_cliques.size()));
  for (int x : removed) EXPECT_EQ(tree.CliqueOf(x), BayesTree::kNone);
  for (int o : orphans) {
    EXPECT_EQ(tree.clique(o).parent(), BayesTree::kNone);
    EXPECT_NE(std::find(tree.roots().begin(), tree.roots().end(), o), tree.roots().end());
  }
  // The copy was deep: the original is intact.
  EXPECT_TRUE(CheckConsistency(before).ok());
  EXPECT_EQ(before.NumCliques(), static_cast<int>(result.cliques.size()));
  // Unknown variables are ignored.
  removed.clear();
  orphans.clear();
  tree.RemoveTop(std::vector<int>{1000}, &removed, &orphans);
  EXPECT_TRUE(removed.empty());
}

// iSAM2's undo of a failed update: the removed top comes back exactly (same ids, links,
// frontals, conditionals), and released cliques' slots are reused.
TEST(BayesTreeTest, RestoreRemovedPutsTheTopBackExactly) {
  BayesTree tree;
  EliminationResult result;
  ASSERT_NO_FATAL_FAILURE(EliminateExample(&tree, &result));
  const BayesTree before = tree;
  std::vector<int> removed, orphans;
  tree.RemoveTop(std::vector<int>{5}, &removed, &orphans);
  ASSERT_FALSE(removed.empty());
  ASSERT_FALSE(orphans.empty());
  tree.RestoreRemoved();
  EXPECT_TRUE(CheckConsistency(tree).ok());
  ASSERT_EQ(tree.NumCliques(), before.NumCliques());
  ASSERT_EQ(tree.NumSlots(), before.NumSlots());
  EXPECT_EQ(AsSet(tree.roots()), AsSet(before.roots()));
  for (int v = 0; v < before.NumVariables(); ++v) EXPECT_EQ(tree.CliqueOf(v), before.CliqueOf(v));
  for (int id = 0; id < before.NumSlots(); ++id) {
    ASSERT_EQ(tree.IsLive(id), before.IsLive(id)) << id;
    if (!before.IsLive(id)) continue;
    const Clique& a = tree.clique(id);
    const Clique& b = before.clique(id);
    EXPECT_EQ(a.parent(), b.parent()) << id;
    EXPECT_EQ(AsSet(a.children()), AsSet(b.children())) << id;
    EXPECT_EQ(AsSet(a.frontals()), AsSet(b.frontals())) << id;
    EXPECT_EQ(a.conditional(), b.conditional()) << id;  // bit for bit
  }
  // Released instead: they are gone, and their slots are handed out again.
  tree.RemoveTop(std::vector<int>{5}, &removed, &orphans);
  const int live = tree.NumCliques();
  tree.ReleaseRemoved();
  EXPECT_EQ(tree.NumCliques(), live);
  std::set<int> top;
  for (int c = before.CliqueOf(5); c != BayesTree::kNone; c = before.clique(c).parent()) top.insert(c);
  EXPECT_EQ(top.count(tree.NewClique()), 1u);
}

TEST(BayesTreeTest, ClearKeepsSlotsForReuse) {
  const RandomLinearSystem s = MakeRandomSystem(10, 5, true, 1);
  BayesTree tree;
  EliminationResult result;
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, NaturalOrder(s.NumVars()), &tree, &result));
  const int slots = tree.NumSlots();
  tree.Clear();
  EXPECT_EQ(tree.NumCliques(), 0);
  EXPECT_TRUE(tree.roots().empty());
  EXPECT_EQ(tree.NumVariables(), 0);
  EXPECT_TRUE(CheckConsistency(tree).ok());
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, NaturalOrder(s.NumVars()), &tree, &result));
  EXPECT_EQ(tree.NumSlots(), slots);
  EXPECT_TRUE(CheckConsistency(tree).ok());
}

// A new clique takes the freed slot whose storage fits it most tightly, else the smallest one
// (LIFO reuse gave small cliques large storage and large cliques new storage).
TEST(BayesTreeTest, NewCliqueTakesTheFreedStorageThatFitsBest) {
  BayesTree tree;
  // Three cliques of one 3-dim frontal on separators of 1, 4 and 10 3-dim variables.
  const auto make = [&](int separator_vars) {
    const int id = tree.NewClique();
    std::vector<int> sep(separator_vars), dims(separator_vars, 3);
    for (int k = 0; k < separator_vars; ++k) sep[k] = 100 + k;
    const std::vector<int> frontal{id}, frontal_dims{3};
    tree.mutable_clique(id).ResetForElimination(frontal, frontal_dims, sep, dims);
    EXPECT_GE(tree.clique(id).MatrixCapacity(), Clique::MatrixDoubles(3, 3 * separator_vars));
    return id;
  };
  const int small = make(1), medium = make(4), large = make(10);
  for (int id : {medium, large, small}) tree.FreeClique(id);  // LIFO would give `small` first
  // Fits `medium`, which is not the smallest freed slot, nor the last freed.
  EXPECT_EQ(tree.NewClique(Clique::MatrixDoubles(3, 9)), medium);
  // Larger than any: the smallest freed slot (whose storage is worth least) is the one to grow.
  EXPECT_EQ(tree.NewClique(Clique::MatrixDoubles(6, 60)), small);
  EXPECT_EQ(tree.NewClique(), large);
  EXPECT_EQ(tree.NumSlots(), 3);
  // Trimmed, freed slots hold nothing and are taken in id order.
  for (int id : {large, small}) tree.FreeClique(id);
  tree.TrimStorage();
  EXPECT_LE(tree.clique(small).MatrixCapacity(), 1u);  // an empty factor's constant
  EXPECT_EQ(tree.NewClique(Clique::MatrixDoubles(3, 3)), std::min(small, large));
}

// The free list's bound (ReleaseRemoved): after a large top, the free cliques keep their
// storage while the tops released lately are as large; once they have been small for long, the
// largest give theirs back, down to an empty clique's one double each, where it stops however
// many there are (more here than the bound's floor: it must not take the same clique for ever).
TEST(BayesTreeTest, FreeStorageFollowsTheTopsReleasedLately) {
  BayesTree tree;
  constexpr int kMany = 40000;
  static_assert(kMany > BayesTree::kMinFreeDoubles);
  const auto add = [&](int var) {
    const int id = tree.NewClique();
    const std::vector<int> frontal{var}, dims{1};
    tree.mutable_clique(id).ResetForElimination(frontal, dims, {}, {});
    tree.SetCliqueOf(var, id);
  };
  std::vector<int> vars(kMany), removed, orphans;
  for (int v = 0; v < kMany; ++v) add(vars[v] = v);
  tree.RemoveTop(vars, &removed, &orphans);
  tree.ReleaseRemoved();
  const std::size_t held = tree.clique(0).MatrixCapacity();
  EXPECT_GT(held, 1u);               // kept: the top just released was this large
  for (int k = 0; k < 20000; ++k) {  // small tops: one clique each
    add(kMany);
    tree.RemoveTop(std::vector<int>{kMany}, &removed, &orphans);
    tree.ReleaseRemoved();
  }
  std::size_t kept = 0;
  for (int id = 0; id < tree.NumSlots(); ++id) kept += tree.clique(id).MatrixCapacity();
  EXPECT_LE(kept, static_cast<std::size_t>(kMany) + held);  // one double each, but the last top's
  EXPECT_TRUE(CheckConsistency(tree).ok());
}

}  // namespace
}  // namespace slamd::core
