#include "core/inference/variable_index.h"

#include <algorithm>
#include <string>

#include "core/base/check.h"

namespace slamd::core {

void VariableIndex::Reserve(int num_vars) {
  if (num_vars > NumVariables()) factors_.resize(num_vars);
}

Status VariableIndex::AddFactor(int factor, std::span<const int> vars) {
  if (factor < 0) return InvalidArgument("VariableIndex: negative factor index");
  int max_var = -1;
  for (size_t i = 0; i < vars.size(); ++i) {
    if (vars[i] < 0) return InvalidArgument("VariableIndex: negative variable id");
    for (size_t j = 0; j < i; ++j) {
      if (vars[j] == vars[i]) {
        return InvalidArgument("VariableIndex: factor " + std::to_string(factor) +
                               " lists variable " + std::to_string(vars[i]) + " twice");
      }
    }
    max_var = std::max(max_var, vars[i]);
  }
  Reserve(max_var + 1);
  factor_end_ = std::max(factor_end_, factor + 1);
  for (int v : vars) factors_[v].push_back(factor);
  num_entries_ += static_cast<long>(vars.size());
  return Status::Ok();
}

Status VariableIndex::RemoveFactor(int factor, std::span<const int> vars) {
  // Validate first so a failure leaves the index unchanged.
  for (size_t i = 0; i < vars.size(); ++i) {
    const int v = vars[i];
    if (std::find(vars.begin(), vars.begin() + i, v) != vars.begin() + i) {
      return InvalidArgument("VariableIndex: variable " + std::to_string(v) + " listed twice");
    }
    const std::span<const int> list = FactorsOf(v);
    if (std::find(list.begin(), list.end(), factor) == list.end()) {
      return NotFound("VariableIndex: factor " + std::to_string(factor) + " is not on variable " +
                      std::to_string(v));
    }
  }
  for (int v : vars) {
    std::vector<int>& list = factors_[v];
    auto it = std::find(list.begin(), list.end(), factor);
    *it = list.back();
    list.pop_back();
  }
  num_entries_ -= static_cast<long>(vars.size());
  return Status::Ok();
}

void VariableIndex::CollectFactors(std::span<const int> vars, std::vector<int>* out) const {
  out->clear();
  size_t entries = 0;
  for (int v : vars) entries += FactorsOf(v).size();
  if (entries * 8 < static_cast<size_t>(factor_end_)) {
    // A few variables (an odometry step): sort what they list, O(k log k).
    for (int v : vars) {
      const std::span<const int> list = FactorsOf(v);
      out->insert(out->end(), list.begin(), list.end());
    }
    std::sort(out->begin(), out->end());
    out->erase(std::unique(out->begin(), out->end()), out->end());
    return;
  }
  // Much of the graph (a large relinearisation): mark, then scan every factor index, O(factors).
  std::vector<unsigned char> listed(factor_end_, 0);
  for (int v : vars) {
    for (int f : FactorsOf(v)) listed[f] = 1;
  }
  for (int f = 0; f < factor_end_; ++f) {
    if (listed[f]) out->push_back(f);
  }
}

void VariableIndex::RenumberVariables(std::span<const int> new_id, int num_vars) {
  std::vector<std::vector<int>> factors(num_vars);
  for (int v = 0; v < NumVariables(); ++v) {
    if (new_id[v] >= 0) {
      factors[new_id[v]] = std::move(factors_[v]);
    } else {
      SLAMD_CHECK(factors_[v].empty()) << "VariableIndex: dropping variable " << v << ", which has "
                                       << factors_[v].size() << " factor(s)";
    }
  }
  factors_ = std::move(factors);
}

std::size_t VariableIndex::StorageBytes() const {
  std::size_t bytes = factors_.capacity() * sizeof(factors_[0]);
  for (const std::vector<int>& list : factors_) bytes += list.capacity() * sizeof(int);
  return bytes;
}

}  // namespace slamd::core
