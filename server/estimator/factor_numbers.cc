#include "server/estimator/factor_numbers.h"

#include <numeric>
#include <utility>

#include "core/base/check.h"

namespace slamd::server {

int FactorNumbers::Add(const Entry& entry, int slot) {
  if (free_.empty()) {
    entries_.push_back(entry);
    slots_.push_back(slot);
    return static_cast<int>(slots_.size()) - 1;
  }
  const int n = free_.back();
  free_.pop_back();
  entries_[n] = entry;
  slots_[n] = slot;
  return n;
}

void FactorNumbers::Release(int n) {
  slots_[n] = -1;
  entries_[n] = {};
  free_.push_back(n);
}

void FactorNumbers::Remap(std::span<const int> position) {
  for (int& slot : slots_) {
    if (slot < 0) continue;
    SLAMD_CHECK(static_cast<std::size_t>(slot) < position.size() && position[slot] >= 0)
        << "applied factor " << slot << " is not in the rebuilt solver";
    slot = position[slot];
  }
}

void FactorNumbers::Restore(std::vector<Entry> entries) {
  entries_ = std::move(entries);
  slots_.resize(entries_.size());
  std::iota(slots_.begin(), slots_.end(), 0);
  free_.clear();
}

}  // namespace slamd::server
