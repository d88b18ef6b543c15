#include "core/inference/bayes_tree.h"

#include <algorithm>
#include <iterator>
#include <utility>

#include "core/base/check.h"

namespace slamd::core {
namespace {

// About what a std::set node of the free list takes: the pair and the red-black links.
constexpr std::size_t kSetNodeBytes = 48;

}  // namespace

BayesTree::BayesTree(const BayesTree& other)
    : recent_top_doubles_(other.recent_top_doubles_),
      roots_(other.roots_),
      var_clique_(other.var_clique_) {
  cliques_.reserve(other.cliques_.size());
  for (const auto& c : other.cliques_) cliques_.push_back(std::make_unique<Clique>(*c));
  // Keyed by what the copies hold (a copied vector's capacity is its size).
  for (const auto& [unused, id] : other.free_) AddFree(id);
}

BayesTree& BayesTree::operator=(const BayesTree& other) {
  if (this != &other) *this = BayesTree(other);
  return *this;
}

std::vector<int> BayesTree::TopDownOrder() const {
  std::vector<int> order(roots_.begin(), roots_.end());
  order.reserve(NumCliques());
  for (size_t i = 0; i < order.size(); ++i) {
    const Clique& c = *cliques_[order[i]];
    order.insert(order.end(), c.children_.begin(), c.children_.end());
  }
  return order;
}

int BayesTree::NewClique(std::size_t doubles) {
  int id;
  if (!free_.empty()) {
    auto fit = free_.lower_bound({doubles, 0});
    if (fit == free_.end()) fit = free_.begin();
    id = fit->second;
    free_doubles_ -= fit->first;
    free_.erase(fit);
  } else {
    id = NumSlots();
    cliques_.push_back(std::make_unique<Clique>());
  }
  Clique& c = *cliques_[id];
  c.live_ = true;
  c.parent_ = kNone;
  c.children_.clear();
  AddRoot(id);
  return id;
}

void BayesTree::FreeClique(int id) {
  SLAMD_CHECK(IsLive(id)) << "FreeClique: clique " << id << " is not live";
  Clique& c = *cliques_[id];
  SLAMD_CHECK(c.children_.empty()) << "FreeClique: clique " << id << " has children";
  Detach(id);
  RemoveRoot(id);
  for (int v : c.frontals()) {
    if (CliqueOf(v) == id) var_clique_[v] = kNone;
  }
  c.live_ = false;
  AddFree(id);
}

void BayesTree::Attach(int child, int parent) {
  SLAMD_CHECK(IsLive(child) && IsLive(parent) && child != parent)
      << "Attach: bad cliques " << child << " -> " << parent;
  Clique& c = *cliques_[child];
  SLAMD_CHECK(c.parent_ == kNone) << "Attach: clique " << child << " already has a parent";
  RemoveRoot(child);
  c.parent_ = parent;
  cliques_[parent]->children_.push_back(child);
}

void BayesTree::Detach(int child) {
  Clique& c = *cliques_[child];
  if (c.parent_ == kNone) return;
  std::vector<int>& siblings = cliques_[c.parent_]->children_;
  siblings.erase(std::find(siblings.begin(), siblings.end(), child));
  c.parent_ = kNone;
  AddRoot(child);
}

void BayesTree::SetCliqueOf(int var, int id) {
  SLAMD_CHECK(var >= 0) << "SetCliqueOf: negative variable id";
  if (var >= NumVariables()) var_clique_.resize(var + 1, kNone);
  var_clique_[var] = id;
}

void BayesTree::RemoveTop(std::span<const int> vars, std::vector<int>* removed_frontals,
                          std::vector<int>* orphans) {
  ReleaseRemoved();
  // 1. Mark the cliques of `vars` and their ancestors (stop at already marked ones: O(top)).
  std::vector<int> removed;
  for (int v : vars) {
    for (int c = CliqueOf(v); c != kNone && !cliques_[c]->marked_; c = cliques_[c]->parent_) {
      cliques_[c]->marked_ = true;
      removed.push_back(c);
    }
  }
  // 2. Children that survive become detached roots (orphans).
  for (int id : removed) {
    for (int child : cliques_[id]->children_) {
      Clique& ch = *cliques_[child];
      if (ch.marked_) continue;
      ch.parent_ = kNone;
      AddRoot(child);
      orphans->push_back(child);
    }
  }
  // 3. Take the removed cliques out (kept aside with their links for RestoreRemoved). Their
  //    parents are removed too, so no sibling lists to edit.
  for (int id : removed) {
    Clique& c = *cliques_[id];
    c.marked_ = false;
    const int begin = static_cast<int>(removed_children_.size());
    removed_children_.insert(removed_children_.end(), c.children_.begin(), c.children_.end());
    removed_.push_back({id, c.parent_, begin, static_cast<int>(removed_children_.size())});
    c.children_.clear();
    c.parent_ = kNone;
    RemoveRoot(id);
    for (int v : c.frontals()) {
      removed_frontals->push_back(v);
      if (CliqueOf(v) == id) var_clique_[v] = kNone;
    }
    c.live_ = false;
  }
}

void BayesTree::RestoreRemoved() {
  for (const Removed& r : removed_) {
    Clique& c = *cliques_[r.id];
    SLAMD_CHECK(!c.live_) << "RestoreRemoved: slot " << r.id << " was reused";
    c.live_ = true;
    c.parent_ = r.parent;
    if (r.parent == kNone) AddRoot(r.id);
    for (int v : c.frontals()) SetCliqueOf(v, r.id);
    const auto children = std::span<const int>(removed_children_).subspan(
        r.children_begin, r.children_end - r.children_begin);
    for (int child : children) {
      Clique& ch = *cliques_[child];
      SLAMD_CHECK(ch.parent_ == kNone || ch.parent_ == r.id)
          << "RestoreRemoved: child " << child << " was attached elsewhere";
      RemoveRoot(child);  // an orphan (a detached root); no-op for a removed child
      ch.parent_ = r.id;
    }
    c.children_.assign(children.begin(), children.end());
  }
  removed_.clear();
  removed_children_.clear();
}

void BayesTree::RemovedEliminationOrder(std::vector<int>* order) {
  order->clear();
  // Top-down from the detached roots through the detached children (orphans are live), then
  // reversed: every clique after its descendants. removed_index_: slot -> index in removed_,
  // -1 between calls.
  removed_index_.resize(NumSlots(), -1);
  for (int i = 0; i < static_cast<int>(removed_.size()); ++i) removed_index_[removed_[i].id] = i;
  std::vector<int>& top_down = removed_order_;
  top_down.clear();
  for (int i = 0; i < static_cast<int>(removed_.size()); ++i) {
    if (removed_[i].parent == kNone) top_down.push_back(i);
  }
  for (std::size_t k = 0; k < top_down.size(); ++k) {
    const Removed& r = removed_[top_down[k]];
    for (int j = r.children_begin; j < r.children_end; ++j) {
      const int child = removed_index_[removed_children_[j]];
      if (child >= 0) top_down.push_back(child);
    }
  }
  for (const Removed& r : removed_) removed_index_[r.id] = -1;
  SLAMD_CHECK(top_down.size() == removed_.size())
      << "RemovedEliminationOrder: detached cliques " << removed_.size() << ", reached "
      << top_down.size();
  for (auto it = top_down.rbegin(); it != top_down.rend(); ++it) {
    const std::span<const int> frontals = cliques_[removed_[*it].id]->frontals();
    order->insert(order->end(), frontals.begin(), frontals.end());
  }
}

void BayesTree::ReleaseRemoved() {
  if (removed_.empty()) return;
  double top = 0.0;
  for (const Removed& r : removed_) {
    top += static_cast<double>(cliques_[r.id]->MatrixCapacity());
    AddFree(r.id);
  }
  removed_.clear();
  removed_children_.clear();
  recent_top_doubles_ = std::max(top, kFreeDecay * recent_top_doubles_);
  BoundFree(2.0 * recent_top_doubles_ + static_cast<double>(kMinFreeDoubles));
}

void BayesTree::AddFree(int id) {
  const std::size_t capacity = cliques_[id]->MatrixCapacity();
  free_.emplace(capacity, id);
  free_doubles_ += capacity;
}

void BayesTree::BoundFree(double limit) {
  while (static_cast<double>(free_doubles_) > limit && !free_.empty()) {
    const auto [capacity, id] = *std::prev(free_.end());
    cliques_[id]->ReleaseStorage();
    // The largest holds no more than an empty clique's few doubles: so does every other.
    if (cliques_[id]->MatrixCapacity() >= capacity) break;
    free_doubles_ -= capacity;
    free_.erase(std::prev(free_.end()));
    AddFree(id);
  }
}

void BayesTree::Clear() {
  ReleaseRemoved();
  for (int id = 0; id < NumSlots(); ++id) {
    Clique& c = *cliques_[id];
    if (!c.live_) continue;
    c.live_ = false;
    c.parent_ = kNone;
    c.root_slot_ = kNone;
    c.children_.clear();
    AddFree(id);
  }
  roots_.clear();
  var_clique_.clear();
}

void BayesTree::AddRoot(int id) {
  Clique& c = *cliques_[id];
  if (c.root_slot_ != kNone) return;
  c.root_slot_ = static_cast<int>(roots_.size());
  roots_.push_back(id);
}

void BayesTree::RemoveRoot(int id) {
  Clique& c = *cliques_[id];
  if (c.root_slot_ == kNone) return;
  // Swap-remove: O(1), root order is not meaningful.
  const int last = roots_.back();
  roots_[c.root_slot_] = last;
  cliques_[last]->root_slot_ = c.root_slot_;
  roots_.pop_back();
  c.root_slot_ = kNone;
}

void BayesTree::RenumberVariables(std::span<const int> new_id, int num_vars) {
  SLAMD_CHECK(removed_.empty()) << "RenumberVariables between RemoveTop and its release";
  for (const std::unique_ptr<Clique>& c : cliques_) {
    if (c->live_) c->RenumberVariables(new_id);
  }
  std::vector<int> var_clique(num_vars, kNone);
  for (int v = 0; v < NumVariables(); ++v) {
    if (new_id[v] >= 0) {
      var_clique[new_id[v]] = var_clique_[v];
    } else {
      SLAMD_CHECK(var_clique_[v] == kNone)
          << "RenumberVariables drops variable " << v << ", frontal in clique " << var_clique_[v];
    }
  }
  var_clique_ = std::move(var_clique);
}

void BayesTree::StorageBytes(std::size_t* live, std::size_t* free) const {
  *live = cliques_.capacity() * sizeof(cliques_[0]) + var_clique_.capacity() * sizeof(int) +
          roots_.capacity() * sizeof(int) +
          (removed_index_.capacity() + removed_order_.capacity()) * sizeof(int);
  *live += free_.size() * kSetNodeBytes;
  *free = 0;
  for (const std::unique_ptr<Clique>& c : cliques_) {
    (c->live_ ? *live : *free) += c->StorageBytes() + (c->live_ ? sizeof(Clique) : 0);
  }
}

void BayesTree::TrimStorage() {
  SLAMD_CHECK(removed_.empty()) << "TrimStorage between RemoveTop and its release";
  for (const std::unique_ptr<Clique>& c : cliques_) {
    if (c->live_) {
      c->ShrinkStorage();
    } else {
      c->ReleaseStorage();
    }
  }
  std::vector<int>().swap(removed_index_);
  std::vector<int>().swap(removed_order_);
  // Rekeyed by what the released slots now hold (as the copy constructor does).
  free_doubles_ = 0;
  for (const auto& [unused, id] : std::exchange(free_, {})) AddFree(id);
}

}  // namespace slamd::core
