// SplitSubtrees: how a few threads share work on a tree of cliques in which each subtree needs
// nothing from outside it but one boundary value (elimination: the cliques below; marginals:
// the parent's joint). The threads take disjoint subtrees whole, with no synchronisation; the
// cliques above them (the "top") run on one thread, after the subtrees (elimination) or before
// them (marginals).
//
// Starting from the roots, the heaviest subtree is split (its root moves to the top, its
// children become subtrees) while that lowers the estimated time: top + the largest thread load
// when the 4 x threads heaviest subtrees are given out whole (least loaded thread first,
// heaviest first) and the rest is poured in as if divisible. SLAM trees are lopsided (a spine
// with short branches), so this peels cliques off the spine; the search stops kTriesPastBest
// splits after the best one (a wide tree has thousands of subtrees after a few splits, and a
// better split that far on is unlikely). The subtrees are then given to the least loaded
// thread, heaviest first (LPT).
//
// Cost: O(splits · (log subtrees + threads log threads)) plus the final assignment,
// O(subtrees log subtrees).
#pragma once

#include <algorithm>
#include <cstddef>
#include <span>
#include <vector>

namespace slamd::core {

struct SubtreeSplit {
  std::vector<int> top;                    // the cliques above the subtrees, in split order
  std::vector<std::vector<int>> subtrees;  // per thread: the roots of its subtrees
};

// Ids index `work` (a clique's own work) and `subtree_work` (its subtree's); `for_each_child(c,
// f)` calls f(child) for every child of c. threads >= 1.
template <typename ForEachChild>
void SplitSubtrees(std::span<const int> roots, std::span<const double> work,
                   std::span<const double> subtree_work, ForEachChild for_each_child,
                   int threads, SubtreeSplit* out) {
  constexpr std::size_t kTriesPastBest = 64;
  auto lighter = [&](int a, int b) { return subtree_work[a] < subtree_work[b]; };
  std::vector<int> heap(roots.begin(), roots.end());  // the subtrees, a max-heap by work
  double frontier_work = 0.0, top_work = 0.0;
  for (int r : heap) frontier_work += subtree_work[r];
  std::make_heap(heap.begin(), heap.end(), lighter);
  bool any_children = false;
  auto has_children = [&](int c) {
    any_children = false;
    for_each_child(c, [&](int) { any_children = true; });
    return any_children;
  };
  // The estimate reads the heaviest subtrees off the heap best first (a binary heap's children
  // of position i are 2i + 1 and 2i + 2): O(exact log exact), not O(subtrees).
  const std::size_t exact = 4 * static_cast<std::size_t>(threads);
  std::vector<std::size_t> candidates;  // positions in `heap`, a max-heap by their work
  auto heavier_at = [&](std::size_t a, std::size_t b) {
    return subtree_work[heap[a]] < subtree_work[heap[b]];
  };
  std::vector<double> load(threads);
  auto estimate = [&] {
    std::fill(load.begin(), load.end(), 0.0);
    candidates.clear();
    if (!heap.empty()) candidates.push_back(0);
    for (std::size_t taken = 0; taken < exact && !candidates.empty(); ++taken) {
      std::pop_heap(candidates.begin(), candidates.end(), heavier_at);
      const std::size_t i = candidates.back();
      candidates.pop_back();
      *std::min_element(load.begin(), load.end()) += subtree_work[heap[i]];
      for (std::size_t child = 2 * i + 1; child <= 2 * i + 2 && child < heap.size(); ++child) {
        candidates.push_back(child);
        std::push_heap(candidates.begin(), candidates.end(), heavier_at);
      }
    }
    return top_work + std::max(*std::max_element(load.begin(), load.end()),
                               frontier_work / threads);
  };
  std::vector<int> split;
  double best = estimate();
  std::size_t best_splits = 0;
  while (!heap.empty() && has_children(heap.front()) && top_work < best &&
         split.size() < best_splits + kTriesPastBest) {
    std::pop_heap(heap.begin(), heap.end(), lighter);
    const int c = heap.back();
    heap.pop_back();
    split.push_back(c);
    top_work += work[c];
    frontier_work -= subtree_work[c];
    for_each_child(c, [&](int child) {
      heap.push_back(child);
      std::push_heap(heap.begin(), heap.end(), lighter);
      frontier_work += subtree_work[child];
    });
    if (const double t = estimate(); t < best) {
      best = t;
      best_splits = split.size();
    }
  }
  // Undo the splits past the best: their children go back under them, they back to subtrees.
  out->top.assign(split.begin(), split.begin() + best_splits);
  std::vector<int> subtrees(roots.begin(), roots.end());
  for (int c : out->top) {
    subtrees.erase(std::find(subtrees.begin(), subtrees.end(), c));
    for_each_child(c, [&](int child) { subtrees.push_back(child); });
  }
  std::stable_sort(subtrees.begin(), subtrees.end(),
                   [&](int a, int b) { return subtree_work[a] > subtree_work[b]; });
  out->subtrees.assign(threads, {});
  std::fill(load.begin(), load.end(), 0.0);
  for (int c : subtrees) {
    const auto t = std::min_element(load.begin(), load.end()) - load.begin();
    load[t] += subtree_work[c];
    out->subtrees[t].push_back(c);
  }
}

}  // namespace slamd::core
