// BayesTree: the cliques produced by eliminating a linearised factor graph, and the map from each
// variable to the clique where it is frontal (Kaess et al., iSAM2, IJRR 2012, §III).
//
// Ownership: the tree owns its cliques and addresses them by int ids in [0, NumSlots()). Freed
// ids go to a free list and are reused by NewClique() together with their storage, so removing
// and re-creating the top of the tree (iSAM2's steady state) allocates nothing once warm.
// Ids of freed cliques are stale: do not keep them across RemoveTop()/FreeClique().
//
// Invariants (checked by CheckConsistency in consistency_check.h): every live clique with no
// parent is in roots(); parent/children links agree; a child's separator is contained in its
// parent's frontals and separator; every variable is frontal in exactly one clique, which
// CliqueOf() returns. Between RemoveTop() and re-attaching the orphans the running intersection
// is temporarily broken (orphans are roots with non-empty separators); CheckConsistency reports it.
//
// Thread safety: const methods may run concurrently; mutation must be exclusive.
#pragma once

#include <memory>
#include <set>
#include <span>
#include <vector>

#include "core/inference/clique.h"

namespace slamd::core {

class BayesTree {
 public:
  static constexpr int kNone = Clique::kNone;

  BayesTree() = default;
  // Deep copies (iSAM2 may keep a copy to roll back a failed update).
  BayesTree(const BayesTree& other);
  BayesTree& operator=(const BayesTree& other);
  BayesTree(BayesTree&&) = default;
  BayesTree& operator=(BayesTree&&) = default;

  // --- Queries
  // ------------------------------------------------------------------------------------ Size of
  // the variable -> clique map (ids the tree has seen; some may map to kNone).
  int NumVariables() const { return static_cast<int>(var_clique_.size()); }
  // The clique where `var` is frontal, or kNone (unknown or not eliminated).
  int CliqueOf(int var) const {
    return var >= 0 && var < NumVariables() ? var_clique_[var] : kNone;
  }
  int NumCliques() const {
    return static_cast<int>(cliques_.size() - free_.size() - removed_.size());
  }
  int NumSlots() const { return static_cast<int>(cliques_.size()); }
  bool IsLive(int id) const { return id >= 0 && id < NumSlots() && cliques_[id]->live_; }
  const Clique& clique(int id) const { return *cliques_[id]; }
  // Mutable access to a clique's matrices and structure (not its links).
  Clique& mutable_clique(int id) { return *cliques_[id]; }
  // Cliques without a parent (one per connected component, plus detached orphans).
  const std::vector<int>& roots() const { return roots_; }
  // Live clique ids, parents before children (roots first, then breadth-first).
  std::vector<int> TopDownOrder() const;

  // --- Mutation (elimination and iSAM2)
  // ----------------------------------------------------------- A live, childless root clique with
  // empty structure (fill it with Clique::Reset()). Reuses a freed slot and its storage when there
  // is one: the one whose matrices hold the fewest doubles >= `doubles` (what the clique will
  // need, Clique::MatrixDoubles), else the one that holds the fewest. Taking freed slots in any
  // order (LIFO) gave small cliques large storage and large cliques new storage: on a bundle
  // adjustment re-eliminated each step, the free list grew to 1.6x the storage in use.
  int NewClique(std::size_t doubles = 0);
  // Frees a childless clique: unlinks it from its parent (or the roots), and maps its frontals
  // to kNone. Precondition (SLAMD_CHECK): live, no children.
  void FreeClique(int id);
  // Makes the root `child` a child of `parent`. Preconditions (SLAMD_CHECK): both live,
  // child != parent, child is a root.
  void Attach(int child, int parent);
  // Makes `child` a root (unlinks it from its parent). No-op for a root.
  void Detach(int child);
  // Records that `var` is frontal in clique `id` (kNone to clear). Grows the map as needed.
  void SetCliqueOf(int var, int id);

  // iSAM2's "remove top" (Alg. 4/5 of the paper): removes every clique that holds one of `vars`
  // as a frontal, and all their ancestors. Appends the frontals of the removed cliques to
  // *removed_frontals (they must be re-eliminated) and the roots of the subtrees left behind to
  // *orphans (now detached roots whose cached factors summarise them; re-attach them under the
  // new cliques, see EliminationResult::hessian_cliques). Variables not in the tree are ignored.
  // Cost: O(removed cliques + their children).
  // The removed cliques are kept aside (not reused) until ReleaseRemoved() or RestoreRemoved().
  void RemoveTop(std::span<const int> vars, std::vector<int>* removed_frontals,
                 std::vector<int>* orphans);
  // Undo of the last RemoveTop (iSAM2 rolling back an update that failed to re-eliminate):
  // puts the removed cliques back exactly as they were, with their parents, children and
  // frontals, re-attaching the orphans. Precondition: the orphans are detached roots again and
  // every clique created since has been freed (Eliminator::Eliminate frees its own on failure).
  // Exact, so it cannot fail where a re-elimination in a new order could (ill-conditioning).
  void RestoreRemoved();
  // The frontals of the cliques the last RemoveTop detached, each clique's after those of its
  // detached descendants and in its own order: an order that eliminates them into the cliques
  // they were, with the same pivots. Read before ReleaseRemoved, to rebuild the top later.
  void RemovedEliminationOrder(std::vector<int>* order);
  // Frees the cliques kept by the last RemoveTop (the update succeeded). RemoveTop and Clear
  // call it first. The storage the free list keeps for reuse is then bounded by twice the
  // largest top removed lately (a maximum decaying by kFreeDecay per top) and kMinFreeDoubles:
  // the largest free cliques give theirs back. Otherwise a rare large re-elimination (a batch
  // step, a relinearisation of most variables) left its storage to the free list for good, and
  // in a lifelong run the list ratcheted up to 4x the tree in use.
  void ReleaseRemoved();
  static constexpr double kFreeDecay = 0.999;
  static constexpr std::size_t kMinFreeDoubles = std::size_t{1} << 15;  // 256 KiB

  // Bytes allocated by the cliques in use (`live`) and by those kept for reuse (free slots and
  // the last RemoveTop's), with the tree's own vectors in `live`; for memory reports.
  void StorageBytes(std::size_t* live, std::size_t* free) const;
  // Memory at rest: the cliques in use keep only what they hold, freed ones nothing (the next
  // updates allocate what they need again). Not between RemoveTop and its release (checked).
  void TrimStorage();

  // Removes all cliques (keeping their storage for reuse) and clears the variable map.
  void Clear();

  // Renames variable v to new_id[v] in every live clique and in the variable map, which keeps
  // num_vars entries; new_id[v] < 0 drops v, which must be frontal nowhere (checked). Not
  // between RemoveTop and ReleaseRemoved/RestoreRemoved (checked). O(cliques + variables).
  void RenumberVariables(std::span<const int> new_id, int num_vars);

 private:
  friend class BayesTreeTestPeer;  // tests corrupt links to exercise CheckConsistency

  void AddRoot(int id);
  void RemoveRoot(int id);
  void AddFree(int id);
  // Gives back the storage of the largest free cliques until the free list keeps at most
  // `limit` doubles.
  void BoundFree(double limit);

  // A clique taken out by RemoveTop, with its links at that time (its children in
  // removed_children_[children_begin, children_end): one pooled array, no allocation per update).
  struct Removed {
    int id;
    int parent;
    int children_begin;
    int children_end;
  };
  std::vector<Removed> removed_;
  std::vector<int> removed_children_;
  // RemovedEliminationOrder's scratch (slot -> index in removed_, -1 between calls; the order).
  std::vector<int> removed_index_, removed_order_;

  std::vector<std::unique_ptr<Clique>> cliques_;
  // Freed slots by (MatrixCapacity when freed, id): ordered, so the choice is deterministic.
  std::set<std::pair<std::size_t, int>> free_;
  std::size_t free_doubles_ = 0;     // Σ of free_'s capacities
  double recent_top_doubles_ = 0.0;  // the largest top released lately (decaying)
  std::vector<int> roots_;       // live cliques with parent kNone
  std::vector<int> var_clique_;  // variable id -> clique id or kNone
};

}  // namespace slamd::core
