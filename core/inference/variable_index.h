// VariableIndex: for every variable id, the factors touching it (iSAM2 uses it to find the
// factors a new or relinearised variable affects, and the factors to re-eliminate with the top).
//
// Factors are named by the caller's factor index (any int >= 0, e.g. a slot in the solver's
// factor list); variables by dense ids. Each variable's list is unordered (removal swaps with the
// last entry); CollectFactors returns sorted, duplicate-free results.
// Complexity: AddFactor O(|vars|) amortised, RemoveFactor O(Σ degree of its vars),
// CollectFactors O(k log k) for k listed entries, or O(largest factor index) when that is less.
// Thread safety: const methods may run concurrently.
#pragma once

#include <span>
#include <vector>

#include "core/base/status.h"

namespace slamd::core {

class VariableIndex {
 public:
  VariableIndex() = default;

  // Number of variable ids known (ids 0..NumVariables()-1, some maybe without factors).
  int NumVariables() const { return static_cast<int>(factors_.size()); }
  // Grows to at least num_vars variables (never shrinks).
  void Reserve(int num_vars);

  // Records factor `factor` touching `vars` (each variable at most once). Grows the variable
  // range as needed. kInvalidArgument on a negative id or a variable listed twice.
  Status AddFactor(int factor, std::span<const int> vars);
  // Forgets factor `factor` on `vars` (the list it was added with). kNotFound if one of the
  // variables does not list it; then nothing is changed.
  Status RemoveFactor(int factor, std::span<const int> vars);

  // The factors touching `var` (empty for an unknown id), in no particular order.
  std::span<const int> FactorsOf(int var) const {
    if (var < 0 || var >= NumVariables()) return {};
    return factors_[var];
  }
  // Union of the factors touching any of `vars`, sorted, without duplicates, into *out
  // (overwritten).
  void CollectFactors(std::span<const int> vars, std::vector<int>* out) const;
  // Renames variable v to new_id[v]; the index then knows num_vars ids. new_id[v] < 0 drops v,
  // which must have no factor left (checked). O(variables).
  void RenumberVariables(std::span<const int> new_id, int num_vars);

  // Bytes of its lists (capacity), for memory reports.
  std::size_t StorageBytes() const;

  // Total number of (variable, factor) entries.
  long NumEntries() const { return num_entries_; }

 private:
  std::vector<std::vector<int>> factors_;
  long num_entries_ = 0;
  int factor_end_ = 0;  // one past the largest factor index ever added
};

}  // namespace slamd::core
