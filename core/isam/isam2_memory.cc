// Isam2::MemoryUse: where the solver's bytes are (isam2_result.h).
#include "core/isam/isam2.h"

#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace slamd::core {
namespace {

template <typename V>
std::size_t Capacity(const V& v) {
  return v.capacity() * sizeof(typename V::value_type);
}

}  // namespace

Isam2Memory Isam2::MemoryUse() const {
  Isam2Memory m;
  m.linearization_point = theta_.StorageBytes();
  m.variables = static_cast<std::size_t>(delta_.size()) * sizeof(double) + Capacity(dims_) +
                Capacity(var_types_) + Capacity(offsets_) + Capacity(budget_) +
                Capacity(screened_norm2_);
  m.factor_lists = Capacity(factors_) + Capacity(linearized_) + Capacity(curvature_) +
                   Capacity(factor_var_begin_) + Capacity(factor_var_ids_) + Capacity(free_slots_);
  for (const std::vector<int>& slots : free_slots_) m.factor_lists += Capacity(slots);
  for (const JacobianFactor& j : linearized_) m.linearizations += j.StorageBytes();
  m.variable_index = variable_index_.StorageBytes();
  tree_.StorageBytes(&m.tree, &m.tree_free);
  m.scratch = Capacity(mark_) + Capacity(ratio_) + Capacity(step_norms_) + Capacity(probe_mark_) +
              Capacity(over_budget_mark_) + Capacity(removed_frontals_) + Capacity(orphans_) +
              Capacity(elim_vars_) + Capacity(elim_factors_) + Capacity(order_) +
              Capacity(released_order_) + Capacity(relin_factors_) + Capacity(wildfire_.changed) +
              Capacity(wildfire_.scratch) + Capacity(wildfire_.forced) +
              Capacity(wildfire_.visited) + Capacity(undo_.removed_factors) +
              Capacity(undo_.reused_slots) + Capacity(undo_.relinearized) + Capacity(undo_.theta) +
              Capacity(undo_.delta) + Capacity(undo_.relinearized_factors) + costs_.MemoryUse();
  return m;
}

void Isam2::TrimMemory() {
  CheckNoPendingSolve("TrimMemory");
  tree_.TrimStorage();
  for (std::vector<int>* v :
       {&removed_frontals_, &orphans_, &elim_vars_, &elim_factors_, &order_, &released_order_,
        &relin_factors_, &over_budget_, &screened_, &probe_factors_}) {
    std::vector<int>().swap(*v);
  }
#ifdef __GLIBC__
  ::malloc_trim(0);  // glibc keeps freed small blocks in its arenas otherwise
#endif
}

}  // namespace slamd::core
