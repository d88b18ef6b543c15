#include "core/inference/clique.h"

#include <atomic>

#include "core/base/check.h"
#include "core/base/storage.h"

namespace slamd::core {
namespace {

// Next value of Clique::generation(); starts at 1 so that 0 can mean "none" to readers.
std::atomic<std::uint64_t> next_generation{1};

}  // namespace

std::uint64_t Clique::NewGeneration() {
  return next_generation.fetch_add(1, std::memory_order_relaxed);
}

void Clique::Reset(std::span<const int> frontals, std::span<const int> frontal_dims,
                   std::span<const int> separator, std::span<const int> separator_dims) {
  ResetImpl(frontals, frontal_dims, separator, separator_dims, /*zero=*/true);
}

void Clique::ResetForElimination(std::span<const int> frontals, std::span<const int> frontal_dims,
                                 std::span<const int> separator,
                                 std::span<const int> separator_dims) {
  ResetImpl(frontals, frontal_dims, separator, separator_dims, /*zero=*/false);
}

void Clique::ResetImpl(std::span<const int> frontals, std::span<const int> frontal_dims,
                       std::span<const int> separator, std::span<const int> separator_dims,
                       bool zero) {
  SLAMD_DCHECK(!frontals.empty() && frontals.size() == frontal_dims.size())
      << "Clique::Reset: bad frontals";
  generation_ = NewGeneration();
  num_frontals_ = static_cast<int>(frontals.size());
  index_.resize(2 * frontals.size() + 1);
  int offset = 0;
  for (int k = 0; k < num_frontals_; ++k) {
    SLAMD_DCHECK(frontal_dims[k] >= 1) << "Clique::Reset: bad dim";
    index_[k] = frontals[k];
    index_[num_frontals_ + k] = offset;
    offset += frontal_dims[k];
  }
  index_[2 * num_frontals_] = offset;
  if (zero) {
    cached_.Reset(separator, separator_dims);
    AssignReusingStorage(&conditional_, ConditionalDoubles(offset, cached_.Dim()), 0.0);
  } else {
    cached_.Reshape(separator, separator_dims);
    ResizeReusingStorage(&conditional_, ConditionalDoubles(offset, cached_.Dim()));
  }
}

void Clique::RenumberVariables(std::span<const int> new_id) {
  for (int k = 0; k < num_frontals_; ++k) {
    const int v = new_id[index_[k]];
    SLAMD_CHECK(v >= 0) << "Clique: frontal " << index_[k] << " renumbered to " << v;
    index_[k] = v;
  }
  cached_.RenumberVariables(new_id);
  generation_ = NewGeneration();
}

void Clique::ShrinkStorage() {
  index_.shrink_to_fit();
  conditional_.shrink_to_fit();
  children_.shrink_to_fit();
  cached_.ShrinkStorage();
}

void Clique::ReleaseStorage() {
  std::vector<int>{0}.swap(index_);
  num_frontals_ = 0;
  UninitVector<double>().swap(conditional_);
  std::vector<int>().swap(children_);
  cached_ = HessianFactor();
}

}  // namespace slamd::core
