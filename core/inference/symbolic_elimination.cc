#include "core/inference/symbolic_elimination.h"

#include <algorithm>

#include "core/base/check.h"

namespace slamd::core::internal {

void BuildSymbolicForest(int k, std::span<const int> structure_ptr,
                         std::span<const int> structure_pos, std::span<const int> hessian_ptr,
                         const SupernodeRule& rule, SymbolicForest* forest,
                         SymbolicWorkspace* workspace) {
  SymbolicForest& f = *forest;
  f.first_frontal.clear();
  f.last_frontal.clear();
  f.num_frontals.clear();
  f.sep_begin.clear();
  f.sep_end.clear();
  f.first_child.clear();
  f.next_sibling.clear();
  f.sep_data.clear();
  f.next_frontal.assign(k, -1);
  f.clique_of.assign(k, -1);
  std::vector<int>& head_child = workspace->head_child;
  std::vector<int>& mark = workspace->mark;
  std::vector<int>& gather = workspace->gather;
  head_child.assign(k, -1);
  mark.assign(k, -1);

  // Links clique c under the variable its separator starts with (its parent's frontal).
  auto link_to_parent = [&](int c) {
    if (f.sep_begin[c] == f.sep_end[c]) return;  // a root
    const int p = f.sep_data[f.sep_begin[c]];
    f.next_sibling[c] = head_child[p];
    head_child[p] = c;
  };

  for (int j = 0; j < k; ++j) {
    // 1. Union of the children's separators and j's own structure, minus j. Newly seen
    //    positions go to `gather`; own_new counts those contributed by j's own factors.
    gather.clear();
    mark[j] = j;
    int num_children = 0;
    for (int c = head_child[j]; c != -1; c = f.next_sibling[c]) {
      ++num_children;
      SLAMD_DCHECK(f.sep_data[f.sep_begin[c]] == j) << "child separator must start at parent";
      for (int i = f.sep_begin[c] + 1; i < f.sep_end[c]; ++i) {
        const int p = f.sep_data[i];
        if (mark[p] != j) {
          mark[p] = j;
          gather.push_back(p);
        }
      }
    }
    int own_new = 0;
    for (int i = structure_ptr[j]; i < structure_ptr[j + 1]; ++i) {
      const int p = structure_pos[i];
      SLAMD_DCHECK(p >= j && p < k) << "structure of " << j << " contains " << p;
      if (mark[p] != j) {
        mark[p] = j;
        gather.push_back(p);
        ++own_new;
      }
    }

    // 2. Supernodes. Fundamental: the single child's separator is exactly {j} ∪ sep(j), so j
    //    joins that clique and the clique's separator loses its first entry (j). Relaxed: j's
    //    own factors add a few positions, so the clique's separator becomes sep(j) (written
    //    anew at the end of sep_data). A Hessian factor is an orphan's summary, i.e. another
    //    child: no merge then.
    const bool has_hessians = hessian_ptr[j + 1] > hessian_ptr[j];
    const int only_child = num_children == 1 ? head_child[j] : -1;
    const bool relaxed = only_child >= 0 && own_new <= rule.relaxed_new_variables &&
                         f.num_frontals[only_child] < rule.relaxed_max_frontals;
    if (rule.merge && only_child >= 0 && !has_hessians && (own_new == 0 || relaxed)) {
      const int c = only_child;
      if (own_new == 0) {
        ++f.sep_begin[c];
      } else {
        std::sort(gather.begin(), gather.end());
        f.sep_begin[c] = static_cast<int>(f.sep_data.size());
        f.sep_data.insert(f.sep_data.end(), gather.begin(), gather.end());
        f.sep_end[c] = static_cast<int>(f.sep_data.size());
      }
      f.next_frontal[f.last_frontal[c]] = j;
      f.last_frontal[c] = j;
      ++f.num_frontals[c];
      f.clique_of[j] = c;
      link_to_parent(c);
      continue;
    }

    // 3. A new clique with frontal j; its children are the cliques hanging off j.
    const int c = f.NumCliques();
    std::sort(gather.begin(), gather.end());
    f.first_frontal.push_back(j);
    f.last_frontal.push_back(j);
    f.num_frontals.push_back(1);
    f.sep_begin.push_back(static_cast<int>(f.sep_data.size()));
    f.sep_data.insert(f.sep_data.end(), gather.begin(), gather.end());
    f.sep_end.push_back(static_cast<int>(f.sep_data.size()));
    f.first_child.push_back(head_child[j]);
    f.next_sibling.push_back(-1);
    f.clique_of[j] = c;
    link_to_parent(c);
  }
}

}  // namespace slamd::core::internal
