// Values: the current value of every variable, by Key, of mixed types (Pose2, Pose3, Point2,
// Point3). Variables keep their insertion order, and each has a dense slot number
// (0..size()-1) that solvers use to index per-variable arrays without hashing.
//
// Not thread-safe for concurrent mutation; concurrent const access is fine.
#pragma once

#include <vector>

#include "core/base/key.h"
#include "core/base/key_slots.h"
#include "core/base/status.h"
#include "core/variables/variable.h"

namespace slamd::core {

class Values {
 public:
  // Adds a new variable; AlreadyExists if the key is present, InvalidArgument if not finite.
  Status Insert(Key key, const Variable& value);
  // Replaces an existing variable's value; NotFound / InvalidArgument on a type change.
  Status Update(Key key, const Variable& value);
  // Removes a variable (O(size): later slots shift down by one). NotFound if absent.
  Status Erase(Key key);

  bool Contains(Key key) const { return slot_.Find(key) >= 0; }
  std::size_t size() const { return keys_.size(); }
  bool empty() const { return keys_.empty(); }

  // Slot of a key, or -1.
  int SlotOf(Key key) const { return slot_.Find(key); }
  Key KeyAt(int slot) const { return keys_[slot]; }
  const std::vector<Key>& keys() const { return keys_; }

  const Variable& VariableAt(int slot) const { return vars_[slot]; }
  Variable& MutableVariableAt(int slot) { return vars_[slot]; }
  // The variable of a key; the key must exist (checked).
  const Variable& Get(Key key) const;

  // Typed access; the key must exist with that type (checked: callers validate first, e.g.
  // FactorGraph::CheckAgainst). Find returns nullptr instead.
  template <typename T>
  const T& At(Key key) const {
    const T* v = Find<T>(key);
    SLAMD_CHECK(v != nullptr) << "no " << VariableTraits<T>::kName << " named " << KeyToString(key);
    return *v;
  }
  template <typename T>
  const T* Find(Key key) const {
    const int s = SlotOf(key);
    return s < 0 ? nullptr : std::get_if<T>(&vars_[s]);
  }

  VariableType TypeAt(int slot) const { return TypeOf(vars_[slot]); }
  int DimAt(int slot) const { return TangentDim(TypeAt(slot)); }
  // Sum of tangent dimensions.
  int TotalDim() const;

  // Bytes of its storage (key list, values, index), for memory reports.
  std::size_t StorageBytes() const {
    return keys_.capacity() * sizeof(Key) + vars_.capacity() * sizeof(Variable) +
           slot_.StorageBytes();
  }

 private:
  std::vector<Key> keys_;
  std::vector<Variable> vars_;
  KeySlots slot_;  // flat: copying Values is a few vector copies
};

}  // namespace slamd::core
