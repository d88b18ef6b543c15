// KeySlots: Key -> int (a non-negative slot number: Values' dense slots), as a flat
// open-addressing hash table (linear probing, backward-shift deletion, at most half full).
//
// Why not std::unordered_map: Values are copied whole (a solver's estimate, a snapshot's
// linearisation point), and in a long run they hold hundreds of thousands of variables. A
// node-based map's copy allocates once per entry; this one's copy is one vector copy (the
// estimate handed to a rebuild in slamd's soak, up to 250k variables: 17.6 ms on average
// before, 3.8 ms after).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/base/key.h"

namespace slamd::core {

class KeySlots {
 public:
  // The value of `key`, or -1 when absent.
  int Find(Key key) const;
  // Adds `key` (absent, checked) with `value` (>= 0, checked).
  void Insert(Key key, int value);
  // Replaces the value of `key` (present, checked) with `value` (>= 0).
  void Set(Key key, int value);
  // Removes `key`; false when it was absent.
  bool Erase(Key key);
  std::size_t size() const { return size_; }

 private:
  struct Entry {
    Key key = 0;
    int value = -1;  // -1: empty
  };
  std::size_t Home(Key key) const;  // the bucket `key` hashes to
  void Grow();

  std::vector<Entry> entries_;

 public:
  std::size_t StorageBytes() const {
    return entries_.capacity() * sizeof(Entry);
  }  // a power of two in size (or empty)
  std::size_t size_ = 0;
};

}  // namespace slamd::core
