// FactorNumbers: the estimator's numbering of the measurements it applied. A number names one
// measurement (its identity, the key the message named first, its dimension) and the solver
// slot of its factor. A released number (its factor left the solver) goes to the next
// measurement, so a run that keeps replacing factors (a shard replaces its neighbours' summaries
// by their next ones) keeps the table the size of its graph. A rebuilt solver numbers
// its factors anew: Remap changes the slots only.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "core/base/key.h"
#include "server/messages/message_spec.h"  // MeasurementId

namespace slamd::server {

class FactorNumbers {
 public:
  struct Entry {
    MeasurementId id;
    core::Key first = 0;  // the key the message named first (loop closures are directed)
    int dim = 0;          // 0: no measurement (a factor a snapshot restored without one)
  };

  int Add(const Entry& entry, int slot);  // a free number, or a new one
  void Release(int n);                    // its factor left the solver
  const Entry& entry(int n) const { return entries_[n]; }
  int slot(int n) const { return slots_[n]; }         // -1 once released
  std::size_t size() const { return slots_.size(); }  // used and free

  // The rebuilt solver's slot of each factor: every used number's slot s becomes position[s]
  // (aborts when a used number's factor is not there).
  void Remap(std::span<const int> position);
  // A restored state: number i is the state's factor i, in solver slot i.
  void Restore(std::vector<Entry> entries);

 private:
  std::vector<Entry> entries_;
  std::vector<int> slots_;
  std::vector<int> free_;
};

}  // namespace slamd::server
