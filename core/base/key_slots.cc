#include "core/base/key_slots.h"

#include <utility>

#include "core/base/check.h"

namespace slamd::core {

std::size_t KeySlots::Home(Key key) const {
  // splitmix64's finaliser: keys differ in their low (index) and high (symbol, robot) bits, and
  // the mask keeps only low bits, so every bit must reach them.
  std::uint64_t z = key;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return static_cast<std::size_t>(z) & (entries_.size() - 1);
}

int KeySlots::Find(Key key) const {
  if (entries_.empty()) return -1;
  const std::size_t mask = entries_.size() - 1;
  for (std::size_t i = Home(key);; i = (i + 1) & mask) {
    const Entry& e = entries_[i];
    if (e.value < 0) return -1;
    if (e.key == key) return e.value;
  }
}

void KeySlots::Insert(Key key, int value) {
  SLAMD_CHECK(value >= 0) << "KeySlots value " << value << " < 0";
  if (2 * (size_ + 1) > entries_.size()) Grow();
  const std::size_t mask = entries_.size() - 1;
  for (std::size_t i = Home(key);; i = (i + 1) & mask) {
    Entry& e = entries_[i];
    if (e.value < 0) {
      e = {key, value};
      ++size_;
      return;
    }
    SLAMD_CHECK(e.key != key) << "KeySlots: " << KeyToString(key) << " is already present";
  }
}

void KeySlots::Set(Key key, int value) {
  SLAMD_CHECK(value >= 0) << "KeySlots value " << value << " < 0";
  SLAMD_CHECK(!entries_.empty()) << "KeySlots: " << KeyToString(key) << " is absent";
  const std::size_t mask = entries_.size() - 1;
  for (std::size_t i = Home(key);; i = (i + 1) & mask) {
    Entry& e = entries_[i];
    SLAMD_CHECK(e.value >= 0) << "KeySlots: " << KeyToString(key) << " is absent";
    if (e.key == key) {
      e.value = value;
      return;
    }
  }
}

bool KeySlots::Erase(Key key) {
  if (entries_.empty()) return false;
  const std::size_t mask = entries_.size() - 1;
  std::size_t hole = Home(key);
  while (true) {
    if (entries_[hole].value < 0) return false;
    if (entries_[hole].key == key) break;
    hole = (hole + 1) & mask;
  }
  // Backward shift: move up each later entry of the run whose home does not lie in the cyclic
  // range (hole, i], so that every entry stays reachable from its home without tombstones.
  for (std::size_t i = (hole + 1) & mask; entries_[i].value >= 0; i = (i + 1) & mask) {
    const std::size_t home = Home(entries_[i].key);
    const bool stays = hole <= i ? (hole < home && home <= i) : (hole < home || home <= i);
    if (stays) continue;
    entries_[hole] = entries_[i];
    hole = i;
  }
  entries_[hole] = Entry{};
  --size_;
  return true;
}

void KeySlots::Grow() {
  std::vector<Entry> old = std::move(entries_);
  entries_.assign(old.empty() ? 16 : 2 * old.size(), Entry{});
  size_ = 0;
  for (const Entry& e : old) {
    if (e.value >= 0) Insert(e.key, e.value);
  }
}

}  // namespace slamd::core
