// Symbolic multifrontal elimination: the clique structure (frontals, separators, parent links)
// of eliminating k variables in a given order, with fundamental supernodes. Internal to
// core/inference; Eliminator runs it before the numeric phase.
//
// Positions: the variables are named by their position 0..k-1 in the elimination order.
// Input: for each position j, the positions of all variables of the factors whose
// first-eliminated variable is j (CSR; may contain j itself and duplicates). Every factor is
// represented once, at its first variable.
//
// Output (SymbolicForest): cliques numbered in creation order, which is a topological order
// (every clique after all its children). Variable j's separator is
//     sep(j) = (structure(j) ∪ ⋃_{child cliques c of j} sep(c)) \ {j}
// (positions > j, ascending). j is merged into its child clique c when c is its only child, no
// Hessian factor is assigned to j, and either
//   - sep(c) = {j} ∪ sep(j): a fundamental supernode (no fill; R keeps its sparsity inside the
//     dense clique), or
//   - relaxed (SupernodeRule): j's own factors add at most `relaxed_new_variables` positions to
//     sep(c) \ {j}, and c has fewer than `relaxed_max_frontals` frontals. c's earlier frontal
//     rows then hold explicit zeros in those columns: a little more arithmetic, for fewer and
//     larger cliques (less assembly and copying per variable, fewer cliques to solve).
// The clique's separator is always sep(j) of its last frontal j. A Hessian factor stands for an
// orphaned subtree (iSAM2), i.e. a child clique outside this call, so it blocks the merge as a
// second child would (the orphan was not merged with j when it was made either). A clique's
// children all hang off its first frontal, because a later frontal was merged only if the
// clique itself was its single child.
//
// Cost: O(Σ |structure| + Σ |sep| log |sep|), no allocation once the buffers are warm.
#pragma once

#include <span>
#include <vector>

namespace slamd::core::internal {

struct SymbolicForest {
  // Per clique, in creation (children-before-parents) order.
  std::vector<int> first_frontal;  // position of the first (earliest) frontal
  std::vector<int> last_frontal;   // position of the last frontal
  std::vector<int> num_frontals;
  std::vector<int> sep_begin;  // separator = sep_data[sep_begin, sep_end), ascending positions
  std::vector<int> sep_end;
  std::vector<int> first_child;  // first child clique or -1; siblings via next_sibling
  std::vector<int> next_sibling;
  // Per position.
  std::vector<int> next_frontal;  // next frontal of the same clique, or -1
  std::vector<int> clique_of;     // the clique where the position is frontal
  std::vector<int> sep_data;

  int NumCliques() const { return static_cast<int>(first_frontal.size()); }
  int Parent(int c) const {
    return sep_begin[c] == sep_end[c] ? -1 : clique_of[sep_data[sep_begin[c]]];
  }
};

// Scratch buffers reused across calls.
struct SymbolicWorkspace {
  std::vector<int> head_child;  // per position: first clique whose separator starts there
  std::vector<int> mark;        // per position: stamp of the last position that marked it
  std::vector<int> gather;      // separator being built
};

// Builds the forest for k positions. structure_ptr has k + 1 entries (CSR offsets into
// structure_pos); hessian_ptr has k + 1 entries, position j has hessian_ptr[j + 1] -
// hessian_ptr[j] Hessian factors assigned (their variables are in structure(j) too).
// Preconditions (SLAMD_DCHECK): every entry of structure(j) is in [j, k).
// rule.merge = false gives one clique per variable (the elimination tree itself).
struct SupernodeRule {
  bool merge = true;
  int relaxed_new_variables = 0;  // 0: fundamental supernodes only
  int relaxed_max_frontals = 1;
};
void BuildSymbolicForest(int k, std::span<const int> structure_ptr,
                         std::span<const int> structure_pos, std::span<const int> hessian_ptr,
                         const SupernodeRule& rule, SymbolicForest* forest,
                         SymbolicWorkspace* workspace);

}  // namespace slamd::core::internal
