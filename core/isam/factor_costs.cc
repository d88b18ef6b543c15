#include "core/isam/factor_costs.h"

#include <algorithm>
#include <cstring>

namespace slamd::core {
namespace {

// Factors per chunk a thread takes; below two chunks' worth everything stays on the caller.
constexpr int kChunk = 1024;

}  // namespace

void FactorCosts::Clear() {
  keys_.clear();
  encoded_.clear();
  begin_.clear();
  factor_.clear();
  cost_.clear();
}

std::size_t FactorCosts::MemoryUse() const {
  return (keys_.capacity() + next_keys_.capacity()) * sizeof(Key) +
         (encoded_.capacity() + next_encoded_.capacity() + cost_.capacity()) * sizeof(double) +
         (begin_.capacity() + next_begin_.capacity() + todo_.capacity()) * sizeof(int) +
         changed_.capacity() + factor_.capacity() * sizeof(const Factor*);
}

void FactorCosts::Snapshot(const Values& at) {
  const int n = static_cast<int>(at.size());
  next_keys_.clear();
  next_encoded_.clear();
  next_begin_.assign(1, 0);
  changed_.assign(n, 1);
  const int known = static_cast<int>(keys_.size());
  for (int v = 0; v < n; ++v) {
    next_keys_.push_back(at.KeyAt(v));
    EncodeVariable(at.VariableAt(v), &next_encoded_);
    next_begin_.push_back(static_cast<int>(next_encoded_.size()));
    if (v < known && keys_[v] == next_keys_[v] &&
        begin_[v + 1] - begin_[v] == next_begin_[v + 1] - next_begin_[v]) {
      const std::size_t bytes = sizeof(double) * (next_begin_[v + 1] - next_begin_[v]);
      changed_[v] = std::memcmp(encoded_.data() + begin_[v], next_encoded_.data() + next_begin_[v],
                                bytes) != 0;
    }
  }
  keys_.swap(next_keys_);
  encoded_.swap(next_encoded_);
  begin_.swap(next_begin_);
}

void FactorCosts::Evaluate(const Values& at, std::span<const FactorPtr> factors, WorkerPool* pool) {
  next_.store(0, std::memory_order_relaxed);
  const int helpers = std::min(pool->helpers(), static_cast<int>(todo_.size()) / kChunk - 1);
  if (helpers <= 0) {
    EvaluateChunks(at, factors);
    return;
  }
  pool->Run(helpers, [&](int) { EvaluateChunks(at, factors); });
  EvaluateChunks(at, factors);
  pool->Wait();
}

void FactorCosts::EvaluateChunks(const Values& at, std::span<const FactorPtr> factors) {
  const int n = static_cast<int>(todo_.size());
  for (;;) {
    const int begin = next_.fetch_add(kChunk, std::memory_order_relaxed);
    if (begin >= n) return;
    for (int i = begin; i < std::min(n, begin + kChunk); ++i) {
      const int f = todo_[i];
      cost_[f] = factors[f]->Cost(at);  // each task writes its own slots
    }
  }
}

}  // namespace slamd::core
